"""The points of every drive, resolved from the configuration before anything is opened.

`resolve` checks a `PlantConfig` against what the parameter model knows (a text parameter
cannot be shown as a number, an array needs an element, a process word must fit the layout)
and returns the `PlantModel` the runtime and the faces are built from. Errors name the key of
the configuration, as `pyuss.points.config` does.

Per drive the points are the same for every face:

- the status word and its bits (C Tables 5.5, 5.6: `STATUS_BIT_NAMES`) and the state they spell;
- actual values: PZD words of the answer, in percent (4000h = 100 %) and, where the reference
  is known, in its unit;
- the control word and setpoints: PZD words of the request, the same way;
- chosen parameters (`ParamMeta`), read when asked or polled;
- health: "does not send" (A 5.2.1.1), the counters of A 5.2.3, the last fault, the last
  refused job;
- availability: whether the drive is online - it answers, and its bus's master exchanges on
  the line - by the bus's `OfflineRule` (`offline_rule`): not after one missed answer, after
  several in a row or a time without any.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from pyuss.drive.database import ParamRef
from pyuss.errors import ConfigError
from pyuss.master.profile import resolve_profile, response_limit
from pyuss.points.config import BusConfig, DriveConfig, PlantConfig, ProcessConfig, Where
from pyuss.points.parameters import ParameterModel, ParamMeta
from pyuss.protocol.layout import Layout
from pyuss.protocol.pzd import StatusWord
from pyuss.protocol.timing import start_pause, transmit_time

__all__ = [
    "COMMANDS",
    "COMMAND_TABLE",
    "MOVES",
    "STATUS_BIT_NAMES",
    "BusModel",
    "Command",
    "DriveModel",
    "OfflineRule",
    "ParameterPoint",
    "PlantModel",
    "line_model",
    "offline_rule",
    "resolve",
]

STATUS_BIT_NAMES: dict[int, str] = {
    flag.bit_length() - 1: str(flag.name).lower()
    for flag in StatusWord
    if flag.name is not None and not flag.name.startswith("DEVICE")
}
"""Status bits 0..10 by the names the faces use (``ready_to_switch_on`` ... ``target_reached``)."""


@dataclass(frozen=True, slots=True)
class Command:
    """One drive command: the control word sequence of `pyuss.master.Drive` that carries
    it (``method`` with ``args``), and whether it can set a motor turning."""

    name: str
    method: str
    args: tuple[int | None, ...] = ()
    moves: bool = False
    """It can set a motor turning: a face that asks a person asks before it sends it."""
    whole: bool = True
    """It sends a whole control word of its own (ON, OFF1/2/3); the others (acknowledge,
    jog) change bits of the word in force, and while the master has sent none yet (0000h:
    no control by the interface) they start from 047Eh, OFF1 (`pyuss.points.DrivePoints.command`
    refuses them then on a drive that is switched on)."""


COMMAND_TABLE: dict[str, Command] = {
    command.name: command
    for command in (
        Command("on", "on", moves=True),  # 047Eh, then 047Fh (C Tables 5.2..5.5)
        Command("off1", "off1"),  # ramp down, control bit 0 = 0
        Command("off2", "off2"),  # pulses off, the motor coasts: bit 1 = 0
        Command("off3", "off3"),  # quick stop: bit 2 = 0
        Command("acknowledge", "acknowledge", whole=False),  # a rising edge of bit 7
        Command("jog1", "jog", (1,), moves=True, whole=False),  # bit 8
        Command("jog2", "jog", (2,), moves=True, whole=False),  # bit 9
        Command("jog_off", "jog", (None,), whole=False),
    )
}
"""Every drive command of the points, by name: the one table the faces' commands come from."""

COMMANDS = ("on", "off1", "off2", "off3", "acknowledge")
"""The drive commands every face offers (the gateway's; the page adds the jog commands)."""

MOVES = frozenset(name for name, command in COMMAND_TABLE.items() if command.moves)
"""The commands that can set a motor turning (a new setpoint can too)."""


@dataclass(frozen=True, slots=True)
class ParameterPoint:
    meta: ParamMeta
    poll: float | None

    @property
    def key(self) -> str:
        return self.meta.key


@dataclass(frozen=True, slots=True)
class DriveModel:
    bus: str
    address: int
    name: str
    profile: str | None
    """The drive's profile (None: of unknown kind, no family's facts)."""
    layout: Layout
    actual: tuple[ProcessConfig, ...]
    setpoints: tuple[ProcessConfig, ...]
    parameters: tuple[ParameterPoint, ...]
    reference: float | ParamMeta | None
    """Physical value of 100 %: a number, the parameter to read it from, or None (percent)."""
    unit: str
    """Unit of the process values ("%" without a reference)."""
    fault: ParamMeta | None
    """The parameter holding the fault number, read when the fault bit rises."""
    config: DriveConfig
    every_word: bool = False
    """Every PZD word of the answer is an actual value (`DrivePoints.actual_row`): PZD2 the
    main one, PZD3... the parameters the profile maps to them (the page's trend)."""

    @property
    def key(self) -> str:
        """``bus/name``: unique in the plant."""
        return f"{self.bus}/{self.name}"

    def parameter(self, key: str) -> ParameterPoint | None:
        for point in self.parameters:
            if point.key == key:
                return point
        return None


@dataclass(frozen=True, slots=True)
class OfflineRule:
    """When a drive that answered is offline: after ``missed`` answers missed in a row, or
    ``silence`` seconds without an answer, whichever comes first (docs/gateway.md,
    "Availability"). One lost answer on a noisy line is none: its values are stale."""

    missed: int = 3
    silence: float = 1.0


MIN_SILENCE = 1.0
"""The shortest default time without an answer after which a drive is offline (seconds)."""
SILENT_SLACK = 0.04
"""What a master waits beyond a silent drive's response window (receive tolerance and
latency, `pyuss.master.scheduler`), in seconds."""


def offline_rule(bus: BusConfig, drives: Sequence[DriveModel]) -> OfflineRule:
    """The bus's `OfflineRule`: its ``offline_after_missed`` and ``offline_after_silence``;
    the time by default ``missed + 1`` of the line's longest cycles, at least `MIN_SILENCE`:
    the bus's ``cycle_time``, or, if longer, a round of the poll list with every drive silent
    (each its request and answer on the line, two start pauses, its response window and the
    master's wait beyond), so that a drive polled in turn is never offline by the time alone
    before it missed as many answers."""
    if bus.offline_after_silence is not None:
        return OfflineRule(bus.offline_after_missed, bus.offline_after_silence)
    round_time = 0.0
    for drive in drives:
        words = drive.layout.words or (4 + drive.layout.pzd)  # variable: PKW 4 as a guess
        telegram = transmit_time(bus.baud, 4 + 2 * words)
        limit = response_limit(resolve_profile(drive.profile), bus.baud)
        round_time += 2 * telegram + 2 * start_pause(bus.baud) + limit + SILENT_SLACK
    cycle = max(bus.cycle_time or 0.0, round_time)
    silence = max(MIN_SILENCE, (bus.offline_after_missed + 1) * cycle)
    return OfflineRule(bus.offline_after_missed, round(silence, 3))


@dataclass(frozen=True, slots=True)
class BusModel:
    config: BusConfig
    drives: tuple[DriveModel, ...]
    offline: OfflineRule = OfflineRule()
    """When its drives are offline (`offline_rule`)."""

    @property
    def name(self) -> str:
        return self.config.name


@dataclass(frozen=True, slots=True)
class PlantModel:
    buses: tuple[BusModel, ...]
    config: PlantConfig

    @property
    def drives(self) -> tuple[DriveModel, ...]:
        return tuple(d for bus in self.buses for d in bus.drives)


def _drive(bus: BusConfig, config: DriveConfig, where: Where) -> DriveModel:
    profile_name = config.profile or bus.profile
    profile = resolve_profile(profile_name)  # None: the USS specification's telegram rules
    layout = config.layout or bus.layout or profile.default_layout
    try:
        profile.check_layout(layout)
    except ConfigError as exc:
        raise where.key("layout").error(str(exc)) from None
    for kind, items in (("actual", config.actual), ("setpoints", config.setpoints)):
        for number, item in enumerate(items):
            last = item.pzd + (1 if item.dword else 0)
            if last > layout.pzd:
                raise (
                    where.key(kind)
                    .key(number)
                    .error(f"PZD{last} is beyond layout {layout} ({layout.pzd} PZD words)")
                )
    model = ParameterModel(profile_name)
    parameters: list[ParameterPoint] = []
    for number, param in enumerate(config.parameters):
        try:
            meta = model.meta(param.pnu, param.index, param.name)
        except ConfigError as exc:
            raise where.key("parameters").key(number).error(str(exc)) from None
        if layout.pkw == 0:
            raise where.key("parameters").error(
                f"layout {layout} has no PKW area: no parameter can be read (C 4.1)"
            )
        if meta.dword and layout.pkw == 3:
            raise (
                where.key("parameters")
                .key(number)
                .error(
                    f"{meta.key} is a double word: layout {layout} carries one word (PKW 4 or v)"
                )
            )
        parameters.append(ParameterPoint(meta, param.poll))
    reference: float | ParamMeta | None
    unit = "%"
    if isinstance(config.reference, float):
        reference = config.reference
        unit = config.unit or ""
    else:
        ref: tuple[int, int | None] | None
        if isinstance(config.reference, ParamRef):
            ref = (config.reference.pnu, config.reference.index)
        else:
            ref = model.role("reference") if layout.pkw else None
        if ref is None:
            reference = None
        else:
            try:
                reference = model.meta(*ref)
            except ConfigError as exc:
                raise where.key("reference").error(str(exc)) from None
            unit = reference.unit
    fault_ref = model.role("fault") if layout.pkw else None
    fault = model.meta(*fault_ref) if fault_ref is not None else None
    return DriveModel(
        bus=bus.name,
        address=config.address,
        name=config.name,
        profile=profile_name,
        layout=layout,
        actual=config.actual,
        setpoints=config.setpoints,
        parameters=tuple(parameters),
        reference=reference,
        unit=unit,
        fault=fault,
        config=config,
    )


def line_model(
    name: str,
    drives: Sequence[tuple[int, str | None, Layout | None]],
    *,
    baud: int = 9600,
    job_timeout: float = 2.0,
) -> PlantModel:
    """The model of one line of drives given by address, profile and layout (the web page's):
    the main setpoint and actual value in PZD2 where the layout has one, every other word of
    the answer an actual value too, the profile's reference, no configured parameters."""
    configs = []
    for address, profile, layout in drives:
        words = (layout or resolve_profile(profile).default_layout).pzd
        main = (ProcessConfig(),) if words >= 2 else ()
        configs.append(
            DriveConfig(address, f"drive{address}", layout, profile, actual=main, setpoints=main)
        )
    bus = BusConfig(name, name, baud, job_timeout=job_timeout, drives=tuple(configs))
    model = resolve(PlantConfig((bus,)))
    buses = tuple(
        replace(b, drives=tuple(replace(d, every_word=True) for d in b.drives)) for b in model.buses
    )
    return PlantModel(buses, model.config)


def resolve(plant: PlantConfig, where: Where | None = None) -> PlantModel:
    """The `PlantModel` of ``plant``; `ConfigError` naming the key of what cannot be shown."""
    where = where or Where("bus")
    buses = []
    for number, bus in enumerate(plant.buses):
        at = where.key(number)
        drives = tuple(
            _drive(bus, drive, at.key("drive").key(n)) for n, drive in enumerate(bus.drives)
        )
        buses.append(BusModel(bus, drives, offline_rule(bus, drives)))
    return PlantModel(tuple(buses), plant)
