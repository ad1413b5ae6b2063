"""The plant as configured: buses, their drives, and per drive the points to show.

A plant is a list of buses; a bus is a port URL with its baud rate, profile and cycle; a drive
is an address on it with a name, a layout, the process data words it carries (actual values
and setpoints, scaled) and the parameters to expose (read on demand, or polled every so many
seconds). The faces (Modbus, MQTT, OPC UA, the web page) show what is configured here, alike.

The same model comes from a TOML file (`parse_plant` on the tables of ``uss gateway --config``)
or from the flags of the one-bus case (`plant_from_flags`). Bad configuration raises
`ConfigError` naming the key (``bus[0].drive[1].address: 40 is not 0..31``) before anything
is opened. The file's format is in docs/gateway.md; in short::

    [[bus]]
    name = "line1"                   # letters, digits, - and _ (it is part of MQTT topics)
    port = "/dev/ttyUSB0"            # any port URL of pyuss.transport
    baud = 19200
    profile = "generic"              # the drives' family; without it: of unknown kind
    layout = "4,2"                   # default layout of its drives
    cycle_time = 0.1                 # seconds; default: as fast as the line allows
    offline_after_missed = 3         # a drive is offline after 3 answers missed in a row
    offline_after_silence = 2.0      # ... or 2 s without an answer (default: from the cycle)

    [[bus.drive]]
    address = 5
    name = "conveyor"
    parameters = [107, "4.2", { pnu = 52, poll = 5.0 }]
    reference = 50.0                 # physical value of 100 % (4000h); or "P352"
    unit = "Hz"

The default reference of a drive is its profile's reference parameter (P352 on the generic
profile), read once when the gateway starts; without one, process values are in percent. A bus
or drive that names no profile is of unknown kind: no family's parameter facts, texts or
reference are applied to it (its parameters travel as words, its process values in percent),
as the commands take a drive without ``--profile``.
"""

from __future__ import annotations

import math
import os
import re
import urllib.parse
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pyuss.drive.database import ParamRef
from pyuss.errors import ConfigError
from pyuss.master.core import MAX_CYCLE_TIME
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import MAX_ADDRESS
from pyuss.protocol.timing import check_baud

__all__ = [
    "BusConfig",
    "DriveConfig",
    "ParameterConfig",
    "PlantConfig",
    "ProcessConfig",
    "Where",
    "parse_parameter_spec",
    "parse_plant",
    "plant_from_flags",
]

NAME = re.compile(r"^[A-Za-z0-9_-]{1,64}$")
"""Bus and drive names: they are parts of MQTT topics and OPC UA node ids."""

DEFAULT_BUS = "bus"


@dataclass(frozen=True, slots=True)
class ParameterConfig:
    """One parameter (element) to expose."""

    pnu: int
    index: int | None = None
    name: str | None = None
    """Shown name; default: the parameter model's."""
    poll: float | None = None
    """Read every ``poll`` seconds; None: read when a client asks."""

    @property
    def key(self) -> str:
        return f"P{self.pnu}" if self.index is None else f"P{self.pnu}.{self.index}"


@dataclass(frozen=True, slots=True)
class ProcessConfig:
    """One process value: an actual value (answer) or setpoint (request) in PZD ``pzd``."""

    key: str = "main"
    pzd: int = 2
    dword: bool = False
    """32 bits in PZD ``pzd`` (high) and ``pzd + 1`` (low), 4000 0000h = 100 %."""


@dataclass(frozen=True, slots=True)
class DriveConfig:
    address: int
    name: str
    layout: Layout | None = None
    profile: str | None = None
    parameters: tuple[ParameterConfig, ...] = ()
    actual: tuple[ProcessConfig, ...] = (ProcessConfig(),)
    setpoints: tuple[ProcessConfig, ...] = (ProcessConfig(),)
    reference: float | ParamRef | None = None
    """Physical value of 100 %: a number in ``unit``, a parameter to read, or None for the
    profile's reference parameter (percent if it has none)."""
    unit: str | None = None
    """Unit of a numeric ``reference``."""


@dataclass(frozen=True, slots=True)
class BusConfig:
    name: str
    port: str
    baud: int = 9600
    profile: str | None = None
    """The drives' profile (None: of unknown kind, unless a drive names its own)."""
    layout: Layout | None = None
    cycle_time: float | None = None
    job_timeout: float = 2.0
    drives: tuple[DriveConfig, ...] = ()
    offline_after_missed: int = 3
    """A drive that answered is offline after this many answers missed in a row."""
    offline_after_silence: float | None = None
    """... or after this many seconds without an answer; None: from the line's cycle
    (`pyuss.points.model.offline_rule`)."""
    extra: Mapping[str, Any] = field(default_factory=dict)
    """Keys of the bus table that belong to a face (``modbus = "HOST:PORT"``)."""


@dataclass(frozen=True, slots=True)
class PlantConfig:
    buses: tuple[BusConfig, ...]

    def bus(self, name: str) -> BusConfig:
        for bus in self.buses:
            if bus.name == name:
                return bus
        raise ConfigError(f"no bus named {name!r}")


class Where:
    """A position in the configuration, to name the key of a bad value."""

    def __init__(self, path: str = "") -> None:
        self.path = path

    def key(self, name: str | int) -> Where:
        if isinstance(name, int):
            return Where(f"{self.path}[{name}]")
        return Where(f"{self.path}.{name}" if self.path else name)

    def error(self, problem: str) -> ConfigError:
        return ConfigError(f"{self.path}: {problem}" if self.path else problem)

    def table(self, value: object, known: Sequence[str]) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self.error(f"expected a table, not {value!r}")
        for key in value:
            if key not in known:
                raise self.key(str(key)).error(f"unknown key (known: {', '.join(known)})")
        return value

    def integer(self, value: object, low: int, high: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(f"expected an integer, not {value!r}")
        if not low <= value <= high:
            raise self.error(f"{value} is not {low}..{high}")
        return value

    def seconds(self, value: object, *, zero: bool = False, most: float | None = None) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(f"expected a number of seconds, not {value!r}")
        if not math.isfinite(value) or value < 0 or (value == 0 and not zero):
            raise self.error(f"{value!r} is not a {'' if zero else 'positive '}number of seconds")
        if most is not None and value > most:
            raise self.error(f"{value!r} seconds is more than the {most:g} allowed")
        return float(value)

    def text(self, value: object) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.error(f"expected a non-empty string, not {value!r}")
        return value.strip()

    def flag(self, value: object) -> bool:
        if not isinstance(value, bool):
            raise self.error(f"expected true or false, not {value!r}")
        return value

    def name(self, value: object) -> str:
        text = self.text(value)
        if not NAME.match(text):
            raise self.error(f"{text!r}: use 1..64 letters, digits, '-' and '_'")
        return text

    def layout(self, value: object) -> Layout:
        try:
            return Layout.parse(self.text(value))
        except ConfigError as exc:
            raise self.error(str(exc)) from None

    def profile(self, value: object) -> str:
        from pyuss.profiles import profile_names

        text = self.text(value)
        if text not in profile_names():
            raise self.error(f"unknown profile {text!r} (known: {', '.join(profile_names())})")
        return text


def parse_parameter_spec(text: str) -> tuple[int, int | None]:
    """``107``, ``P107``, ``r0002``, ``4.2``, ``P4.2`` or ``r0947[1]`` -> (PNU, index): any
    spelling of `pyuss.params.names`."""
    from pyuss.params.names import parse_param_name

    return parse_param_name(text)


def _parameter_spec(text: str, where: Where) -> tuple[int, int | None]:
    """`parse_parameter_spec` of a value of the file at ``where``: its refusal names the place."""
    try:
        return parse_parameter_spec(text)
    except ConfigError as exc:
        raise where.error(str(exc)) from None


def _parameter(value: object, where: Where) -> ParameterConfig:
    if isinstance(value, bool):
        raise where.error(f"expected a PNU, 'PNU.INDEX' or a table, not {value!r}")
    if isinstance(value, int):
        return ParameterConfig(where.integer(value, 0, 65535))
    if isinstance(value, str):
        pnu, index = _parameter_spec(value, where)
        return ParameterConfig(pnu, index)
    table = where.table(value, ("pnu", "index", "name", "poll"))
    if "pnu" not in table:
        raise where.key("pnu").error("missing")
    pnu_value = table["pnu"]
    if isinstance(pnu_value, str):
        pnu, index = _parameter_spec(pnu_value, where.key("pnu"))
    else:
        pnu, index = where.key("pnu").integer(pnu_value, 0, 65535), None
    if "index" in table:
        index = where.key("index").integer(table["index"], 0, 254)
    name = where.key("name").text(table["name"]) if "name" in table else None
    poll = where.key("poll").seconds(table["poll"]) if "poll" in table else None
    return ParameterConfig(pnu, index, name, poll)


def _process(value: object, where: Where, pzd_count: int | None) -> ProcessConfig:
    if isinstance(value, int) and not isinstance(value, bool):
        value = {"pzd": value}
    table = where.table(value, ("key", "pzd", "dword"))
    key = where.key("key").name(table.get("key", "main"))
    pzd = where.key("pzd").integer(table.get("pzd", 2), 2, 16)
    dword = where.key("dword").flag(table.get("dword", False))
    last = pzd + (1 if dword else 0)
    if pzd_count is not None and last > pzd_count:
        raise where.key("pzd").error(
            f"PZD{last} is beyond the layout's {pzd_count} PZD words (C 5)"
        )
    return ProcessConfig(key, pzd, dword)


def _separate(setpoints: Sequence[ProcessConfig], where: Where) -> None:
    """Setpoints share no PZD word: a write of one would change what another one sends."""
    owner: dict[int, str] = {}
    for number, item in enumerate(setpoints):
        for word in range(item.pzd, item.pzd + (2 if item.dword else 1)):
            if word in owner:
                raise (
                    where.key(number)
                    .key("pzd")
                    .error(
                        f"PZD{word} carries setpoint {owner[word]!r} already: a write of one "
                        "setpoint would change the other"
                    )
                )
            owner[word] = item.key


def _reference(value: object, where: Where) -> float | ParamRef:
    if isinstance(value, str):
        pnu, index = _parameter_spec(value, where)
        return ParamRef(pnu, index)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise where.error(f"expected a number or a parameter such as 'P352', not {value!r}")
    if not math.isfinite(value) or value <= 0:
        raise where.error(f"{value!r} is not a positive number")
    return float(value)


_DRIVE_KEYS = (
    "address",
    "name",
    "layout",
    "profile",
    "parameters",
    "actual",
    "setpoints",
    "reference",
    "unit",
)


def _drive(value: object, where: Where, bus_layout: Layout | None) -> DriveConfig:
    table = where.table(value, _DRIVE_KEYS)
    if "address" not in table:
        raise where.key("address").error("missing")
    address = where.key("address").integer(table["address"], 0, MAX_ADDRESS)
    name = where.key("name").name(table.get("name", f"drive{address}"))
    layout = where.key("layout").layout(table["layout"]) if "layout" in table else None
    profile = where.key("profile").profile(table["profile"]) if "profile" in table else None
    effective = layout or bus_layout
    pzd_count = effective.pzd if effective is not None else None
    parameters: list[ParameterConfig] = []
    raw_params = table.get("parameters", [])
    if not isinstance(raw_params, list):
        raise where.key("parameters").error(f"expected a list, not {raw_params!r}")
    for number, item in enumerate(raw_params):
        param = _parameter(item, where.key("parameters").key(number))
        if any(p.key == param.key for p in parameters):
            raise where.key("parameters").key(number).error(f"{param.key} is listed twice")
        parameters.append(param)
    process: dict[str, tuple[ProcessConfig, ...]] = {}
    for kind in ("actual", "setpoints"):
        if kind not in table:
            default = () if pzd_count is not None and pzd_count < 2 else (ProcessConfig(),)
            process[kind] = default
            continue
        items = table[kind]
        if not isinstance(items, list):
            raise where.key(kind).error(f"expected a list, not {items!r}")
        found = [_process(item, where.key(kind).key(n), pzd_count) for n, item in enumerate(items)]
        keys = [p.key for p in found]
        if len(set(keys)) != len(keys):
            raise where.key(kind).error("keys must differ")
        if kind == "setpoints":
            _separate(found, where.key(kind))
        process[kind] = tuple(found)
    reference = (
        _reference(table["reference"], where.key("reference")) if "reference" in table else None
    )
    unit = where.key("unit").text(table["unit"]) if "unit" in table else None
    if unit is not None and not isinstance(reference, float):
        raise where.key("unit").error("belongs to a numeric reference (reference = 50.0)")
    return DriveConfig(
        address=address,
        name=name,
        layout=layout,
        profile=profile,
        parameters=tuple(parameters),
        actual=process["actual"],
        setpoints=process["setpoints"],
        reference=reference,
        unit=unit,
    )


_BUS_KEYS = (
    "name",
    "port",
    "baud",
    "profile",
    "layout",
    "cycle_time",
    "job_timeout",
    "offline_after_missed",
    "offline_after_silence",
    "drive",
)
MAX_MISSED = 1000
"""The most answers in a row a drive may miss before it is offline."""
MAX_SILENCE = 3600.0
"""The longest a drive may go without an answer before it is offline (seconds)."""


def _bus(value: object, where: Where, number: int, face_keys: Sequence[str]) -> BusConfig:
    table = where.table(value, (*_BUS_KEYS, *face_keys))
    name = where.key("name").name(table.get("name", DEFAULT_BUS if number == 0 else f"bus{number}"))
    if "port" not in table:
        raise where.key("port").error(
            "missing (a port URL such as /dev/ttyUSB0 or bus://HOST:PORT)"
        )
    port = where.key("port").text(table["port"])
    baud = where.key("baud").integer(table.get("baud", 9600), 1, 10_000_000)
    try:
        check_baud(baud)
    except ConfigError as exc:
        raise where.key("baud").error(str(exc)) from None
    profile = where.key("profile").profile(table["profile"]) if "profile" in table else None
    layout = where.key("layout").layout(table["layout"]) if "layout" in table else None
    cycle = (
        where.key("cycle_time").seconds(table["cycle_time"], most=MAX_CYCLE_TIME)
        if "cycle_time" in table
        else None
    )
    timeout = where.key("job_timeout").seconds(table.get("job_timeout", 2.0))
    missed = where.key("offline_after_missed").integer(
        table.get("offline_after_missed", 3), 1, MAX_MISSED
    )
    silence = (
        where.key("offline_after_silence").seconds(table["offline_after_silence"], most=MAX_SILENCE)
        if "offline_after_silence" in table
        else None
    )
    drives_value = table.get("drive", [])
    if not isinstance(drives_value, list) or not drives_value:
        raise where.key("drive").error("at least one [[bus.drive]] table is needed")
    drives: list[DriveConfig] = []
    for n, item in enumerate(drives_value):
        drive = _drive(item, where.key("drive").key(n), layout)
        for other in drives:
            for key, shown in (("address", str(drive.address)), ("name", repr(drive.name))):
                if getattr(other, key) == getattr(drive, key):
                    raise (
                        where.key("drive")
                        .key(n)
                        .key(key)
                        .error(f"{key} {shown} is used twice on this bus")
                    )
        drives.append(drive)
    extra = {key: table[key] for key in face_keys if key in table}
    return BusConfig(
        name=name,
        port=port,
        baud=baud,
        profile=profile,
        layout=layout,
        cycle_time=cycle,
        job_timeout=timeout,
        drives=tuple(drives),
        offline_after_missed=missed,
        offline_after_silence=silence,
        extra=extra,
    )


def _line(port: str) -> str:
    """The line a port URL opens, to find two buses on one: a device path resolved through
    its links (``/dev/serial/by-id/...`` is a ``/dev/ttyUSB0``), a URL without its options
    (``?rs485=rts``, ``?name=``)."""
    if "://" not in port:
        path = port.split("?", 1)[0]
        return os.path.realpath(path) if os.path.isabs(path) else path
    parts = urllib.parse.urlsplit(port)
    return f"{parts.scheme.lower()}://{parts.netloc.lower()}{parts.path}"


def parse_plant(
    buses: object, where: Where | None = None, *, face_keys: Sequence[str] = ()
) -> PlantConfig:
    """The plant from the ``[[bus]]`` tables of a configuration file (already read by
    ``tomllib``). ``face_keys``: further keys a bus table may carry for the faces."""
    where = where or Where("bus")
    if not isinstance(buses, list) or not buses:
        raise where.error("at least one [[bus]] table is needed")
    found: list[BusConfig] = []
    for number, item in enumerate(buses):
        bus = _bus(item, where.key(number), number, face_keys)
        for other in found:
            if other.name == bus.name:
                raise where.key(number).key("name").error(f"bus name {bus.name!r} is used twice")
            if other.port == bus.port:
                raise where.key(number).key("port").error(f"port {bus.port!r} is used twice")
            if _line(other.port) == _line(bus.port):
                raise (
                    where.key(number)
                    .key("port")
                    .error(
                        f"{bus.port!r} is the line of bus {other.name!r} ({other.port!r}) too: "
                        "one master per line"
                    )
                )
        found.append(bus)
    return PlantConfig(tuple(found))


def plant_from_flags(
    *,
    port: str,
    addresses: Sequence[int],
    baud: int = 9600,
    profile: str | None = None,
    layout: str | None = None,
    name: str = DEFAULT_BUS,
    cycle_time: float | None = None,
    parameters: Sequence[str] = (),
    job_timeout: float = 2.0,
) -> PlantConfig:
    """The one-bus plant of ``uss gateway --port URL --address 5 --address 6 ...``; bad values
    raise `ConfigError` naming the flag."""
    data: dict[str, Any] = {
        "name": name,
        "port": port,
        "baud": baud,
        **({"profile": profile} if profile is not None else {}),
        "job_timeout": job_timeout,
        "drive": [
            {"address": a, **({"parameters": list(parameters)} if parameters else {})}
            for a in addresses
        ],
    }
    if layout is not None:
        data["layout"] = layout
    if cycle_time is not None:
        data["cycle_time"] = cycle_time
    if not addresses:
        raise ConfigError("--address: give at least one drive address")
    try:
        return parse_plant([data])
    except ConfigError as exc:
        raise ConfigError(_flag_message(str(exc))) from None


_FLAGS = {
    "address": "--address",
    "port": "--port",
    "baud": "--baud",
    "profile": "--profile",
    "layout": "--layout",
    "cycle_time": "--cycle-time",
    "job_timeout": "--timeout",
    "name": "--bus-name",
    "parameters": "--parameter",
}


def _flag_message(message: str) -> str:
    path, sep, rest = message.partition(": ")
    if not sep:
        return message
    key = re.sub(r"\[\d+\]", "", path).rsplit(".", 1)[-1]
    if key in _FLAGS:
        return f"{_FLAGS[key]}: {rest}"
    parts = path.split(".")
    for part in reversed(parts):
        bare = re.sub(r"\[\d+\]", "", part)
        if bare in _FLAGS:
            return f"{_FLAGS[bare]}: {rest}"
    return message
