"""The OPC UA face: an asyncua server with one object per drive (what it shows and allows,
without a server, is `pyuss.gateway.uanodes`).

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
another's session.
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
import contextvars
import hmac
import logging
import math
import secrets
import time
from collections import deque
from collections.abc import AsyncIterator, Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from asyncua import Server, ua
from asyncua.common.utils import ServiceError
from asyncua.crypto.permission_rules import USER_TYPES, PermissionRuleset, User, UserRole
from asyncua.server.address_space import AttributeService, AttributeValue
from asyncua.server.binary_server_asyncio import BinaryServer, OPCUAProtocol
from asyncua.server.uaprocessor import PublishRequestData, UaProcessor
from asyncua.server.user_managers import UserManager
from asyncua.ua.ua_binary import struct_from_binary

from pyuss import __version__
from pyuss.errors import ConfigError, DriveRefusal, UssError
from pyuss.gateway.options import STOP_WAIT, OpcuaOptions
from pyuss.gateway.uanodes import (
    argument_fault,
    may_change,
    parameter_range,
    percent_range,
    unit_id,
    value_parts,
    value_status,
)
from pyuss.points.drive import DrivePoints
from pyuss.points.errors import Failure, classify
from pyuss.points.model import STATUS_BIT_NAMES
from pyuss.points.plant import Plant
from pyuss.points.state import DriveState

__all__ = ["STATUS_CODES", "OpcuaFace", "engineering_units"]

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

_current_user: contextvars.ContextVar[User | None] = contextvars.ContextVar(
    "pyuss_opcua_user", default=None
)
"""The user of the session whose request is being served (None: no activated session)."""


def engineering_units(unit: str) -> ua.EUInformation:
    """The EUInformation of ``unit`` (UnitId -1 for a unit without a UNECE code)."""
    return ua.EUInformation(
        NamespaceUri="http://www.opcfoundation.org/UA/units/un/cefact",
        UnitId=unit_id(unit),
        DisplayName=ua.LocalizedText(unit),
        Description=ua.LocalizedText(unit),
    )


def status_of(exc: BaseException) -> ua.StatusCode:
    if isinstance(exc, DriveRefusal) and exc.number == 1:
        return ua.StatusCode(ua.StatusCodes.BadNotWritable)
    return ua.StatusCode(STATUS_CODES[classify(exc)])


class _Value(ua.DataValue):  # type: ignore[misc]
    """A drive's value as the face writes it into its node: never changed once made, so a
    client's monitored item keeps it as it is. asyncua keeps a deep copy of every value
    written to a monitored node (``MonitoredItemValues.set_current_datavalue``), which took
    most of the gateway's CPU with a client monitoring a drive's values (some 0.3 ms a
    value)."""

    def __deepcopy__(self, memo: dict[int, Any]) -> _Value:
        return self


def _status(code: int) -> ua.StatusCode:
    return ua.StatusCode(code)


def check_value(variant: Any, vtype: ua.VariantType) -> int | None:
    """Why a written or passed value cannot be taken (a status code), else None: it must be
    a scalar of the node's or argument's own type (Part 4: BadTypeMismatch otherwise, no
    conversion), and a Double a finite number (BadOutOfRange)."""
    if (
        not isinstance(variant, ua.Variant)
        or variant.VariantType != vtype
        or variant.is_array
        or variant.Dimensions
        or variant.Value is None
    ):
        mismatch: int = ua.StatusCodes.BadTypeMismatch
        return mismatch
    if vtype is ua.VariantType.Double and not math.isfinite(variant.Value):
        out_of_range: int = ua.StatusCodes.BadOutOfRange
        return out_of_range
    return None


class _Users(UserManager):  # type: ignore[misc]
    def __init__(self, options: OpcuaOptions) -> None:
        self.options = options

    def get_user(
        self,
        iserver: Any,
        username: str | None = None,
        password: str | None = None,
        certificate: Any = None,
    ) -> User | None:
        if username is None:
            if self.options.anonymous == "none":
                return None
            return User(role=UserRole.Anonymous)
        expected = self.options.users.get(username)
        if expected is None or password is None:
            return None
        if not hmac.compare_digest(expected.encode(), password.encode()):
            return None
        return User(role=UserRole.User, name=username)


_ANONYMOUS = User(role=UserRole.Anonymous)


class _Rules(PermissionRuleset):  # type: ignore[misc]
    """Lets every signed-in client use the services (the face checks writes and calls)."""

    def __init__(self) -> None:
        self._allowed = {ua.NodeId(t) for t in USER_TYPES}

    def check_validity(self, user: User, action_type_id: ua.NodeId, body: Any) -> bool:
        return user.role is UserRole.Admin or action_type_id in self._allowed


_NO_SESSION = {
    ua.NodeId(code)
    for code in (
        ua.ObjectIds.CreateSessionRequest_Encoding_DefaultBinary,
        ua.ObjectIds.FindServersRequest_Encoding_DefaultBinary,
        ua.ObjectIds.GetEndpointsRequest_Encoding_DefaultBinary,
        ua.ObjectIds.RegisterServerRequest_Encoding_DefaultBinary,
        ua.ObjectIds.RegisterServer2Request_Encoding_DefaultBinary,
        ua.ObjectIds.CloseSecureChannelRequest_Encoding_DefaultBinary,
    )
}
_CREATE = ua.NodeId(ua.ObjectIds.CreateSessionRequest_Encoding_DefaultBinary)
_CLOSE = ua.NodeId(ua.ObjectIds.CloseSessionRequest_Encoding_DefaultBinary)
_ACTING = {
    ua.NodeId(ua.ObjectIds.WriteRequest_Encoding_DefaultBinary),
    ua.NodeId(ua.ObjectIds.CallRequest_Encoding_DefaultBinary),
}
"""The services that may change a drive."""
_PUBLISH = ua.NodeId(ua.ObjectIds.PublishRequest_Encoding_DefaultBinary)


class _SessionProcessor(UaProcessor):  # type: ignore[misc]
    """asyncua's processor of one connection, with each request served by the session its
    authentication token names (Part 4 5.6): asyncua's own keeps one session per connection,
    so a second session on the same secure channel (as node-opcua opens them) would lend its
    user to the first. A token of no session of this channel is served by none (refused),
    except ActivateSession, which may move a live session here (Part 4 5.6.3).

    A Write or Call that waited in the connection's queue longer than its TimeoutHint is
    not carried out (BadTimeout, Part 4 7.28): its client has given up on it.

    Publish requests are kept per session too: a subscription's notifications answer a
    Publish of the session that owns it (Part 4 5.13.5), where asyncua's would answer any
    session's on the channel, which the other session's client drops."""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.sessions: dict[ua.NodeId, Any] = {}
        self.arrived: float | None = None
        """When the message being served arrived (`_Protocol`)."""

    def stale(self, requesthdr: Any) -> bool:
        hint = requesthdr.TimeoutHint
        waited = 0.0 if self.arrived is None else time.monotonic() - self.arrived
        return bool(hint) and waited > hint / 1000

    async def _process_message(self, typeid: Any, requesthdr: Any, seqhdr: Any, body: Any) -> Any:
        if typeid in _ACTING and self.stale(requesthdr):
            log.info("a request waited longer than its client waits for it: not carried out")
            raise ServiceError(ua.StatusCodes.BadTimeout)
        if typeid not in _NO_SESSION:
            self.session = self.sessions.get(requesthdr.AuthenticationToken)
        session: Any = self.session if typeid != _CREATE else None
        active = session is not None and session.is_activated()
        _current_user.set(session.user if active else None)
        try:
            if typeid == _PUBLISH and active:
                await self._publish(session, requesthdr, seqhdr, body)
                return True
            return await super()._process_message(typeid, requesthdr, seqhdr, body)
        finally:
            if self.session is not None:
                if typeid == _CLOSE:
                    self.sessions.pop(self.session.auth_token, None)
                else:
                    self.sessions[self.session.auth_token] = self.session
            _current_user.set(None)

    def _owned(self, session: Any) -> dict[int, Any]:
        """The subscriptions of ``session`` by id."""
        subscriptions = self.iserver.subscription_service.subscriptions
        return {i: s for i, s in subscriptions.items() if s.session_id == session.session_id}

    def _owner(self, subscription_id: int) -> ua.NodeId | None:
        """The token of the session of this channel that owns the subscription."""
        sub = self.iserver.subscription_service.subscriptions.get(subscription_id)
        for token, session in self.sessions.items():
            if sub is not None and session.session_id == sub.session_id:
                return token
        return None

    async def _publish(self, session: Any, requesthdr: Any, seqhdr: Any, body: Any) -> None:
        """A Publish request of ``session``, as asyncua serves one, for its own subscriptions
        only."""
        self.session_last_activity = time.monotonic()
        session.touch()
        params = struct_from_binary(ua.PublishParameters, body)
        owned = self._owned(session)
        if not owned:
            raise ServiceError(ua.StatusCodes.BadNoSubscription)
        results: list[ua.StatusCode] = []
        for ack in params.SubscriptionAcknowledgements or []:
            sub = owned.get(ack.SubscriptionId)
            if sub is None:
                results.append(ua.StatusCode(ua.StatusCodes.BadSubscriptionIdInvalid))
            else:
                sub.publish([ack.SequenceNumber])
                results.append(ua.StatusCode())
        data = PublishRequestData(requesthdr=requesthdr, seqhdr=seqhdr, results=results)
        token = requesthdr.AuthenticationToken
        for subscription_id in [i for i in self._publish_results_subs if i in owned]:
            del self._publish_results_subs[subscription_id]
            if await owned[subscription_id].publish_results(data):
                return  # answered at once with what was waiting
        mine = [d for d in self._publish_requests if d.requesthdr.AuthenticationToken == token]
        if len(mine) >= self.publish_request_limit(len(owned)):
            self._publish_requests.remove(mine[0])
            fault = ua.ServiceFault()
            fault.ResponseHeader.ServiceResult = ua.StatusCode(
                ua.StatusCodes.BadTooManyPublishRequests
            )
            self.send_response(mine[0].requesthdr.RequestHandle, mine[0].seqhdr, fault)
        self._publish_requests.append(data)

    def get_publish_request(self, subscription_id: int) -> Any:
        """The oldest Publish request of the subscription's session still waited for; None
        (the subscription waits for the next) without one."""
        owner = self._owner(subscription_id)
        now = time.monotonic()
        for data in list(self._publish_requests):
            if data.requesthdr.AuthenticationToken != owner:
                continue
            self._publish_requests.remove(data)
            if not data.has_timed_out(now):
                return data
            self._send_publish_request_timeout(data)
        self._publish_results_subs[subscription_id] = True
        return None

    async def close(self) -> None:
        others = [s for s in self.sessions.values() if s is not self.session]
        await super().close()
        for session in others:
            self.session = session
            if self._should_close_session_on_transport_loss():
                await session.close_session(True)


class _Protocol(OPCUAProtocol):  # type: ignore[misc]
    """asyncua's connection, serving with `_SessionProcessor` and telling it when each
    message arrived."""

    processor: Any

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.arrivals: deque[float] = deque()

    def data_received(self, data: bytes) -> None:
        now = time.monotonic()
        queued = self.messages.qsize()
        super().data_received(data)
        self.arrivals.extend([now] * (self.messages.qsize() - queued))

    async def _process_one_msg(self, header: Any, buf: Any) -> bool:
        if self.arrivals and self.processor is not None:
            self.processor.arrived = self.arrivals.popleft()
        done: bool = await super()._process_one_msg(header, buf)
        return done

    def connection_made(self, transport: Any) -> None:
        super().connection_made(transport)
        if self.processor is not None:
            processor = _SessionProcessor(self.iserver, self.transport, self.limits)
            processor.set_policies(self.policies)
            self.processor = processor


class _Listener(BinaryServer):  # type: ignore[misc]
    def _make_protocol(self) -> _Protocol:
        return _Protocol(
            iserver=self.iserver,
            policies=self._policies,
            clients=self.clients,
            closing_tasks=self.closing_tasks,
            limits=self.limits,
        )


class _Server(Server):  # type: ignore[misc]
    """asyncua's server listening with `_SessionProcessor` (as ``Server.start`` does), its
    clients' sessions named by random authentication tokens: asyncua numbers them one after
    the other, so a client could name the next client's session in an ActivateSession on its
    own channel and take it over (Part 4 5.6.2: the token is a secret)."""

    async def start(self) -> None:
        iserver = self.iserver
        create = iserver.create_session

        def create_session(name: str, user: User = _ANONYMOUS, external: bool = False) -> Any:
            session = create(name, user=user, external=external)
            if external:
                iserver.unregister_external_session(session)
                session.auth_token = ua.NodeId(secrets.token_bytes(32), 0, ua.NodeIdType.ByteString)
                iserver.register_external_session(session)
            return session

        iserver.create_session = create_session
        await self._setup_server_nodes()
        await self.iserver.start()
        host, port = self._get_bind_socket_info()
        self.bserver = _Listener(self.iserver, host, port, self.limits)
        self.bserver.set_policies(self._policies)
        try:
            await self.bserver.start()
        except Exception:
            await self.iserver.stop()
            raise

    async def stop(self) -> None:
        # The server's clock writes CurrentTime once a second, and asyncua's stop waits for
        # its next tick: up to a second more for every stop of the face. It ends at once.
        clock = self.iserver.time_task
        if clock is not None:
            clock.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await clock
            self.iserver.time_task = None
        await super().stop()


WriteHandler = Callable[[Any], Awaitable[ua.StatusCode | None]]
"""Carries a checked value out; returns the write's status where it is not Good."""


@dataclass(frozen=True, slots=True)
class _Writable:
    """A variable whose writes go to the drive: the handler and the type it takes."""

    handler: WriteHandler
    vtype: ua.VariantType


_ADMIN = User(role=UserRole.Admin)
_ROLES = {UserRole.Anonymous: "anonymous", UserRole.User: "user"}
"""The users `pyuss.gateway.uanodes.may_change` knows (none an admin: clients never are)."""
_READ = ua.AccessLevel.CurrentRead.mask
_READ_WRITE = ua.AccessLevel.CurrentRead.mask | ua.AccessLevel.CurrentWrite.mask


class _Attributes(AttributeService):  # type: ignore[misc]
    """Client writes to the drives' variables go to the drive first, once checked; the
    UserAccessLevel and UserExecutable a session reads say what that session may do."""

    def __init__(self, aspace: Any, face: OpcuaFace) -> None:
        super().__init__(aspace)
        self.face = face

    def read(self, params: ua.ReadParameters) -> list[ua.DataValue]:
        results: list[ua.DataValue] = super().read(params)
        may = self.face.may_write(_current_user.get())
        for number, item in enumerate(params.NodesToRead):
            attribute, node = item.AttributeId, item.NodeId
            if attribute == ua.AttributeIds.UserAccessLevel and node in self.face.writables:
                level = _READ_WRITE if may else _READ
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
                results.append(_status(ua.StatusCodes.BadNotWritable))
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

    async def _write(self, item: ua.WriteValue, writable: _Writable, user: User) -> ua.StatusCode:
        where = item.NodeId.to_string()
        if not self.face.may_write(user):
            return _status(ua.StatusCodes.BadUserAccessDenied)
        if item.IndexRange:
            return _status(ua.StatusCodes.BadWriteNotSupported)  # a scalar, written whole
        value = item.Value
        if value is None or (value.StatusCode is not None and not value.StatusCode.is_good()):
            return _status(ua.StatusCodes.BadWriteNotSupported)  # only good values act
        wrong = check_value(value.Value, writable.vtype)
        if wrong is not None:
            log.info("write to %s refused: %r is not a %s", where, value.Value, writable.vtype)
            return _status(wrong)
        status = await self.face.carry_out(
            lambda: writable.handler(value.Value.Value), f"write to {where}"
        )
        return ua.StatusCode() if status is None else status


@dataclass(frozen=True, slots=True)
class _Method:
    """A drive's method: the object it belongs to, the types of its input arguments, whether
    it changes the drive (a write right needed), what it does with checked values, and its
    name (for the log)."""

    face: OpcuaFace
    parent: ua.NodeId
    inputs: tuple[ua.VariantType, ...]
    changes: bool
    body: Callable[..., Awaitable[Any]]
    name: str

    async def call(self, parent: ua.NodeId, *args: Any) -> Any:
        if parent != self.parent:
            return _status(ua.StatusCodes.BadMethodInvalid)  # another object's method
        if self.changes and not self.face.may_write(_current_user.get()):
            return _status(ua.StatusCodes.BadUserAccessDenied)
        wrong_count = argument_fault(len(args), len(self.inputs))
        if wrong_count is not None:
            return _status(getattr(ua.StatusCodes, wrong_count))
        checks = [check_value(a, t) for a, t in zip(args, self.inputs, strict=True)]
        if any(code is not None for code in checks):
            return ua.CallMethodResult(
                StatusCode=_status(ua.StatusCodes.BadInvalidArgument),
                InputArgumentResults=[ua.StatusCode(code or 0) for code in checks],
            )
        return await self.face.carry_out(
            lambda: self.body(*(a.Value for a in args)),
            f"{self.name} of {self.parent.to_string()}",
        )


class _DriveNodes:
    """The nodes of one drive and keeping them up to date."""

    def __init__(self, face: OpcuaFace, drive: DrivePoints) -> None:
        self.face = face
        self.drive = drive
        self.nodes: dict[str, tuple[ua.NodeId, ua.VariantType]] = {}
        self.last: dict[str, Any] = {}
        self.statuses: dict[str, str | None] = {}
        """The StatusCode each variable was last written with (`value_status`; None: Good,
        as every variable starts)."""
        self.quality: tuple[bool, bool, bool] | None = None
        """Whether the drive had answered, was online and stale, at the last write."""
        self.sources: list[object] = []
        """What each of `value_parts` was last made from."""
        self.reference: float | None = None
        self.ranges: dict[str, tuple[ua.NodeId, float, float]] = {}
        """The EURange of each process value in the drive's unit: its node and the percent
        range it is the reference's share of (set once the reference is known)."""

    def nid(self, name: str) -> ua.NodeId:
        return ua.NodeId(f"{self.drive.model.bus}.{self.drive.name}{name}", self.face.ns)

    @property
    def obj(self) -> ua.NodeId:
        """The drive's object."""
        return self.nid("")

    async def var(
        self,
        where: Any,
        name: str,
        key: str,
        value: Any,
        vtype: ua.VariantType,
        *,
        unit: str | None = None,
        span: tuple[float, float] | None = None,
        writer: WriteHandler | None = None,
    ) -> None:
        """A variable; with a ``unit`` an AnalogItemType (Part 8 5.3.2) with EngineeringUnits
        and EURange ``span`` (None: not known yet, BadWaitingForInitialData)."""
        face = self.face
        ns = face.ns
        nodeid = self.nid(key)
        item = ua.AddNodesItem(
            RequestedNewNodeId=nodeid,
            BrowseName=ua.QualifiedName(name, ns),
            NodeClass=ua.NodeClass.Variable,
            ParentNodeId=where.nodeid,
            ReferenceTypeId=ua.NodeId(ua.ObjectIds.HasComponent),
            TypeDefinition=ua.NodeId(
                ua.ObjectIds.BaseDataVariableType if unit is None else ua.ObjectIds.AnalogItemType
            ),
        )
        attrs = ua.VariableAttributes(
            DisplayName=ua.LocalizedText(name),
            Description=ua.LocalizedText(name),
            DataType=ua.NodeId(vtype.value),
            Value=ua.Variant(value, vtype),
            AccessLevel=_READ,
            UserAccessLevel=_READ,
        )
        if isinstance(value, list):
            attrs.ValueRank = ua.ValueRank.OneDimension
            attrs.ArrayDimensions = [len(value)]
        else:
            attrs.ValueRank = ua.ValueRank.Scalar
        item.NodeAttributes = attrs
        (result,) = await face.server.iserver.isession.add_nodes([item])
        result.StatusCode.check()
        node = face.server.get_node(nodeid)
        if unit is not None:
            await node.add_property(
                ua.NodeId(f"{nodeid.Identifier}.EngineeringUnits", ns),
                ua.QualifiedName("EngineeringUnits", 0),
                engineering_units(unit),
            )
            eu_range = await node.add_property(
                ua.NodeId(f"{nodeid.Identifier}.EURange", ns),
                ua.QualifiedName("EURange", 0),
                ua.Range(Low=0.0, High=0.0),
            )
            if span is None:
                await eu_range.write_value(
                    ua.DataValue(StatusCode=_status(ua.StatusCodes.BadWaitingForInitialData))
                )
            else:
                await eu_range.write_value(ua.Range(Low=span[0], High=span[1]))
        if writer is not None and not face.options.read_only:
            await node.set_writable(True)
            face.writables[nodeid] = _Writable(writer, vtype)
        self.nodes[key] = (nodeid, vtype)
        self.last[key] = value

    async def build(self, parent: Any) -> None:
        face = self.face
        ns = face.ns
        model = self.drive.model
        obj = await parent.add_object(self.obj, ua.QualifiedName(self.drive.name, ns))
        var = self.var

        async def folder(name: str) -> Any:
            return await obj.add_folder(self.nid(f".{name}"), ua.QualifiedName(name, ns))

        def scaled(key: str, percent: tuple[float, float]) -> tuple[float, float] | None:
            """The range in the drive's unit: known at once for a reference in the table,
            else once it was read; remembered so that `update` sets it then."""
            self.ranges[key] = (self.nid(f"{key}.EURange"), *percent)
            if model.unit == "%":
                return percent
            if isinstance(model.reference, float):
                return percent[0] * model.reference / 100, percent[1] * model.reference / 100
            return None

        await var(obj, "Address", ".Address", model.address, ua.VariantType.UInt16)
        await var(obj, "StatusWord", ".StatusWord", 0, ua.VariantType.UInt16)
        await var(obj, "State", ".State", "no answer", ua.VariantType.String)
        await var(obj, "StatusText", ".StatusText", "", ua.VariantType.String)
        status = await folder("Status")
        for name in STATUS_BIT_NAMES.values():
            await var(status, name, f".Status.{name}", False, ua.VariantType.Boolean)
        drive = self.drive
        actual = await folder("Actual")
        actual_pc = await folder("ActualPercent")
        double = ua.VariantType.Double
        for item in model.actual:
            percent = percent_range(item.dword)
            key = f".Actual.{item.key}"
            span = scaled(key, percent)
            await var(actual, item.key, key, math.nan, double, unit=model.unit, span=span)
            key = f".ActualPercent.{item.key}"
            await var(actual_pc, item.key, key, math.nan, double, unit="%", span=percent)

        async def control(value: Any) -> None:
            await drive.set_control_word(int(value))

        await var(obj, "ControlWord", ".ControlWord", 0, ua.VariantType.UInt16, writer=control)
        await var(obj, "ControlText", ".ControlText", "", ua.VariantType.String)
        setpoint = await folder("Setpoint")
        setpoint_pc = await folder("SetpointPercent")
        for item in model.setpoints:

            def writer(key: str, unit: str) -> WriteHandler:
                async def write(value: Any) -> None:
                    await drive.set_setpoint(float(value), key, unit=unit)

                return write

            percent = percent_range(item.dword)
            key = f".Setpoint.{item.key}"
            await var(
                setpoint,
                item.key,
                key,
                0.0,
                double,
                unit=model.unit,
                span=scaled(key, percent),
                writer=writer(item.key, "value"),
            )
            await var(
                setpoint_pc,
                item.key,
                f".SetpointPercent.{item.key}",
                0.0,
                double,
                unit="%",
                span=percent,
                writer=writer(item.key, "percent"),
            )
        params = await folder("Parameters")
        for point in model.parameters:
            meta = point.meta

            def param_writer(pnu: int, index: int | None) -> WriteHandler:
                async def write(value: Any) -> ua.StatusCode | None:
                    reading = await drive.write_parameter(pnu, float(value), index)
                    if reading.written is None:
                        return None
                    return _status(ua.StatusCodes.GoodClamped)  # the drive holds another

                return write

            await var(
                params,
                meta.key,
                f".Parameters.{meta.key}",
                math.nan,
                double,
                unit=meta.unit or None,
                span=parameter_range(meta),
                writer=param_writer(meta.pnu, meta.index) if meta.writable else None,
            )
        health = await folder("Health")
        await var(health, "Online", ".Health.Online", False, ua.VariantType.Boolean)
        await var(health, "NotSending", ".Health.NotSending", False, ua.VariantType.Boolean)
        await var(health, "Counters", ".Health.Counters", [0] * 16, ua.VariantType.UInt16)
        await var(health, "Answers", ".Health.Answers", 0, ua.VariantType.UInt32)
        await var(health, "Timeouts", ".Health.Timeouts", 0, ua.VariantType.UInt32)
        await var(health, "LastFault", ".Health.LastFault", 0, ua.VariantType.UInt32)
        await var(health, "LastErrorNumber", ".Health.LastErrorNumber", -1, ua.VariantType.Int32)
        await var(health, "LastErrorPnu", ".Health.LastErrorPnu", -1, ua.VariantType.Int32)
        await self._methods(obj)

    async def _method(
        self,
        obj: Any,
        name: str,
        body: Callable[..., Awaitable[Any]],
        inputs: Sequence[ua.Argument],
        outputs: Sequence[ua.Argument],
        *,
        changes: bool,
    ) -> None:
        face = self.face
        types = tuple(ua.VariantType(a.DataType.Identifier) for a in inputs)
        method = _Method(face, self.obj, types, changes, body, name)
        node = await obj.add_method(
            self.nid(f".{name}"),
            ua.QualifiedName(name, face.ns),
            method.call,
            list(inputs),
            outputs,
        )
        if changes:
            face.commands.add(node.nodeid)
            if face.options.read_only:
                await node.write_attribute(
                    ua.AttributeIds.Executable, ua.DataValue(ua.Variant(False))
                )

    async def _methods(self, obj: Any) -> None:
        drive = self.drive
        for name in ("On", "Off1", "Off2", "Off3", "Acknowledge"):

            def command(which: str) -> Callable[[], Awaitable[Any]]:
                async def call() -> Any:
                    await drive.command(which)
                    return []

                return call

            await self._method(obj, name, command(name.lower()), [], [], changes=True)

        def argument(name: str, dtype: int, text: str) -> ua.Argument:
            return ua.Argument(
                Name=name,
                DataType=ua.NodeId(dtype),
                ValueRank=-1,
                Description=ua.LocalizedText(text),
            )

        pnu_arg = argument("Pnu", ua.ObjectIds.UInt16, "parameter number")
        index_arg = argument("Index", ua.ObjectIds.Int16, "element, -1 for a simple parameter")
        value_arg = argument("Value", ua.ObjectIds.Double, "value in the parameter's unit")
        unit_arg = argument("Unit", ua.ObjectIds.String, "the parameter's unit")

        def index_of(value: int) -> int | None:
            if value < -1:
                raise ConfigError(
                    f"Index is an element 0.. or -1 for a simple parameter, not {value}"
                )
            return None if value < 0 else value

        async def read(pnu: int, index: int) -> Any:
            reading = await drive.read_parameter(pnu, index_of(index))
            value = math.nan if reading.value is None else float(reading.value)
            return [
                ua.Variant(value, ua.VariantType.Double),
                ua.Variant(reading.meta.unit, ua.VariantType.String),
            ]

        async def write(pnu: int, index: int, value: float) -> Any:
            reading = await drive.write_parameter(pnu, value, index_of(index))
            answered = math.nan if reading.value is None else float(reading.value)
            outputs = [ua.Variant(answered, ua.VariantType.Double)]
            if reading.written is None:
                return outputs
            # the drive holds another value than the one written (it limits or rounds)
            return ua.CallMethodResult(
                StatusCode=_status(ua.StatusCodes.GoodClamped), OutputArguments=outputs
            )

        await self._method(
            obj, "ReadParameter", read, [pnu_arg, index_arg], [value_arg, unit_arg], changes=False
        )
        await self._method(
            obj,
            "WriteParameter",
            write,
            [pnu_arg, index_arg, value_arg],
            [value_arg],
            changes=True,
        )

    def changes(self, state: DriveState) -> list[tuple[ua.NodeId, ua.DataValue]]:
        """The writes that bring the nodes to ``state``: the values that changed (NaN
        stays NaN) or whose StatusCode did (`value_status`: the drive answered for the first
        time, fell silent, answers again), and the EURanges when the reference changed. What
        is returned counts as written."""
        writes = []
        nodes, last, sources, statuses = self.nodes, self.last, self.sources, self.statuses
        quality = (state.answered, state.online, state.stale)
        same_quality = quality == self.quality
        self.quality = quality
        parts = value_parts(state)
        for part, (source, values) in enumerate(parts):
            if same_quality and part < len(sources) and sources[part] == source:
                continue  # the same values as last time
            for key, value in values().items():
                node = nodes.get(key)
                if node is None:
                    continue
                status = value_status(state, key)
                old = last.get(key)
                if statuses.get(key) == status and (
                    old == value
                    or (
                        isinstance(old, float)
                        and isinstance(value, float)
                        and math.isnan(old)
                        and math.isnan(value)
                    )
                ):
                    continue
                nodeid, vtype = node
                last[key] = value
                statuses[key] = status
                code = _status(0 if status is None else getattr(ua.StatusCodes, status))
                writes.append(
                    (
                        nodeid,
                        _Value(
                            ua.Variant(value, vtype),
                            StatusCode=code,
                            SourceTimestamp=state.time,
                            ServerTimestamp=state.time,
                        ),
                    )
                )
        self.sources = [source for source, _values in parts]
        reference = state.reference
        if reference is not None and reference != self.reference and self.drive.model.unit != "%":
            self.reference = reference
            for nodeid, low, high in self.ranges.values():
                span = ua.Range(Low=low * reference / 100, High=high * reference / 100)
                writes.append((nodeid, _Value(ua.Variant(span))))
        return writes

    def value_nodes(self) -> list[ua.NodeId]:
        """The nodes `changes` writes: the variables and the EURanges."""
        return [nodeid for nodeid, _ in self.nodes.values()] + [
            nodeid for nodeid, _low, _high in self.ranges.values()
        ]

    async def write(self, writes: list[tuple[ua.NodeId, ua.DataValue]]) -> None:
        """``writes`` through the server, which tells the clients monitoring them."""
        server = self.face.server
        for nodeid, value in writes:
            await server.write_attribute_value(nodeid, value)

    async def update(self, state: DriveState) -> None:
        await self.write(self.changes(state))


class OpcuaFace:
    """An OPC UA server with the drives of every bus (see the module docstring)."""

    def __init__(self, plant: Plant, options: OpcuaOptions) -> None:
        self.plant = plant
        self.options = options
        self.server = _Server(user_manager=_Users(options))
        self.ns = 0
        self.writables: dict[ua.NodeId, _Writable] = {}
        self.commands: set[ua.NodeId] = set()
        """The methods that change a drive (all but ReadParameter)."""
        self.drives = [_DriveNodes(self, drive) for drive in plant.drives]
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
            [policies[p] for p in self.options.security], permission_ruleset=_Rules()
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

    def _updater(self, nodes: _DriveNodes) -> Callable[[DriveState], object]:
        return _Updater(nodes).changed

    async def carry_out(self, what: Callable[[], Awaitable[T]], where: str) -> T | ua.StatusCode:
        """``what()`` - a checked write or method call - carried out, unless the face is
        stopping (BadShutdown); a stop waits for it (`acting`). A refusal is its status code
        (`status_of`) and one log line naming ``where``."""
        if self.stopping:
            return _status(ua.StatusCodes.BadShutdown)
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


class _Updater:
    """Keeps a drive's nodes at its newest state.

    While no client monitors any of them, a state is only noted: the values are made from
    it when a client reads one (a value callback on each node, which asyncua's
    ``read_attribute_value`` calls), so an answer nobody looks at costs nothing here; a
    value that changed since it was last read then carries the time of the newest state.
    Else the values that changed are written, at once where no client monitors them
    (`_write_at_once`), else through the server in a task, which tells the subscriptions; a
    state that comes while the previous one is being written waits, and a newer one
    replaces it."""

    def __init__(self, nodes: _DriveNodes) -> None:
        self.nodes = nodes
        aspace = nodes.face.server.iserver.aspace
        self.attributes: dict[ua.NodeId, AttributeValue] = {}
        for nodeid in nodes.value_nodes():
            node = aspace.get(nodeid)
            attribute = None if node is None else node.attributes.get(ua.AttributeIds.Value)
            if attribute is not None:
                self.attributes[nodeid] = attribute
        self.values = tuple(self.attributes.values())
        self.task: asyncio.Task[None] | None = None
        self.waiting: DriveState | None = None
        self.pending: DriveState | None = None
        """The state the values are to be made of when read."""
        self.reading = False
        """Whether the nodes make their values when read (their value callbacks are set)."""

    def changed(self, state: DriveState) -> None:
        if self.task is not None and not self.task.done():
            self.waiting = state
            return
        for attribute in self.values:  # (a loop: no generator to step through)
            if attribute.datachange_callbacks:
                break  # a client monitors one of them
        else:
            self.pending = state
            if not self.reading:  # (a write through the server took the callback away)
                self.reading = True
                for attribute in self.values:
                    if attribute.value_setter is None:
                        attribute.value_callback = self.read
            return
        self.reading = False
        self.pending = None
        writes = self.nodes.changes(state)
        if not writes or self._write_at_once(writes):
            return
        self.task = asyncio.get_running_loop().create_task(self.run(writes))

    def read(self, nodeid: ua.NodeId, _attribute: ua.AttributeIds) -> ua.DataValue:
        """A node's value callback: its value, the noted state made into values first."""
        state, self.pending = self.pending, None
        if state is not None:
            for written, value in self.nodes.changes(state):
                self.attributes[written].value = value
        value = self.attributes[nodeid].value
        assert value is not None
        return value

    def _write_at_once(self, writes: list[tuple[ua.NodeId, ua.DataValue]]) -> bool:
        """Store ``writes`` in the address space as its own write does (asyncua's
        ``AddressSpace.write_attribute_value``), without awaiting: possible, and done, when
        no value has a data change callback (no client monitors it) or a setter of its own.
        False: nothing was written, the writes are to go through the server."""
        attributes = self.attributes
        for nodeid, _value in writes:
            attribute = attributes.get(nodeid)
            if (
                attribute is None
                or attribute.datachange_callbacks
                or attribute.value_setter is not None
            ):
                return False
        for nodeid, value in writes:
            attributes[nodeid].value = value
        return True

    async def run(self, writes: list[tuple[ua.NodeId, ua.DataValue]]) -> None:
        while True:
            await self.nodes.write(writes)
            state, self.waiting = self.waiting, None
            if state is None:
                return
            writes = self.nodes.changes(state)


def _build_date() -> Any:
    import datetime

    return datetime.datetime(2024, 1, 1, tzinfo=datetime.UTC)
