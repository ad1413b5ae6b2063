"""The MQTT topics of a bus and its drives, command parsing and Home Assistant discovery,
without a broker.

Topics (``uss`` is the configurable prefix, ``BUS`` and ``DRIVE`` the configured names)::

    uss/BUS/availability              online / offline, retained; the gateway's last will
    uss/BUS/DRIVE/availability        online while the drive answers, retained
    uss/BUS/DRIVE/state               the drive's state as JSON with units, retained
    uss/BUS/DRIVE/param/P107          a configured parameter as last read, retained
    uss/BUS/DRIVE/param/P107/set      write it (payload: the value in its unit)
    uss/BUS/DRIVE/param/P107/get      read it now (any parameter, P4.2 for an element)
    uss/BUS/DRIVE/cmd/NAME            a command (`COMMAND_NAMES`)
    uss/BUS/DRIVE/reply               the result or the refusal of every command
    uss/BUS/DRIVE/reply/...           the reply namespace: other reply topics of the drive

A command's payload is a JSON object - ``{"id": "42", "value": 25.0}``, with ``reply_to``
for another reply topic (`check_reply_to`: never one where a reply could act) - or a plain
value (``25``, ``ON``, ``PRESS``, nothing). Every payload is parsed within bounds
(`MAX_PAYLOAD` bytes, `MAX_DEPTH` levels of JSON, numbers of `MAX_NUMBER` characters below
`LIMIT`, texts of `MAX_TEXT`); what breaks them is a `ConfigError` naming it. A command with
an ``id`` is carried out once: a repeated id (an MQTT QoS 1 duplicate, a client's retry) is
answered with the first result again and not applied twice. Commands without an id (Home
Assistant's) are all applied; those it sends are the same whether applied once or twice.

Replies: ``{"v", "id", "command", "drive", "ok": true, "result": {...}}`` or ``{"ok": false,
"error": {"type", "message", "class", "number", "meaning"}}`` (`pyuss.points.errors`).

The topics and payloads are a versioned contract: JSON Schema files shipped in the package
(``pyuss/gateway/schemas``, docs/gateway.md "The MQTT contract"). Every JSON payload the
gateway publishes carries the contract version as ``"v": 1`` (`CONTRACT_VERSION`); a command
may name the version it is written in (``v``) and is refused if the gateway does not speak
it (`VERSIONS`, `UnsupportedVersion`). A JSON command holds only the fields of its topic
(`FIELDS`): a misspelt field is refused (`UnknownField`), never ignored. These refusals carry
the command's id (`CommandError`).

States, parameters and results carry values rounded to their resolution (`state_dict`,
`reading_dict`); a state holds every configured process value, its numbers null until the
drive answered. `StateThrottle` says when a state is due (``max_rate``, ``deadband``).

Home Assistant discovery (`discovery`): per drive one device, its maker and model from the
profile, with sensors for the state text, every actual value and configured parameter (named
as the family's manual names it, with unit, display precision and, where the unit has one,
the device class: an energy counter counts up), the last fault number with its text, binary
sensors for fault, warning and operation enabled and one per other named bit of the family's
status word, a number for the main setpoint (the range the gateway takes), a switch for
ON/OFF1 and buttons for acknowledge, OFF2 and OFF3; all available while the gateway and the
drive are; each names its entity id as ``default_entity_id``
(``sensor.pyuss_line1_conveyor_state``). Every template renders with every state message:
what is not known renders ``None``, Home Assistant's "unknown".
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pyuss import __version__
from pyuss.errors import ConfigError
from pyuss.points.config import parse_parameter_spec
from pyuss.points.model import DriveModel
from pyuss.points.parameters import ParamMeta
from pyuss.points.state import (
    COUNTER_FIELDS,
    DriveState,
    Health,
    ParamValue,
    decimals,
    iso,
    process_decimals,
    setpoint_span,
)
from pyuss.profiles import UNKNOWN_KIND, get_profile
from pyuss.protocol.pzd import STATUS_BITS
from pyuss.userfile import NotJson, parse_message

__all__ = [
    "COMMAND_NAMES",
    "CONTRACT_VERSION",
    "FIELDS",
    "VERSIONS",
    "Command",
    "CommandError",
    "DriveTopics",
    "StatePayloads",
    "StateThrottle",
    "UnknownField",
    "UnsupportedVersion",
    "check_reply_to",
    "decimals",
    "discovery",
    "discovery_node",
    "parse_command",
    "reply_payload",
    "state_dict",
    "state_payload",
]

COMMAND_NAMES = (
    "on",
    "off1",
    "off2",
    "off3",
    "acknowledge",
    "run",
    "setpoint",
    "setpoint_percent",
    "control_word",
    "read",
    "write",
)
"""``run`` takes ON (= on) or OFF (= off1); ``setpoint`` a value in the setpoint's unit,
``setpoint_percent`` in percent; ``read`` and ``write`` a parameter."""

WRITES = frozenset(set(COMMAND_NAMES) - {"read"})

CONTRACT_VERSION = 1
"""The version of the MQTT contract (``pyuss/gateway/schemas``) the gateway publishes: the
``v`` of every JSON payload it sends."""
VERSIONS = (1,)
"""The contract versions the gateway takes commands in (``v``; a command without one is
taken as the newest)."""

_BASE = frozenset({"v", "id", "reply_to"})
FIELDS: dict[str, frozenset[str]] = {
    **{name: _BASE | {"value"} for name in ("on", "off1", "off2", "off3", "acknowledge")},
    "run": _BASE | {"value"},
    "control_word": _BASE | {"value"},
    "setpoint": _BASE | {"value", "key"},
    "setpoint_percent": _BASE | {"value", "key"},
    "read": _BASE | {"pnu", "index", "value"},
    "write": _BASE | {"pnu", "index", "value", "eeprom"},
    "param/set": _BASE | {"value", "eeprom"},
    "param/get": _BASE,
}
"""The fields a JSON command may hold, by command (``param/set`` and ``param/get``: the
topics of a parameter)."""

DEVICE_CLASSES: dict[str, str] = {
    "Hz": "frequency",
    "kHz": "frequency",
    "A": "current",
    "mA": "current",
    "V": "voltage",
    "mV": "voltage",
    "kV": "voltage",
    "W": "power",
    "kW": "power",
    "°C": "temperature",
    "K": "temperature",
    "s": "duration",
    "ms": "duration",
    "min": "duration",
    "h": "duration",
    "Wh": "energy",
    "kWh": "energy",
    "MWh": "energy",
}
"""Home Assistant sensor device class for a unit (units without one get none)."""

STATE_CLASSES: dict[str, str] = {"energy": "total_increasing"}
"""Home Assistant state class of a sensor by its device class, where it is not
``measurement``: an energy counter (r0039 kWh) only grows, or starts again from 0 when reset
(Home Assistant takes a fall for a new cycle)."""


@dataclass(frozen=True, slots=True)
class DriveTopics:
    prefix: str
    bus: str
    drive: str

    @property
    def base(self) -> str:
        return f"{self.prefix}/{self.bus}/{self.drive}"

    @property
    def bus_availability(self) -> str:
        return f"{self.prefix}/{self.bus}/availability"

    @property
    def availability(self) -> str:
        return f"{self.base}/availability"

    @property
    def state(self) -> str:
        return f"{self.base}/state"

    @property
    def reply(self) -> str:
        return f"{self.base}/reply"

    def command(self, name: str) -> str:
        return f"{self.base}/cmd/{name}"

    def param(self, key: str) -> str:
        return f"{self.base}/param/{key}"


def subscriptions(prefix: str, bus: str) -> list[str]:
    """The topic filters a bus's face subscribes to."""
    return [
        f"{prefix}/{bus}/+/cmd/+",
        f"{prefix}/{bus}/+/param/+/set",
        f"{prefix}/{bus}/+/param/+/get",
    ]


@dataclass(frozen=True, slots=True)
class Command:
    """A command received on a topic."""

    drive: str
    name: str
    id: str | None = None
    value: Any = None
    pnu: int | None = None
    index: int | None = None
    key: str = "main"
    eeprom: bool = False
    reply_to: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def writes(self) -> bool:
        return self.name in WRITES


MAX_PAYLOAD = 4096
"""Bytes a command's payload may have (a command is a few dozen)."""
MAX_DEPTH = 4
"""JSON nesting a command's payload may have (a command is one flat object)."""
MAX_NUMBER = 24
"""Characters a number may have, in JSON or as plain text (a 64-bit integer has 20)."""
MAX_TEXT = 256
"""Characters of an id, a key or a reply topic."""
LIMIT = 1 << 63
"""Numbers are smaller in magnitude than this (what a drive carries has 32 bits)."""


def show(value: object, width: int = 40) -> str:
    """``repr(value)``, cut to ``width`` characters for error messages and log lines."""
    text = repr(value)
    return text if len(text) <= width else f"{text[: width - 5]}...{text[-2:]}"


def _payload(raw: bytes) -> tuple[dict[str, Any], Any]:
    """(JSON object fields, plain value); `ConfigError` if the payload is too long, nested
    too deep, holds too long a number or NaN/Infinity, or is not UTF-8 text (read by
    `pyuss.userfile.parse_message`). A payload that is no JSON is a plain value (``ON``)."""
    try:
        data = parse_message(
            raw,
            "the payload",
            max_depth=MAX_DEPTH,
            max_bytes=MAX_PAYLOAD,
            max_number=MAX_NUMBER,
        )
    except NotJson:
        text = raw.decode("utf-8").strip()
        return {}, (text or None)
    if isinstance(data, dict):
        return data, data.get("value")
    return {}, data


def _text(fields: dict[str, Any], key: str) -> str | None:
    """The optional text field ``key``: a string (or, for ``id``, a number) of at most
    `MAX_TEXT` characters."""
    value = fields.get(key)
    if value is None:
        return None
    if key == "id" and isinstance(value, int) and not isinstance(value, bool):
        value = str(value)
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{key} must be a non-empty string, not {show(value)}")
    if len(value) > MAX_TEXT:
        raise ConfigError(f"{key} has at most {MAX_TEXT} characters, not {len(value)}")
    return value


class CommandError(ConfigError):
    """A command refused while it is parsed, once its ``id`` is known: the refusal carries
    the id, so that it reaches the client waiting for it."""

    def __init__(self, message: str, id: str | None = None) -> None:
        super().__init__(message)
        self.id = id


class UnsupportedVersion(CommandError):
    """A command written in a contract version the gateway does not speak."""


class UnknownField(CommandError):
    """A JSON command holds a field its topic does not take."""


def _version(fields: dict[str, Any], ident: str | None) -> None:
    """`UnsupportedVersion` unless the command's ``v`` is absent or one of `VERSIONS`."""
    version = fields.get("v")
    if version is None or (
        isinstance(version, int) and not isinstance(version, bool) and version in VERSIONS
    ):
        return
    speaks = ", ".join(str(v) for v in VERSIONS)
    raise UnsupportedVersion(
        f"v {show(version)}: this gateway speaks MQTT contract version {speaks} "
        "(send one of these as v, or no v)",
        ident,
    )


def _fields(fields: dict[str, Any], name: str, ident: str | None) -> None:
    """`UnknownField` naming the fields of a JSON command that its topic does not take."""
    unknown = sorted(set(fields) - FIELDS[name])
    if unknown:
        names = ", ".join(show(key, 30) for key in unknown[:4])
        known = ", ".join(sorted(FIELDS[name]))
        raise UnknownField(f"{name}: unknown field {names} (known: {known})", ident)


def _param(value: object) -> tuple[int, int | None]:
    if isinstance(value, int) and not isinstance(value, bool):
        return value, None
    if isinstance(value, str) and len(value) <= MAX_NUMBER:
        return parse_parameter_spec(value)
    raise ConfigError(f"a parameter is a PNU or 'PNU.INDEX', not {show(value)}")


def parse_command(topic: str, payload: bytes, prefix: str, bus: str) -> Command:
    """The command of a message; `ConfigError` naming what is wrong (the drive part of the
    topic is kept in the message so that the reply can go to the right drive)."""
    parts = topic.split("/")
    head = [*prefix.split("/"), bus]
    if parts[: len(head)] != head or len(parts) < len(head) + 3:
        raise ConfigError(f"topic {show(topic)} is not a command topic of bus {bus}")
    drive = parts[len(head)]
    rest = parts[len(head) + 1 :]
    fields, value = _payload(payload)
    ident = _text(fields, "id")
    _version(fields, ident)
    reply_to = _text(fields, "reply_to")
    if reply_to is not None and any(c in reply_to for c in "+#\0"):
        raise ConfigError(f"reply_to must be a topic without wildcards, not {show(reply_to)}")
    eeprom = fields.get("eeprom", False)
    if not isinstance(eeprom, bool):
        raise ConfigError(f"eeprom must be true or false, not {show(eeprom)}")
    common: dict[str, Any] = {
        "drive": drive,
        "id": ident,
        "reply_to": reply_to,
        "eeprom": eeprom,
    }
    if rest[0] == "param" and len(rest) == 3 and rest[2] in ("set", "get"):
        param = _param(rest[1])
        _fields(fields, f"param/{rest[2]}", ident)
        name = "write" if rest[2] == "set" else "read"
        return Command(name=name, value=value, pnu=param[0], index=param[1], **common)
    if rest[0] != "cmd" or len(rest) != 2:
        raise ConfigError(f"topic {show(topic)} is not a command topic")
    name = rest[1]
    if name not in COMMAND_NAMES:
        raise ConfigError(f"unknown command {show(name)} (known: {', '.join(COMMAND_NAMES)})")
    _fields(fields, name, ident)
    pnu: int | None = None
    index: int | None = None
    if name in ("read", "write"):
        spec = fields.get("pnu")
        if spec is None and name == "read" and value is not None:
            spec = value
        if spec is None:
            raise ConfigError(f"{name}: give the parameter as pnu (107 or '4.2')")
        pnu, index = _param(spec)
        if "index" in fields:
            index = fields["index"]
            if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= 254:
                raise ConfigError(f"index must be 0..254, not {show(index)}")
        if name == "read":
            value = None
    key = _text(fields, "key") or "main"
    return Command(name=name, value=value, pnu=pnu, index=index, key=key, **common)


def number(value: Any, what: str) -> int | float:
    """A number from a payload value (JSON number or text such as ``25``, ``0x047F``):
    finite, integers below `LIMIT` in magnitude, text of at most `MAX_NUMBER` characters;
    else `ConfigError`."""
    if isinstance(value, bool) or value is None:
        raise ConfigError(f"{what}: expected a number, not {show(value)}")
    result: int | float
    if isinstance(value, int | float):
        result = value
    elif isinstance(value, str):
        if len(value) > MAX_NUMBER:
            raise ConfigError(f"{what}: a number has at most {MAX_NUMBER} characters")
        try:
            result = int(value, 0)
        except ValueError:
            try:
                result = float(value)
            except ValueError:
                raise ConfigError(f"{what}: {show(value)} is not a number") from None
    else:
        raise ConfigError(f"{what}: expected a number, not {show(value)}")
    if isinstance(result, float) and not math.isfinite(result):
        raise ConfigError(f"{what}: {show(value)} is not a finite number")
    if not -LIMIT < result < LIMIT:
        raise ConfigError(f"{what}: {show(value)} is out of range")
    return result


def switch_value(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    if isinstance(value, str) and value.strip().upper() in ("ON", "OFF", "1", "0", "TRUE", "FALSE"):
        return value.strip().upper() in ("ON", "1", "TRUE")
    raise ConfigError(f"run: expected ON or OFF, not {show(value)}")


def under(topic: str, prefix: str) -> bool:
    """``topic`` is ``prefix`` or a topic below it."""
    return topic == prefix or topic.startswith(f"{prefix}/")


def check_reply_to(topic: str, topics: DriveTopics, discovery_prefix: str) -> None:
    """`ConfigError` unless ``topic`` may carry the replies of a command to ``topics``' drive.

    A reply never lands where something acts on it: not on a ``$`` topic of the broker, not
    under the gateway's prefix except the drive's own reply topic and the topics below it
    (``uss/BUS/DRIVE/reply/...``, the reply namespace), not under the discovery prefix, not
    on a topic shaped like a command topic of any gateway (``.../cmd/NAME``,
    ``.../param/KEY/set``, ``.../param/KEY/get``) nor on any topic ending in ``/set``.
    Wildcards are refused by `parse_command`."""
    levels = topic.split("/")
    if topic.startswith("$"):
        raise ConfigError(f"reply_to {show(topic)}: $ topics belong to the broker")
    if under(topic, topics.prefix) and not under(topic, topics.reply):
        raise ConfigError(
            f"reply_to {show(topic)} is under the gateway's prefix {topics.prefix!r}: "
            f"replies go to {topics.reply} or a topic below it"
        )
    if under(topic, discovery_prefix):
        raise ConfigError(f"reply_to {show(topic)} is under the discovery prefix")
    if (
        levels[-1] == "set"
        or (len(levels) >= 2 and levels[-2] == "cmd")
        or (len(levels) >= 3 and levels[-3] == "param" and levels[-1] == "get")
    ):
        raise ConfigError(f"reply_to {show(topic)} has the shape of a command topic")


def param_places(meta: ParamMeta) -> int | None:
    """The decimals of a parameter's resolution: those of its scaling, those its parameter
    file gives a float (`decimals`), 0 for an integer; None: a float whose file names none,
    shown to the 7 significant digits of a 32-bit float."""
    if meta.scaling is not None and not meta.is_float:
        return decimals(abs(meta.scaling))
    if meta.is_float:
        return meta.decimals or None
    return 0


def param_value(meta: ParamMeta, value: int | float | None) -> int | float | None:
    """A parameter's value rounded to its resolution (`param_places`); integers as they
    are."""
    if not isinstance(value, float) or not math.isfinite(value):
        return value
    places = param_places(meta)
    return float(f"{value:.7g}") if places is None else round(value, places)


def reading_dict(reading: ParamValue) -> dict[str, Any]:
    """`ParamValue.to_dict` with the value rounded to its resolution (`param_value`)."""
    item = reading.to_dict()
    item["value"] = param_value(reading.meta, reading.value)
    return item


def state_dict(state: DriveState) -> dict[str, Any]:
    """`DriveState.to_dict` with the process values and parameters rounded to their
    resolution (`process_decimals`, `param_value`): a 20 Hz setpoint of a 50 Hz reference
    is 20.0, not the 20.001221 its raw word 199Ah stands for."""
    data = state.to_dict()
    data["actual"] = _process_dict(state, "actual")
    data["setpoint"] = _process_dict(state, "setpoint")
    data["parameters"] = _parameters_dict(state)
    return data


def _process_dict(state: DriveState, group: str) -> dict[str, Any]:
    """The ``actual`` or ``setpoint`` part of `state_dict`: every configured process value,
    with ``value``, ``percent`` and ``raw`` null while it is not known (no answer yet)."""
    model = state.model
    values, items = (
        (state.actual, model.actual) if group == "actual" else (state.setpoints, model.setpoints)
    )
    data: dict[str, Any] = {}
    for item in items:
        value = values.get(item.key)
        if value is None:
            data[item.key] = {
                "value": None,
                "unit": model.unit,
                "percent": None,
                "raw": None,
                "pzd": item.pzd,
            }
            continue
        entry = value.to_dict()
        places, percent_places = process_decimals(item.dword, model.unit, state.reference)
        if entry["value"] is not None:
            entry["value"] = round(entry["value"], places)
        entry["percent"] = round(entry["percent"], percent_places)
        data[item.key] = entry
    return data


def _parameters_dict(state: DriveState) -> dict[str, Any]:
    return {key: reading_dict(reading) for key, reading in state.parameters.items()}


def _dumps(data: object) -> str:
    return json.dumps(data, separators=(",", ":"))


def state_payload(state: DriveState) -> bytes:
    """The state message (schema ``state.json``)."""
    data = {"v": CONTRACT_VERSION, **state_dict(state)}
    return _dumps(data).encode()


class StatePayloads:
    """The state messages of one drive, byte for byte `state_payload`, each built from the
    parts that changed since the last one: a drive that ramps changes its time, its actual
    values and its counters at every answer, and its identity, state, bits, setpoints and
    parameters seldom. Each part's JSON is kept with what it was made from (the process
    values from their raw words and the reference, the parameters by the readings
    themselves) and made again only when that differs."""

    def __init__(self) -> None:
        self._parts: dict[str, tuple[object, str]] = {}
        self._readings: tuple[object, ...] | None = None
        self._parameters = ""

    def _part(self, name: str, key: object, build: Callable[[], str]) -> str:
        last = self._parts.get(name)
        if last is not None and (last[0] is key or last[0] == key):
            return last[1]
        text = build()
        self._parts[name] = (key, text)
        return text

    def payload(self, state: DriveState) -> bytes:
        model = state.model
        reference = (state.reference, type(state.reference), model.unit)
        head = self._part(
            "head",
            model,
            lambda: _dumps(
                {
                    "v": CONTRACT_VERSION,
                    "bus": model.bus,
                    "address": model.address,
                    "name": model.name,
                    "profile": model.profile or UNKNOWN_KIND,
                }
            )[:-1],
        )
        status = self._part(
            "status",
            (state.online, state.status_word, state.control_word, reference),
            lambda: self._status(state),
        )
        actual = self._part(
            "actual",
            (state.actual_words, tuple(state.actual), reference),
            lambda: _dumps(_process_dict(state, "actual")),
        )
        setpoint = self._part(
            "setpoint",
            (state.setpoint_words, tuple(state.setpoints), reference),
            lambda: _dumps(_process_dict(state, "setpoint")),
        )
        # the readings themselves: a reading is kept until the parameter is read again
        readings = (*state.parameters, *state.parameters.values())
        if (
            self._readings is None
            or len(readings) != len(self._readings)
            or any(a is not b for a, b in zip(readings, self._readings, strict=True))
        ):
            self._readings = readings
            self._parameters = _dumps(_parameters_dict(state))
        return (
            f'{head},"time":"{iso(state.time)}",{status},"actual":{actual},'
            f'"setpoint":{setpoint},"parameters":{self._parameters},'
            f'"health":{self._health(state.health)}}}'
        ).encode()

    def _health(self, health: Health) -> str:
        """``Health.to_dict`` as JSON: the counters (whole numbers, as ``to_dict`` makes
        them) into a template, the fault and refusal as they last were."""
        faults = self._part(
            "faults",
            (health.last_fault, health.last_fault_time, health.last_refusal),
            lambda: _dumps(
                {
                    "last_fault": health.last_fault,
                    "last_fault_time": iso(health.last_fault_time),
                    "last_refusal": health.last_refusal,
                }
            )[1:-1],
        )
        counters = health.counters
        return _HEALTH % (
            "true" if health.not_sending else "false",
            health.exchanges,
            health.answers,
            health.timeouts,
            *[int(getattr(counters, name)) for name in COUNTER_FIELDS],
            faults,
        )

    @staticmethod
    def _status(state: DriveState) -> str:
        data = state.to_dict()
        part = {key: data[key] for key in _STATUS_KEYS}
        return _dumps(part)[1:-1]


_HEALTH = (
    '{"not_sending":%s,"exchanges":%d,"answers":%d,"timeouts":%d,"counters":{'
    + ",".join(f'"{name}":%d' for name in COUNTER_FIELDS)
    + "},%s}"
)
_STATUS_KEYS = (
    "online",
    "status_word",
    "status_hex",
    "status_text",
    "state",
    "bits",
    "control_word",
    "control_text",
    "reference",
)


class StateThrottle:
    """When a drive's new state is to be published (`offer`): at once if anything but its
    actual values changed since the last one published (a status bit, a fault, what was
    sent, a parameter, its availability: `DriveState.events`); if only actual values
    changed, once one of them moved ``deadband`` percent of the reference or more from the
    value last published, and not sooner than ``interval`` seconds after the last state
    published - the newest one then, so that the last state of a ramp is always published.
    ``interval`` 0: no wait; ``deadband`` 0: every change counts."""

    def __init__(self, interval: float = 0.0, deadband: float = 0.0) -> None:
        self.interval = interval
        self.deadband = deadband
        self._last: DriveState | None = None
        self._events: tuple[object, ...] = ()
        self._time = 0.0

    def offer(self, state: DriveState, now: float) -> float | None:
        """Seconds to wait before ``state`` is published (0: now); None: not to be published
        (its actual values are within the deadband of those published, nothing else
        changed): a state held back earlier is dropped then too, being no newer than the
        one published."""
        last = self._last
        if last is None or state.events() != self._events:
            return 0.0
        if not self._moved(state, last):
            return None
        return max(0.0, self._time + self.interval - now)

    def sent(self, state: DriveState, now: float) -> None:
        """``state`` was published at ``now``."""
        self._last = state
        self._events = state.events()
        self._time = now

    def _moved(self, state: DriveState, last: DriveState) -> bool:
        if state.actual.keys() != last.actual.keys():
            return True
        band = self.deadband
        for key, value in state.actual.items():
            before = last.actual[key].percent
            if value.percent != before and abs(value.percent - before) >= band:
                return True
        return False


def param_payload(reading: ParamValue) -> bytes:
    """The message of a parameter as last read (schema ``param.json``)."""
    data = {"v": CONTRACT_VERSION, **reading_dict(reading)}
    return json.dumps(data, separators=(",", ":")).encode()


def reply_payload(
    command: Command,
    *,
    result: dict[str, Any] | None = None,
    error: dict[str, Any] | None = None,
    duplicate: bool = False,
) -> dict[str, Any]:
    """The reply to ``command`` (schema ``reply.json``)."""
    reply: dict[str, Any] = {
        "v": CONTRACT_VERSION,
        "id": command.id,
        "command": command.name,
        "drive": command.drive,
        "ok": error is None,
    }
    if error is None:
        reply["result"] = result or {}
    else:
        reply["error"] = error
    if duplicate:
        reply["duplicate"] = True
    return reply


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c in "_-" else "_" for c in text)


def discovery_node(model: DriveModel) -> str:
    """The node id of a drive in Home Assistant's discovery topics: ``pyuss_BUS_DRIVE``."""
    return _slug(f"pyuss_{model.bus}_{model.name}")


def _item(group: str, key: str, field: str) -> str:
    """The Jinja expression of a field of a configured process value (``value_json.actual
    ['main'].value``): the key in brackets, since a key may hold ``-`` or read like a
    method of the object (``items``)."""
    return f"value_json.{group}[{json.dumps(key)}].{field}"


def _bit_template(bit: int, active_low: bool = False) -> str:
    """``ON`` or ``OFF`` for status bit ``bit`` (``active_low``: ON while it is 0), ``None``
    (Home Assistant: unknown) before the drive's first answer."""
    on, off = ("'OFF'", "'ON'") if active_low else ("'ON'", "'OFF'")
    return (
        "{{ 'None' if value_json.status_word is none else "
        f"({on} if value_json.status_word | bitwise_and({1 << bit}) else {off}) }}}}"
    )


_LOW_ACTIVE = " (0 = active)"
"""How a family's status bit text marks a bit that is active while 0 (`Profile.status_bits`)."""

OWN_BITS: dict[int, tuple[str, str, str]] = {
    3: ("fault", "Fault", "problem"),
    7: ("warning", "Warning", "problem"),
    2: ("operation_enabled", "Running", "running"),
}
"""The status bits with binary sensors of their own: bit -> (object id, name, device class);
the other named bits are diagnostic binary sensors ``bitN``."""


def status_bit_names(profile: str | None) -> dict[int, tuple[str, bool]]:
    """The named status bits of a drive's family: bit -> (what it shows when active, whether
    it is active while 0): the family's texts (`Profile.status_bits`), else the USS
    specification's meanings of bits 0..10 (C Tables 5.5, 5.6); device-specific bits without
    a text have none."""
    family = get_profile(profile).status_bits if profile is not None else {}
    if not family:
        return {bit: (texts[0], False) for bit, texts in STATUS_BITS.items()}
    return {
        bit: (text.removesuffix(_LOW_ACTIVE), text.endswith(_LOW_ACTIVE))
        for bit, text in family.items()
    }


def _jinja_texts(texts: Mapping[int, str]) -> str:
    """A Jinja dict literal of numbered texts (``{1: "overcurrent", ...}``)."""
    return "{" + ", ".join(f"{number}: {json.dumps(text)}" for number, text in texts.items()) + "}"


def _device(model: DriveModel) -> dict[str, Any]:
    """The Home Assistant device of a drive: maker and model from its profile."""
    device: dict[str, Any] = {
        "identifiers": [discovery_node(model)],
        "name": f"{model.name} ({model.bus})",
    }
    if model.profile is None:
        device["model"] = "USS drive of unknown kind (no profile named)"
        return device
    profile = get_profile(model.profile)
    if profile.manufacturer:
        device["manufacturer"] = profile.manufacturer
    device["model"] = profile.title
    device["model_id"] = profile.name
    return device


def discovery(
    model: DriveModel,
    state: DriveState,
    *,
    prefix: str,
    discovery_prefix: str = "homeassistant",
    read_only: bool = False,
) -> list[tuple[str, dict[str, Any]]]:
    """The Home Assistant discovery messages of one drive: ``(topic, config)`` pairs, to be
    published retained. Every template renders with every state message: the keys it names
    are always there, ``null`` (Home Assistant: unknown) where nothing is known yet."""
    topics = DriveTopics(prefix, model.bus, model.name)
    node = discovery_node(model)
    device = _device(model)
    origin = {"name": "pyuss", "sw_version": __version__}
    availability = [{"topic": topics.bus_availability}, {"topic": topics.availability}]
    messages: list[tuple[str, dict[str, Any]]] = []

    def add(component: str, what: str, name: str, config: dict[str, Any]) -> None:
        unique = f"{node}_{_slug(what)}"
        config = {
            "name": name,
            "unique_id": unique,
            "default_entity_id": f"{component}.{unique.lower().replace('-', '_')}",
            "device": device,
            "origin": origin,
            "availability": availability,
            "availability_mode": "all",
            **config,
        }
        messages.append((f"{discovery_prefix}/{component}/{node}/{_slug(what)}/config", config))

    add(
        "sensor",
        "state",
        "State",
        {
            "state_topic": topics.state,
            "value_template": "{{ value_json.state }}",
            "json_attributes_topic": topics.state,
            "json_attributes_template": (
                '{{ {"status_word": value_json.status_hex, "time": value_json.time} | tojson }}'
            ),
        },
    )
    for item in model.actual:
        unit = model.unit
        config: dict[str, Any] = {
            "state_topic": topics.state,
            "value_template": f"{{{{ {_item('actual', item.key, 'value')} }}}}",
            "state_class": "measurement",
            "suggested_display_precision": process_decimals(item.dword, unit, state.reference)[0],
        }
        if unit:
            config["unit_of_measurement"] = unit
        if unit in DEVICE_CLASSES:
            config["device_class"] = DEVICE_CLASSES[unit]
        add("sensor", f"actual_{item.key}", f"Actual value {item.key}", config)
    for point in model.parameters:
        meta = point.meta
        config = {
            "state_topic": topics.param(meta.key),
            "value_template": "{{ value_json.value }}",
        }
        if meta.writable:  # a setting (P1120); a value the drive shows (r0027, r0039) is no
            config["entity_category"] = "diagnostic"  # diagnostic, but what the plant watches
        places = param_places(meta)
        if places is not None:
            config["suggested_display_precision"] = places
        device_class = DEVICE_CLASSES.get(meta.unit)
        if meta.unit:
            config["unit_of_measurement"] = meta.unit
            config["state_class"] = STATE_CLASSES.get(device_class or "", "measurement")
        if device_class is not None:
            config["device_class"] = device_class
        add("sensor", f"param_{meta.key}", f"{meta.shown} {meta.name}", config)
    if model.fault is not None:
        texts = get_profile(model.profile).fault_names if model.profile is not None else {}
        add(
            "sensor",
            "last_fault",
            "Last fault",
            {
                "state_topic": topics.state,
                "value_template": "{{ value_json.health.last_fault }}",
                "suggested_display_precision": 0,  # a number: None is unknown
                "json_attributes_topic": topics.state,
                "json_attributes_template": (
                    f'{{{{ {{"text": {_jinja_texts(texts)}.get(value_json.health.last_fault), '
                    '"time": value_json.health.last_fault_time} | tojson }}'
                ),
            },
        )
    for bit, (what, name, device_class) in OWN_BITS.items():
        add(
            "binary_sensor",
            what,
            name,
            {
                "state_topic": topics.state,
                "value_template": _bit_template(bit),
                "payload_on": "ON",
                "payload_off": "OFF",
                "device_class": device_class,
            },
        )
    for bit, (text, active_low) in status_bit_names(model.profile).items():
        if bit in OWN_BITS:
            continue
        add(
            "binary_sensor",
            f"bit{bit}",
            f"Status bit {bit}: {text}",
            {
                "state_topic": topics.state,
                "value_template": _bit_template(bit, active_low),
                "payload_on": "ON",
                "payload_off": "OFF",
                "entity_category": "diagnostic",
            },
        )
    if read_only:
        return messages
    if model.setpoints:
        item = model.setpoints[0]
        places = min(process_decimals(item.dword, model.unit, state.reference)[0], 3)
        span = setpoint_span(state.reference, model.unit, dword=item.dword, places=places)
        # until the reference is known the setpoint is taken in percent only
        percent = span.unit == "%" and model.unit != "%"
        config = {
            "command_topic": topics.command("setpoint_percent" if percent else "setpoint"),
            "retain": False,  # a retained command never acts
            "state_topic": topics.state,
            "value_template": (
                f"{{{{ {_item('setpoint', item.key, 'percent' if percent else 'value')} }}}}"
            ),
            "min": span.low,
            "max": span.high,
            "step": 10.0**-span.places,
            "mode": "box",
            "unit_of_measurement": span.unit,
        }
        if DEVICE_CLASSES.get(span.unit) in ("frequency", "current", "voltage"):
            config["device_class"] = DEVICE_CLASSES[span.unit]
        add("number", "setpoint", "Setpoint", config)
        add(
            "switch",
            "run",
            "Run (ON / OFF1)",
            {
                "command_topic": topics.command("run"),
                "retain": False,
                "state_topic": topics.state,
                "value_template": _bit_template(2),
                "payload_on": "ON",
                "payload_off": "OFF",
                "state_on": "ON",
                "state_off": "OFF",
            },
        )
        for command, name in (
            ("acknowledge", "Acknowledge fault"),
            ("off2", "Coast stop (OFF2)"),
            ("off3", "Quick stop (OFF3)"),
        ):
            add(
                "button",
                command,
                name,
                {
                    "command_topic": topics.command(command),
                    "payload_press": "PRESS",
                    "retain": False,
                },
            )
    return messages
