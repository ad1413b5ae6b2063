"""The OPC UA face: an asyncua server with one object per drive (what it shows and allows,
without a server, is `pyuss.gateway.uanodes`; a drive's nodes made and kept up to date,
`pyuss.gateway.opcua_nodes`; the server's sessions, `pyuss.gateway.opcua_sessions`). This
module is the face: the server set up and started, the rights of a session checked on every
write and call, a stop that lets what is being carried out finish.

Address space (namespace ``urn:pyuss:gateway``; string node ids, ``BUS`` and ``DRIVE`` the
configured names)::

    Objects/USS                                   ns=N;s=USS
      BUS                                         ns=N;s=BUS
        DRIVE                                     ns=N;s=BUS.DRIVE
          Address            UInt16               ns=N;s=BUS.DRIVE.Address
          StatusWord         UInt16               ...DRIVE.StatusWord
          State              String               ...DRIVE.State ("operation enabled", ...)
          StatusText         String               ...DRIVE.StatusText ("EA40h  switch-on
                                                  inhibited, ...": `pyuss.params.words`)
          Status/<bit>       Boolean              ...DRIVE.Status.ready_to_switch_on ...
          Actual/<key>       Double, unit         ...DRIVE.Actual.main (EngineeringUnits)
          ActualPercent/<key> Double, %           ...DRIVE.ActualPercent.main
          ControlWord        UInt16, writable     ...DRIVE.ControlWord
          ControlText        String               ...DRIVE.ControlText (the word sent, so)
          Setpoint/<key>     Double, writable     ...DRIVE.Setpoint.main (EngineeringUnits)
          SetpointPercent/<key> Double, writable  ...DRIVE.SetpointPercent.main
          Parameters/<P107>  Double, unit         ...DRIVE.Parameters.P107 (writable if the
                                                  parameter is; a read value, NaN until read)
          Health/Online      Boolean              ...DRIVE.Health.Online (the drive
                                                  answers and its bus is online)
          Health/NotSending  Boolean              ...DRIVE.Health.NotSending
          Health/Counters    UInt16[16]           the diagnostic parameters of A 5.2.3
          Health/Answers, Timeouts  UInt32
          Health/LastFault   UInt32               0: none
          Health/LastErrorNumber  Int32           the drive's number of the last refusal
                                                  (-1 none; 8: no write authority, response 8)
          Health/LastErrorPnu     Int32           -1 none
          On(), Off1(), Off2(), Off3(), Acknowledge()
          ReadParameter(Pnu UInt16, Index Int16 = -1) -> (Value Double, Unit String)
          WriteParameter(Pnu UInt16, Index Int16, Value Double) -> Value Double
                                                  (the drive's; GoodClamped where it holds
                                                  another value than the one written)

Variables with a unit (Actual, ActualPercent, Setpoint, SetpointPercent, parameters with a
unit) are AnalogItemType (OPC UA Part 8 5.3.2) with the properties EngineeringUnits (UNECE
code) and EURange: -200 % .. +199.99 % of a 16-bit process word (the reference's share of it
in the drive's unit, set once the reference is known; BadWaitingForInitialData until then),
a parameter's limits from the parameter file, else what its word(s) can carry.

Variables change when the drive's state changes (`pyuss.points.drive`), so subscriptions get
changes at the bus cycle. The values of the drive's answers carry BadWaitingForInitialData
before its first answer, BadNoCommunication while it is offline (its bus's offline rule, or
the bus offline) and UncertainLastUsableValue while it is online but its latest answer was
missed (`pyuss.gateway.uanodes.value_status`), with the time of the answer as
SourceTimestamp.
Writes to ControlWord and Setpoint return once the telegram carrying them was answered;
writes to parameters and WriteParameter once the job was answered; a refusal is the status
code of `STATUS_CODES`, with the drive's number in Health/LastErrorNumber.

Every request is checked whole before anything goes on the line (OPC UA Part 4):

- a written value must be a scalar of the variable's own type (no conversion), else
  BadTypeMismatch; a Double must be finite, else BadOutOfRange; an IndexRange or a value
  whose status is not Good is BadWriteNotSupported; a variable no one writes (StatusWord,
  Actual, a read-only parameter) is BadNotWritable;
- a method call needs its exact number of arguments (BadArgumentsMissing,
  BadTooManyArguments); an argument of another type or a non-finite Double is
  BadInvalidArgument with the argument's own code (BadTypeMismatch, BadOutOfRange) in
  InputArgumentResults; Index below -1 is BadOutOfRange; a drive's method called on another
  object is BadMethodInvalid;
- a Write or Call that waited in the connection's queue longer than its TimeoutHint is not
  carried out (BadTimeout): its client has given up on it.

Access is per session (Part 4 5.6): every request is served by the session its
authentication token names, so several sessions on one secure channel (as node-opcua opens
them) keep their own users and subscriptions; the tokens are random, so no client can name
another's session (`pyuss.gateway.opcua_sessions`).
Anonymous sessions may read, browse, subscribe and call ReadParameter; writing and the other
methods need a user of ``users`` (``anonymous = "write"`` lets anonymous clients write too,
``"none"`` refuses them): BadUserAccessDenied otherwise. The UserAccessLevel and
UserExecutable a session reads say what that session may do (Part 3 5.6.2). ``read_only``
refuses every write and every method but ReadParameter; AccessLevel then says read-only and
Executable is false. Security policies ``None`` (default), ``Basic256Sha256_Sign`` and
``Basic256Sha256_SignAndEncrypt`` (the last two with the server's certificate and private
key).

Why asyncua: the maintained asyncio OPC UA stack for Python (server, client, subscriptions,
security policies).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any, TypeVar

from asyncua import ua
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.address_space import AttributeService

from pyuss import __version__
from pyuss.errors import ConfigError, DriveRefusal, UssError
from pyuss.gateway.opcua_nodes import READ, DriveNodes, Updater, Writable, check_value, status_code
from pyuss.gateway.opcua_sessions import Rules, SessionServer, Users, current_user
from pyuss.gateway.options import STOP_WAIT, OpcuaOptions
from pyuss.gateway.uanodes import may_change
from pyuss.points.errors import Failure, classify
from pyuss.points.plant import Plant
from pyuss.points.state import DriveState

__all__ = ["STATUS_CODES", "OpcuaFace"]

log = logging.getLogger("pyuss.gateway.opcua")
T = TypeVar("T")

STATUS_CODES: dict[Failure, int] = {
    Failure.NOT_FOUND: ua.StatusCodes.BadNotFound,
    Failure.BAD_VALUE: ua.StatusCodes.BadOutOfRange,
    Failure.REFUSED: ua.StatusCodes.BadInvalidState,
    Failure.NO_AUTHORITY: ua.StatusCodes.BadRequestNotAllowed,
    Failure.READ_ONLY: ua.StatusCodes.BadUserAccessDenied,
    Failure.NO_ANSWER: ua.StatusCodes.BadTimeout,
    Failure.UNAVAILABLE: ua.StatusCodes.BadNoCommunication,
}
"""The status code of each class of failure; a refusal with error 1 ("parameter cannot be
changed") is BadNotWritable."""


def status_of(exc: BaseException) -> ua.StatusCode:
    if isinstance(exc, DriveRefusal) and exc.number == 1:
        return ua.StatusCode(ua.StatusCodes.BadNotWritable)
    return ua.StatusCode(STATUS_CODES[classify(exc)])


_ADMIN = User(role=UserRole.Admin)
_ROLES = {UserRole.Anonymous: "anonymous", UserRole.User: "user"}
"""The users `pyuss.gateway.uanodes.may_change` knows (none an admin: clients never are)."""
_READ_WRITE = ua.AccessLevel.CurrentRead.mask | ua.AccessLevel.CurrentWrite.mask


class _Attributes(AttributeService):  # type: ignore[misc]
    """Client writes to the drives' variables go to the drive first, once checked; the
    UserAccessLevel and UserExecutable a session reads say what that session may do."""

    def __init__(self, aspace: Any, face: OpcuaFace) -> None:
        super().__init__(aspace)
        self.face = face

    def read(self, params: ua.ReadParameters) -> list[ua.DataValue]:
        results: list[ua.DataValue] = super().read(params)
        may = self.face.may_write(current_user.get())
        for number, item in enumerate(params.NodesToRead):
            attribute, node = item.AttributeId, item.NodeId
            if attribute == ua.AttributeIds.UserAccessLevel and node in self.face.writables:
                level = _READ_WRITE if may else READ
                results[number] = ua.DataValue(ua.Variant(level, ua.VariantType.Byte))
            elif attribute == ua.AttributeIds.UserExecutable and node in self.face.commands:
                results[number] = ua.DataValue(ua.Variant(may, ua.VariantType.Boolean))
        return results

    async def write(self, params: ua.WriteParameters, user: User = _ADMIN) -> list[ua.StatusCode]:
        results: list[ua.StatusCode] = []
        for item in params.NodesToWrite:
            writable = self.face.writables.get(item.NodeId)
            value = item.AttributeId == ua.AttributeIds.Value
            client = user.role is not UserRole.Admin  # the server itself writes as admin
            if client and value and writable is None and self._read_only_here(item.NodeId):
                results.append(status_code(ua.StatusCodes.BadNotWritable))
                continue
            if writable is None or not value:
                one = ua.WriteParameters(NodesToWrite=[item])
                results.extend(await super().write(one, user))
                continue
            results.append(await self._write(item, writable, user))
        return results

    def _read_only_here(self, node: ua.NodeId) -> bool:
        """A variable of the face's own that no one may write (the whole face read-only
        is BadUserAccessDenied instead, as on the other faces)."""
        face = self.face
        return (
            not face.options.read_only and node.NamespaceIndex == face.ns and node in self._aspace
        )

    async def _write(self, item: ua.WriteValue, writable: Writable, user: User) -> ua.StatusCode:
        where = item.NodeId.to_string()
        if not self.face.may_write(user):
            return status_code(ua.StatusCodes.BadUserAccessDenied)
        if item.IndexRange:
            return status_code(ua.StatusCodes.BadWriteNotSupported)  # a scalar, written whole
        value = item.Value
        if value is None or (value.StatusCode is not None and not value.StatusCode.is_good()):
            return status_code(ua.StatusCodes.BadWriteNotSupported)  # only good values act
        wrong = check_value(value.Value, writable.vtype)
        if wrong is not None:
            log.info("write to %s refused: %r is not a %s", where, value.Value, writable.vtype)
            return status_code(wrong)
        status = await self.face.carry_out(
            lambda: writable.handler(value.Value.Value), f"write to {where}"
        )
        return ua.StatusCode() if status is None else status


class OpcuaFace:
    """An OPC UA server with the drives of every bus (see the module docstring)."""

    def __init__(self, plant: Plant, options: OpcuaOptions) -> None:
        self.plant = plant
        self.options = options
        self.server = SessionServer(user_manager=Users(options))
        self.ns = 0
        self.writables: dict[ua.NodeId, Writable] = {}
        self.commands: set[ua.NodeId] = set()
        """The methods that change a drive (all but ReadParameter)."""
        self.drives = [DriveNodes(self, drive) for drive in plant.drives]
        self._removers: list[Callable[[], None]] = []
        self._started = False
        self.stopping = False
        """The face is stopping: no new write or call is carried out."""
        self._acting = 0
        self._idle = asyncio.Event()
        self._idle.set()

    def may_write(self, user: User | None) -> bool:
        """Whether ``user`` (None: no activated session) may write and call the methods that
        change a drive."""
        role = None if user is None else _ROLES.get(user.role)
        options = self.options
        return may_change(role, anonymous=options.anonymous, read_only=options.read_only)

    async def start(self) -> None:
        server = self.server
        await server.init()
        endpoint = self.options.endpoint
        server.set_endpoint(f"opc.tcp://{endpoint.host}:{endpoint.port}{endpoint.path}")
        server.set_server_name("pyuss USS gateway")
        await server.set_build_info(
            "urn:pyuss:gateway", "pyuss", "pyuss gateway", __version__, "0", _build_date()
        )
        policies = {
            "None": ua.SecurityPolicyType.NoSecurity,
            "Basic256Sha256_Sign": ua.SecurityPolicyType.Basic256Sha256_Sign,
            "Basic256Sha256_SignAndEncrypt": ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
        }
        server.set_security_policy(
            [policies[p] for p in self.options.security], permission_ruleset=Rules()
        )
        tokens: list[type] = [ua.UserNameIdentityToken]
        if self.options.anonymous != "none":
            tokens.append(ua.AnonymousIdentityToken)
        server.set_identity_tokens(tokens)
        if self.options.certificate is not None and self.options.private_key is not None:
            await server.load_certificate(self.options.certificate)
            await server.load_private_key(self.options.private_key)
        server.iserver.attribute_service = _Attributes(server.iserver.aspace, self)
        self.ns = await server.register_namespace(self.options.namespace)
        root = await server.nodes.objects.add_folder(
            ua.NodeId("USS", self.ns), ua.QualifiedName("USS", self.ns)
        )
        buses: dict[str, Any] = {}
        for nodes in self.drives:
            bus = nodes.drive.model.bus
            if bus not in buses:
                buses[bus] = await root.add_object(
                    ua.NodeId(bus, self.ns), ua.QualifiedName(bus, self.ns)
                )
            await nodes.build(buses[bus])
        try:
            await server.start()
        except OSError as exc:
            raise ConfigError(f"opcua {endpoint}: cannot listen there ({exc})") from None
        self._started = True
        for nodes in self.drives:
            await nodes.update(nodes.drive.snapshot())
            self._removers.append(nodes.drive.subscribe(self._updater(nodes)))
        log.info("OPC UA on %s", endpoint)

    def _updater(self, nodes: DriveNodes) -> Callable[[DriveState], object]:
        return Updater(nodes).changed

    async def carry_out(self, what: Callable[[], Awaitable[T]], where: str) -> T | ua.StatusCode:
        """``what()`` - a checked write or method call - carried out, unless the face is
        stopping (BadShutdown); a stop waits for it (`acting`). A refusal is its status code
        (`status_of`) and one log line naming ``where``."""
        if self.stopping:
            return status_code(ua.StatusCodes.BadShutdown)
        try:
            async with self.acting():
                return await what()
        except (UssError, ValueError, TypeError) as exc:
            log.info("%s refused: %s", where, exc)
            return status_of(exc)

    @contextlib.asynccontextmanager
    async def acting(self) -> AsyncIterator[None]:
        """A write or a method call being carried out: a stop waits for it (`close`)."""
        self._acting += 1
        self._idle.clear()
        try:
            yield
        finally:
            self._acting -= 1
            if not self._acting:
                self._idle.set()

    async def close(self) -> None:
        """Stop: new writes and calls get BadShutdown; those being carried out finish and
        are answered (at most `STOP_WAIT` seconds), then the server stops."""
        self.stopping = True
        for remove in self._removers:
            remove()
        self._removers.clear()
        if self._acting:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(STOP_WAIT):
                    await self._idle.wait()
        if self._started:
            self._started = False
            await self.server.stop()


def _build_date() -> Any:
    import datetime

    return datetime.datetime(2024, 1, 1, tzinfo=datetime.UTC)
