"""A drive's object in the OPC UA face's address space (`pyuss.gateway.opcua`): its variables
and methods made (`DriveNodes.build`, the address space of the face's docstring), the checks
of what a client writes or passes (`check_value`, `Method`), and its values kept at the
drive's newest state (`Updater`). What each node shows and allows, without a server, is
`pyuss.gateway.uanodes`.

Variables with a unit are AnalogItemType (OPC UA Part 8 5.3.2) with the properties
EngineeringUnits (UNECE code: `engineering_units`) and EURange. A drive's value, once written
into its node, is never changed (`Value`): asyncua then keeps no deep copy of it per
monitored item. While no client monitors a drive's nodes, a state is only noted and the
values are made when a client reads one; else the values that changed are written, at once
where no client monitors them (`Updater`).
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

from asyncua import Server, ua
from asyncua.crypto.permission_rules import User
from asyncua.server.address_space import AttributeValue

from pyuss.errors import ConfigError
from pyuss.gateway.opcua_sessions import current_user
from pyuss.gateway.options import OpcuaOptions
from pyuss.gateway.uanodes import (
    argument_fault,
    parameter_range,
    percent_range,
    unit_id,
    value_parts,
    value_status,
)
from pyuss.points.drive import DrivePoints
from pyuss.points.model import STATUS_BIT_NAMES
from pyuss.points.state import DriveState

__all__ = [
    "READ",
    "DriveNodes",
    "Face",
    "Method",
    "Updater",
    "Value",
    "Writable",
    "check_value",
    "engineering_units",
    "status_code",
]

log = logging.getLogger("pyuss.gateway.opcua")
T = TypeVar("T")


class Face(Protocol):
    """What a drive's nodes use of the OPC UA face (`pyuss.gateway.opcua.OpcuaFace`)."""

    server: Server
    options: OpcuaOptions
    ns: int
    """The face's namespace index."""
    writables: dict[ua.NodeId, Writable]
    """The variables whose writes go to a drive."""
    commands: set[ua.NodeId]
    """The methods that change a drive."""

    def may_write(self, user: User | None) -> bool:
        """Whether ``user`` may write and call the methods that change a drive."""
        ...

    async def carry_out(self, what: Callable[[], Awaitable[T]], where: str) -> T | ua.StatusCode:
        """``what()`` carried out, unless the face is stopping; a refusal is its status."""
        ...


def engineering_units(unit: str) -> ua.EUInformation:
    """The EUInformation of ``unit`` (UnitId -1 for a unit without a UNECE code)."""
    return ua.EUInformation(
        NamespaceUri="http://www.opcfoundation.org/UA/units/un/cefact",
        UnitId=unit_id(unit),
        DisplayName=ua.LocalizedText(unit),
        Description=ua.LocalizedText(unit),
    )


class Value(ua.DataValue):  # type: ignore[misc]
    """A drive's value as the face writes it into its node: never changed once made, so a
    client's monitored item keeps it as it is. asyncua keeps a deep copy of every value
    written to a monitored node (``MonitoredItemValues.set_current_datavalue``), which took
    most of the gateway's CPU with a client monitoring a drive's values (some 0.3 ms a
    value)."""

    def __deepcopy__(self, memo: dict[int, Any]) -> Value:
        return self


def status_code(code: int) -> ua.StatusCode:
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


WriteHandler = Callable[[Any], Awaitable[ua.StatusCode | None]]
"""Carries a checked value out; returns the write's status where it is not Good."""


@dataclass(frozen=True, slots=True)
class Writable:
    """A variable whose writes go to the drive: the handler and the type it takes."""

    handler: WriteHandler
    vtype: ua.VariantType


READ = ua.AccessLevel.CurrentRead.mask


@dataclass(frozen=True, slots=True)
class Method:
    """A drive's method: the object it belongs to, the types of its input arguments, whether
    it changes the drive (a write right needed), what it does with checked values, and its
    name (for the log)."""

    face: Face
    parent: ua.NodeId
    inputs: tuple[ua.VariantType, ...]
    changes: bool
    body: Callable[..., Awaitable[Any]]
    name: str

    async def call(self, parent: ua.NodeId, *args: Any) -> Any:
        if parent != self.parent:
            return status_code(ua.StatusCodes.BadMethodInvalid)  # another object's method
        if self.changes and not self.face.may_write(current_user.get()):
            return status_code(ua.StatusCodes.BadUserAccessDenied)
        wrong_count = argument_fault(len(args), len(self.inputs))
        if wrong_count is not None:
            return status_code(getattr(ua.StatusCodes, wrong_count))
        checks = [check_value(a, t) for a, t in zip(args, self.inputs, strict=True)]
        if any(code is not None for code in checks):
            return ua.CallMethodResult(
                StatusCode=status_code(ua.StatusCodes.BadInvalidArgument),
                InputArgumentResults=[ua.StatusCode(code or 0) for code in checks],
            )
        return await self.face.carry_out(
            lambda: self.body(*(a.Value for a in args)),
            f"{self.name} of {self.parent.to_string()}",
        )


class DriveNodes:
    """The nodes of one drive and keeping them up to date."""

    def __init__(self, face: Face, drive: DrivePoints) -> None:
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
            AccessLevel=READ,
            UserAccessLevel=READ,
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
                    ua.DataValue(StatusCode=status_code(ua.StatusCodes.BadWaitingForInitialData))
                )
            else:
                await eu_range.write_value(ua.Range(Low=span[0], High=span[1]))
        if writer is not None and not face.options.read_only:
            await node.set_writable(True)
            face.writables[nodeid] = Writable(writer, vtype)
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
                    return status_code(ua.StatusCodes.GoodClamped)  # the drive holds another

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
        method = Method(face, self.obj, types, changes, body, name)
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
                StatusCode=status_code(ua.StatusCodes.GoodClamped), OutputArguments=outputs
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
                code = status_code(0 if status is None else getattr(ua.StatusCodes, status))
                writes.append(
                    (
                        nodeid,
                        Value(
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
                writes.append((nodeid, Value(ua.Variant(span))))
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


class Updater:
    """Keeps a drive's nodes at its newest state.

    While no client monitors any of them, a state is only noted: the values are made from
    it when a client reads one (a value callback on each node, which asyncua's
    ``read_attribute_value`` calls), so an answer nobody looks at costs nothing here; a
    value that changed since it was last read then carries the time of the newest state.
    Else the values that changed are written, at once where no client monitors them
    (`_write_at_once`), else through the server in a task, which tells the subscriptions; a
    state that comes while the previous one is being written waits, and a newer one
    replaces it."""

    def __init__(self, nodes: DriveNodes) -> None:
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
