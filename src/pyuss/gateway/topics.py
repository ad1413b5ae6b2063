"""The MQTT topics of a bus and its drives and the commands they carry, parsed without a
broker: the contract's topics and commands. What the gateway publishes on them is
`pyuss.gateway.payloads`; Home Assistant's discovery messages are
`pyuss.gateway.homeassistant`.

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

The topics and payloads are a versioned contract: JSON Schema files shipped in the package
(``pyuss/gateway/schemas``, docs/gateway.md "The MQTT contract"). Every JSON payload the
gateway publishes carries the contract version as ``"v": 1`` (`CONTRACT_VERSION`); a command
may name the version it is written in (``v``) and is refused if the gateway does not speak
it (`VERSIONS`, `UnsupportedVersion`). A JSON command holds only the fields of its topic
(`FIELDS`): a misspelt field is refused (`UnknownField`), never ignored. These refusals carry
the command's id (`CommandError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from pyuss.errors import ConfigError
from pyuss.points.config import parse_parameter_spec
from pyuss.userfile import NotJson, parse_message

__all__ = [
    "COMMAND_NAMES",
    "CONTRACT_VERSION",
    "FIELDS",
    "VERSIONS",
    "Command",
    "CommandError",
    "DriveTopics",
    "UnknownField",
    "UnsupportedVersion",
    "check_reply_to",
    "parse_command",
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


def drive_of(topic: str, prefix: str, bus: str) -> str | None:
    """The drive part of a topic of bus ``bus`` (None: the topic is none of the bus's drives),
    for the reply to a message that is no command."""
    parts = topic.split("/")
    head = [*prefix.split("/"), bus]
    if parts[: len(head)] == head and len(parts) > len(head):
        return parts[len(head)]
    return None


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
