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
`reading_dict`).

Home Assistant discovery (`discovery`): per drive one device with sensors for the state text,
the status word, every actual value and configured parameter (with unit and, where the unit
has one, the device class), binary sensors for fault, warning and operation enabled, a number
for the main setpoint, a switch for ON/OFF1 and buttons for acknowledge, OFF2 and OFF3; all
available while the gateway and the drive are; each names its entity id as
``default_entity_id`` (``sensor.pyuss_line1_conveyor_state``) and its display precision.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pyuss import __version__
from pyuss.errors import ConfigError
from pyuss.points.config import ProcessConfig, parse_parameter_spec
from pyuss.points.model import DriveModel
from pyuss.points.parameters import ParamMeta
from pyuss.points.state import COUNTER_FIELDS, DriveState, Health, ParamValue, iso
from pyuss.profiles import UNKNOWN_KIND
from pyuss.protocol.pzd import FULL_SCALE_16, FULL_SCALE_32
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
    "UnknownField",
    "UnsupportedVersion",
    "check_reply_to",
    "discovery",
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
}
"""Home Assistant sensor device class for a unit (units without one get none)."""


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


def _under(topic: str, prefix: str) -> bool:
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
    if _under(topic, topics.prefix) and not _under(topic, topics.reply):
        raise ConfigError(
            f"reply_to {show(topic)} is under the gateway's prefix {topics.prefix!r}: "
            f"replies go to {topics.reply} or a topic below it"
        )
    if _under(topic, discovery_prefix):
        raise ConfigError(f"reply_to {show(topic)} is under the discovery prefix")
    if (
        levels[-1] == "set"
        or (len(levels) >= 2 and levels[-2] == "cmd")
        or (len(levels) >= 3 and levels[-3] == "param" and levels[-1] == "get")
    ):
        raise ConfigError(f"reply_to {show(topic)} has the shape of a command topic")


@functools.lru_cache(maxsize=256)
def decimals(step: float) -> int:
    """The decimals a value that moves in steps of ``step`` is shown with: the first decimal
    place at or above the step (steps of 0.003 Hz: 2)."""
    if not math.isfinite(step) or step <= 0:
        return 6
    return max(0, math.floor(-math.log10(step) + 1e-9))


def process_decimals(item: ProcessConfig, unit: str, reference: float | None) -> tuple[int, int]:
    """(decimals of the value in its unit, decimals of the percent) of a process value: one
    raw step is 100 % / 4000h (16 bits) or / 4000 0000h (32 bits) of the reference."""
    step = 100.0 / (FULL_SCALE_32 if item.dword else FULL_SCALE_16)
    value_step = step if reference is None or unit == "%" else step * abs(reference) / 100.0
    return decimals(value_step), decimals(step)


def param_value(meta: ParamMeta, value: int | float | None) -> int | float | None:
    """A parameter's value rounded to its resolution: the decimals of its scaling, or the
    7 significant digits of a 32-bit float; integers as they are."""
    if not isinstance(value, float) or not math.isfinite(value):
        return value
    if meta.scaling is not None and not meta.is_float:
        return round(value, decimals(abs(meta.scaling)))
    return float(f"{value:.7g}")


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
    """The ``actual`` or ``setpoint`` part of `state_dict`."""
    model = state.model
    values, items = (
        (state.actual, model.actual) if group == "actual" else (state.setpoints, model.setpoints)
    )
    data = {key: value.to_dict() for key, value in values.items()}
    for item in items:
        entry = data.get(item.key)
        if entry is None:
            continue
        places, percent_places = process_decimals(item, model.unit, state.reference)
        if entry["value"] is not None:
            entry["value"] = round(entry["value"], places)
        entry["percent"] = round(entry["percent"], percent_places)
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
    "state",
    "bits",
    "control_word",
    "reference",
)


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


def discovery(
    model: DriveModel,
    state: DriveState,
    *,
    prefix: str,
    discovery_prefix: str = "homeassistant",
    read_only: bool = False,
) -> list[tuple[str, dict[str, Any]]]:
    """The Home Assistant discovery messages of one drive: ``(topic, config)`` pairs, to be
    published retained."""
    topics = DriveTopics(prefix, model.bus, model.name)
    node = _slug(f"pyuss_{model.bus}_{model.name}")
    device = {
        "identifiers": [node],
        "name": f"{model.name} ({model.bus})",
        "manufacturer": "USS drive",
        "model": f"profile {model.profile or '(unknown kind)'}, address {model.address}",
    }
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
        {"state_topic": topics.state, "value_template": "{{ value_json.state }}"},
    )
    add(
        "sensor",
        "status_word",
        "Status word",
        {
            "state_topic": topics.state,
            "value_template": "{{ value_json.status_word }}",
            "entity_category": "diagnostic",
        },
    )
    for item in model.actual:
        unit = state.model.unit
        config: dict[str, Any] = {
            "state_topic": topics.state,
            "value_template": f"{{{{ value_json.actual.{item.key}.value }}}}",
            "state_class": "measurement",
            "suggested_display_precision": process_decimals(item, unit, state.reference)[0],
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
            "entity_category": "diagnostic",
        }
        if meta.is_integer:
            config["suggested_display_precision"] = 0
        elif meta.scaling is not None and not meta.is_float:
            config["suggested_display_precision"] = decimals(abs(meta.scaling))
        if meta.unit:
            config["unit_of_measurement"] = meta.unit
            config["state_class"] = "measurement"
        if meta.unit in DEVICE_CLASSES:
            config["device_class"] = DEVICE_CLASSES[meta.unit]
        add("sensor", f"param_{meta.key}", f"{meta.key} {meta.name}", config)
    for bit, name, device_class in (
        ("fault", "Fault", "problem"),
        ("warning", "Warning", "problem"),
        ("operation_enabled", "Running", "running"),
    ):
        add(
            "binary_sensor",
            bit,
            name,
            {
                "state_topic": topics.state,
                "value_template": f"{{{{ 'ON' if value_json.bits.{bit} else 'OFF' }}}}",
                "payload_on": "ON",
                "payload_off": "OFF",
                "device_class": device_class,
            },
        )
    if read_only:
        return messages
    if model.setpoints:
        item = model.setpoints[0]
        unit = model.unit
        full = state.reference if state.reference is not None and unit != "%" else 100.0
        low, high = -2 * full, round(2 * full * (0x7FFF / 0x8000), 2)
        config = {
            "command_topic": topics.command("setpoint"),
            "retain": False,  # a retained command never acts
            "state_topic": topics.state,
            "value_template": f"{{{{ value_json.setpoint.{item.key}.value }}}}",
            "min": low,
            "max": high,
            "step": 10.0 ** -process_decimals(item, unit, state.reference)[0],
            "mode": "box",
        }
        if unit:
            config["unit_of_measurement"] = unit
        if unit in DEVICE_CLASSES and DEVICE_CLASSES[unit] in ("frequency", "current", "voltage"):
            config["device_class"] = DEVICE_CLASSES[unit]
        add("number", "setpoint", "Setpoint", config)
        add(
            "switch",
            "run",
            "Run (ON / OFF1)",
            {
                "command_topic": topics.command("run"),
                "retain": False,
                "state_topic": topics.state,
                "value_template": "{{ 'ON' if value_json.bits.operation_enabled else 'OFF' }}",
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
