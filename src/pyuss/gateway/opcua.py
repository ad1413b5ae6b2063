"""The OPC UA face: an asyncua server with one object per drive.

Address space (namespace ``urn:pyuss:gateway``; string node ids, ``BUS`` and ``DRIVE`` the
configured names)::

    Objects/USS                                   ns=N;s=USS
      BUS                                         ns=N;s=BUS
        DRIVE                                     ns=N;s=BUS.DRIVE
          Address            UInt16               ns=N;s=BUS.DRIVE.Address
          StatusWord         UInt16               ...DRIVE.StatusWord
          State              String               ...DRIVE.State ("operation enabled", ...)
          Status/<bit>       Boolean              ...DRIVE.Status.ready_to_switch_on ...
          Actual/<key>       Double, unit         ...DRIVE.Actual.main (EngineeringUnits)
          ActualPercent/<key> Double, %           ...DRIVE.ActualPercent.main
          ControlWord        UInt16, writable     ...DRIVE.ControlWord
          Setpoint/<key>     Double, writable     ...DRIVE.Setpoint.main (EngineeringUnits)
          SetpointPercent/<key> Double, writable  ...DRIVE.SetpointPercent.main
          Parameters/<P107>  Double, unit         ...DRIVE.Parameters.P107 (writable if the
                                                  parameter is; a read value, NaN until read)
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

Variables change when the drive's state changes (`pyuss.points.plant`), so subscriptions get
changes at the bus cycle. Writes to ControlWord and Setpoint return once the telegram
carrying them was answered; writes to parameters and WriteParameter once the job was
answered; a refusal is the status code of `STATUS_CODES`, with the drive's number in
Health/LastErrorNumber.

Access: anonymous clients may read, browse, subscribe and call ReadParameter; writing and
the other methods need a user of ``users`` (``anonymous = "write"`` lets anonymous clients
write too, ``"none"`` refuses them); ``read_only`` refuses every write. Security policies
``None`` (default), ``Basic256Sha256_Sign`` and ``Basic256Sha256_SignAndEncrypt`` (the last
two with the server's certificate and private key).

Why asyncua: the maintained asyncio OPC UA stack for Python (server, client, subscriptions,
security policies).
"""

from __future__ import annotations

import asyncio
import contextvars
import hmac
import logging
import math
from collections.abc import Awaitable, Callable
from typing import Any

from asyncua import Server, ua
from asyncua.crypto.permission_rules import USER_TYPES, PermissionRuleset, User, UserRole
from asyncua.server.address_space import AttributeService
from asyncua.server.user_managers import UserManager

from pyuss import __version__
from pyuss.errors import ConfigError, DriveRefusal, UssError
from pyuss.gateway.config import OpcuaOptions
from pyuss.points.errors import Failure, classify
from pyuss.points.model import STATUS_BIT_NAMES
from pyuss.points.plant import DrivePoints, Plant
from pyuss.points.state import DriveState

__all__ = ["STATUS_CODES", "OpcuaFace", "engineering_units"]

log = logging.getLogger("pyuss.gateway.opcua")

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

_UNECE = {
    "Hz": "HTZ",
    "kHz": "KHZ",
    "A": "AMP",
    "mA": "4K",
    "V": "VLT",
    "W": "WTT",
    "kW": "KWT",
    "s": "SEC",
    "ms": "C26",
    "min": "MIN",
    "h": "HUR",
    "%": "P1",
    "°C": "CEL",
    "K": "KEL",
    "rpm": "RPM",
    "1/min": "RPM",
    "Nm": "NU",
}
"""UNECE Recommendation 20 codes of the units drives use (OPC UA EngineeringUnits)."""

_current_user: contextvars.ContextVar[User | None] = contextvars.ContextVar(
    "pyuss_opcua_user", default=None
)


def engineering_units(unit: str) -> ua.EUInformation:
    """The EUInformation of ``unit`` (UnitId -1 for a unit without a UNECE code)."""
    code = _UNECE.get(unit)
    unit_id = -1
    if code is not None:
        unit_id = 0
        for char in code:
            unit_id = unit_id << 8 | ord(char)
    return ua.EUInformation(
        NamespaceUri="http://www.opcfoundation.org/UA/units/un/cefact",
        UnitId=unit_id,
        DisplayName=ua.LocalizedText(unit),
        Description=ua.LocalizedText(unit),
    )


def status_of(exc: BaseException) -> ua.StatusCode:
    if isinstance(exc, DriveRefusal) and exc.number == 1:
        return ua.StatusCode(ua.StatusCodes.BadNotWritable)
    return ua.StatusCode(STATUS_CODES[classify(exc)])


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


class _Rules(PermissionRuleset):  # type: ignore[misc]
    """Lets every signed-in client use the services; remembers who asks, for the methods."""

    def __init__(self) -> None:
        self._allowed = {ua.NodeId(t) for t in USER_TYPES}

    def check_validity(self, user: User, action_type_id: ua.NodeId, body: Any) -> bool:
        _current_user.set(user)
        return user.role is UserRole.Admin or action_type_id in self._allowed


WriteHandler = Callable[[Any], Awaitable[None]]


_ADMIN = User(role=UserRole.Admin)


class _Writes(AttributeService):  # type: ignore[misc]
    """Client writes to the drives' variables go to the drive first."""

    def __init__(self, aspace: Any, face: OpcuaFace) -> None:
        super().__init__(aspace)
        self.face = face

    async def write(self, params: ua.WriteParameters, user: User = _ADMIN) -> list[ua.StatusCode]:
        results: list[ua.StatusCode] = []
        for item in params.NodesToWrite:
            handler = self.face.write_handlers.get(item.NodeId)
            if handler is None or item.AttributeId != ua.AttributeIds.Value:
                one = ua.WriteParameters(NodesToWrite=[item])
                results.extend(await super().write(one, user))
                continue
            if not self.face.may_write(user):
                results.append(ua.StatusCode(ua.StatusCodes.BadUserAccessDenied))
                continue
            value = item.Value.Value.Value if item.Value and item.Value.Value else None
            try:
                await handler(value)
            except (UssError, ValueError, TypeError) as exc:
                log.info("write to %s refused: %s", item.NodeId.to_string(), exc)
                results.append(status_of(exc))
                continue
            results.append(ua.StatusCode())
        return results


class _DriveNodes:
    """The nodes of one drive and keeping them up to date."""

    def __init__(self, face: OpcuaFace, drive: DrivePoints) -> None:
        self.face = face
        self.drive = drive
        self.nodes: dict[str, tuple[ua.NodeId, ua.VariantType]] = {}
        self.last: dict[str, Any] = {}

    def nid(self, name: str) -> ua.NodeId:
        return ua.NodeId(f"{self.drive.model.bus}.{self.drive.name}{name}", self.face.ns)

    async def build(self, parent: Any) -> None:
        face = self.face
        ns = face.ns
        model = self.drive.model
        obj = await parent.add_object(self.nid(""), ua.QualifiedName(self.drive.name, ns))

        async def var(
            where: Any,
            name: str,
            key: str,
            value: Any,
            vtype: ua.VariantType,
            *,
            unit: str | None = None,
            writer: WriteHandler | None = None,
        ) -> None:
            node = await where.add_variable(
                self.nid(key), ua.QualifiedName(name, ns), ua.Variant(value, vtype)
            )
            if unit is not None:
                await node.add_property(
                    ua.NodeId(f"{self.nid(key).Identifier}.EngineeringUnits", ns),
                    ua.QualifiedName("EngineeringUnits", 0),
                    engineering_units(unit),
                )
            if writer is not None and not face.options.read_only:
                await node.set_writable(True)
                face.write_handlers[node.nodeid] = writer
            self.nodes[key] = (node.nodeid, vtype)
            self.last[key] = value

        async def folder(name: str) -> Any:
            return await obj.add_folder(self.nid(f".{name}"), ua.QualifiedName(name, ns))

        await var(obj, "Address", ".Address", model.address, ua.VariantType.UInt16)
        await var(obj, "StatusWord", ".StatusWord", 0, ua.VariantType.UInt16)
        await var(obj, "State", ".State", "no answer", ua.VariantType.String)
        status = await folder("Status")
        for name in STATUS_BIT_NAMES.values():
            await var(status, name, f".Status.{name}", False, ua.VariantType.Boolean)
        drive = self.drive
        actual = await folder("Actual")
        actual_pc = await folder("ActualPercent")
        for item in model.actual:
            await var(
                actual,
                item.key,
                f".Actual.{item.key}",
                math.nan,
                ua.VariantType.Double,
                unit=model.unit,
            )
            await var(
                actual_pc,
                item.key,
                f".ActualPercent.{item.key}",
                math.nan,
                ua.VariantType.Double,
                unit="%",
            )

        async def control(value: Any) -> None:
            await drive.set_control_word(int(value))

        await var(obj, "ControlWord", ".ControlWord", 0, ua.VariantType.UInt16, writer=control)
        setpoint = await folder("Setpoint")
        setpoint_pc = await folder("SetpointPercent")
        for item in model.setpoints:

            def writer(key: str, unit: str) -> WriteHandler:
                async def write(value: Any) -> None:
                    await drive.set_setpoint(float(value), key, unit=unit)

                return write

            await var(
                setpoint,
                item.key,
                f".Setpoint.{item.key}",
                0.0,
                ua.VariantType.Double,
                unit=model.unit,
                writer=writer(item.key, "value"),
            )
            await var(
                setpoint_pc,
                item.key,
                f".SetpointPercent.{item.key}",
                0.0,
                ua.VariantType.Double,
                unit="%",
                writer=writer(item.key, "percent"),
            )
        params = await folder("Parameters")
        for point in model.parameters:
            meta = point.meta

            def param_writer(pnu: int, index: int | None) -> WriteHandler:
                async def write(value: Any) -> None:
                    await drive.write_parameter(pnu, float(value), index)

                return write

            await var(
                params,
                meta.key,
                f".Parameters.{meta.key}",
                math.nan,
                ua.VariantType.Double,
                unit=meta.unit or None,
                writer=param_writer(meta.pnu, meta.index) if meta.writable else None,
            )
        health = await folder("Health")
        await var(health, "NotSending", ".Health.NotSending", False, ua.VariantType.Boolean)
        await var(health, "Counters", ".Health.Counters", [0] * 16, ua.VariantType.UInt16)
        await var(health, "Answers", ".Health.Answers", 0, ua.VariantType.UInt32)
        await var(health, "Timeouts", ".Health.Timeouts", 0, ua.VariantType.UInt32)
        await var(health, "LastFault", ".Health.LastFault", 0, ua.VariantType.UInt32)
        await var(health, "LastErrorNumber", ".Health.LastErrorNumber", -1, ua.VariantType.Int32)
        await var(health, "LastErrorPnu", ".Health.LastErrorPnu", -1, ua.VariantType.Int32)
        await self._methods(obj)

    async def _methods(self, obj: Any) -> None:
        ns = self.face.ns
        drive = self.drive
        for name in ("On", "Off1", "Off2", "Off3", "Acknowledge"):

            def command(which: str) -> Callable[..., Awaitable[Any]]:
                async def call(parent: ua.NodeId) -> Any:
                    denied = self.face.denied()
                    if denied is not None:
                        return denied
                    try:
                        await drive.command(which)
                    except (UssError, ValueError) as exc:
                        return status_of(exc)
                    return []

                return call

            await obj.add_method(
                self.nid(f".{name}"), ua.QualifiedName(name, ns), command(name.lower()), [], []
            )

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

        def index_of(variant: Any) -> int | None:
            value = int(variant.Value if isinstance(variant, ua.Variant) else variant)
            return None if value < 0 else value

        async def read(parent: ua.NodeId, pnu: Any, index: Any) -> Any:
            try:
                reading = await drive.read_parameter(int(pnu.Value), index_of(index))
            except (UssError, ValueError) as exc:
                return status_of(exc)
            value = math.nan if reading.value is None else float(reading.value)
            return [
                ua.Variant(value, ua.VariantType.Double),
                ua.Variant(reading.meta.unit, ua.VariantType.String),
            ]

        async def write(parent: ua.NodeId, pnu: Any, index: Any, value: Any) -> Any:
            denied = self.face.denied()
            if denied is not None:
                return denied
            try:
                reading = await drive.write_parameter(
                    int(pnu.Value), float(value.Value), index_of(index)
                )
            except (UssError, ValueError) as exc:
                return status_of(exc)
            answered = math.nan if reading.value is None else float(reading.value)
            return [ua.Variant(answered, ua.VariantType.Double)]

        await obj.add_method(
            self.nid(".ReadParameter"),
            ua.QualifiedName("ReadParameter", ns),
            read,
            [pnu_arg, index_arg],
            [value_arg, unit_arg],
        )
        await obj.add_method(
            self.nid(".WriteParameter"),
            ua.QualifiedName("WriteParameter", ns),
            write,
            [pnu_arg, index_arg, value_arg],
            [value_arg],
        )

    def values(self, state: DriveState) -> dict[str, Any]:
        found: dict[str, Any] = {
            ".StatusWord": state.status_word or 0,
            ".State": state.state,
            ".ControlWord": state.control_word & 0xFFFF,
            ".Health.NotSending": state.health.not_sending,
            ".Health.Counters": list(state.health.counters.words()),
            ".Health.Answers": state.health.answers & 0xFFFF_FFFF,
            ".Health.Timeouts": state.health.timeouts & 0xFFFF_FFFF,
            ".Health.LastFault": (state.health.last_fault or 0) & 0xFFFF_FFFF,
        }
        for name, on in state.bits.items():
            found[f".Status.{name}"] = on
        for key, value in state.actual.items():
            found[f".Actual.{key}"] = math.nan if value.value is None else value.value
            found[f".ActualPercent.{key}"] = value.percent
        for key, value in state.setpoints.items():
            found[f".Setpoint.{key}"] = math.nan if value.value is None else value.value
            found[f".SetpointPercent.{key}"] = value.percent
        for key, reading in state.parameters.items():
            found[f".Parameters.{key}"] = (
                math.nan if reading.value is None else float(reading.value)
            )
        refusal = state.health.last_refusal
        if refusal is not None:
            number = 8 if refusal.get("response_id") == 8 else int(refusal.get("number", -1))
            found[".Health.LastErrorNumber"] = number
            found[".Health.LastErrorPnu"] = int(refusal.get("pnu", -1))
        return found

    async def update(self, state: DriveState) -> None:
        server = self.face.server
        for key, value in self.values(state).items():
            if key not in self.nodes:
                continue
            old = self.last.get(key)
            if old == value or (
                isinstance(old, float)
                and isinstance(value, float)
                and math.isnan(old)
                and math.isnan(value)
            ):
                continue
            nodeid, vtype = self.nodes[key]
            self.last[key] = value
            await server.write_attribute_value(nodeid, ua.DataValue(ua.Variant(value, vtype)))


class OpcuaFace:
    """An OPC UA server with the drives of every bus (see the module docstring)."""

    def __init__(self, plant: Plant, options: OpcuaOptions) -> None:
        self.plant = plant
        self.options = options
        self.server = Server(user_manager=_Users(options))
        self.ns = 0
        self.write_handlers: dict[ua.NodeId, WriteHandler] = {}
        self.drives = [_DriveNodes(self, drive) for drive in plant.drives]
        self._removers: list[Callable[[], None]] = []
        self._started = False

    def may_write(self, user: User | None) -> bool:
        if self.options.read_only:
            return False
        if user is None or user.role is UserRole.Admin:
            return True
        if user.role is UserRole.Anonymous:
            return self.options.anonymous == "write"
        return True

    def denied(self) -> ua.StatusCode | None:
        """The status code for a method call the calling user may not make, else None."""
        if self.may_write(_current_user.get()):
            return None
        return ua.StatusCode(ua.StatusCodes.BadUserAccessDenied)

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
        server.iserver.attribute_service = _Writes(server.iserver.aspace, self)
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

    async def close(self) -> None:
        for remove in self._removers:
            remove()
        self._removers.clear()
        if self._started:
            self._started = False
            await self.server.stop()


class _Updater:
    """Writes a drive's changed states into its nodes, one at a time, newest first: a state
    that comes while the previous one is being written waits, and a newer one replaces it."""

    def __init__(self, nodes: _DriveNodes) -> None:
        self.nodes = nodes
        self.task: asyncio.Task[None] | None = None
        self.waiting: DriveState | None = None

    def changed(self, state: DriveState) -> None:
        if self.task is not None and not self.task.done():
            self.waiting = state
            return
        self.task = asyncio.get_running_loop().create_task(self.run(state))

    async def run(self, state: DriveState) -> None:
        current: DriveState | None = state
        while current is not None:
            await self.nodes.update(current)
            current, self.waiting = self.waiting, None


def _build_date() -> Any:
    import datetime

    return datetime.datetime(2024, 1, 1, tzinfo=datetime.UTC)
