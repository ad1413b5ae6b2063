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

A command's payload is a JSON object - ``{"id": "42", "value": 25.0}``, with ``reply_to``
for another reply topic - or a plain value (``25``, ``ON``, ``PRESS``, nothing). A command with
an ``id`` is carried out once: a repeated id (an MQTT QoS 1 duplicate, a client's retry) is
answered with the first result again and not applied twice. Commands without an id (Home
Assistant's) are all applied; those it sends are the same whether applied once or twice.

Replies: ``{"id", "command", "drive", "ok": true, "result": {...}}`` or ``{"ok": false,
"error": {"type", "message", "class", "number", "meaning"}}`` (`pyuss.points.errors`).

Home Assistant discovery (`discovery`): per drive one device with sensors for the state text,
the status word, every actual value and configured parameter (with unit and, where the unit
has one, the device class), binary sensors for fault, warning and operation enabled, a number
for the main setpoint, a switch for ON/OFF1 and buttons for acknowledge, OFF2 and OFF3; all
available while the gateway and the drive are.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

from pyuss import __version__
from pyuss.errors import ConfigError
from pyuss.points.config import parse_parameter_spec
from pyuss.points.model import DriveModel
from pyuss.points.state import DriveState, ParamValue

__all__ = [
    "COMMAND_NAMES",
    "Command",
    "DriveTopics",
    "discovery",
    "parse_command",
    "reply_payload",
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


def _payload(raw: bytes) -> tuple[dict[str, Any], Any]:
    """(JSON object fields, plain value)."""
    text = raw.decode("utf-8", errors="strict").strip() if raw else ""
    if not text:
        return {}, None
    try:
        data = json.loads(text)
    except ValueError:
        return {}, text
    if isinstance(data, dict):
        return data, data.get("value")
    return {}, data


def _param(value: object) -> tuple[int, int | None]:
    if isinstance(value, int) and not isinstance(value, bool):
        return value, None
    if isinstance(value, str):
        return parse_parameter_spec(value)
    raise ConfigError(f"a parameter is a PNU or 'PNU.INDEX', not {value!r}")


def parse_command(topic: str, payload: bytes, prefix: str, bus: str) -> Command:
    """The command of a message; `ConfigError` naming what is wrong (the drive part of the
    topic is kept in the message so that the reply can go to the right drive)."""
    parts = topic.split("/")
    head = [*prefix.split("/"), bus]
    if parts[: len(head)] != head or len(parts) < len(head) + 3:
        raise ConfigError(f"topic {topic!r} is not a command topic of bus {bus}")
    drive = parts[len(head)]
    rest = parts[len(head) + 1 :]
    try:
        fields, value = _payload(payload)
    except UnicodeDecodeError:
        raise ConfigError("the payload is not UTF-8 text") from None
    ident = fields.get("id")
    if ident is not None and not isinstance(ident, str | int):
        raise ConfigError(f"id must be a string or a number, not {ident!r}")
    reply_to = fields.get("reply_to")
    if reply_to is not None and (
        not isinstance(reply_to, str) or not reply_to or any(c in reply_to for c in "+#")
    ):
        raise ConfigError(f"reply_to must be a topic without wildcards, not {reply_to!r}")
    common: dict[str, Any] = {
        "drive": drive,
        "id": None if ident is None else str(ident),
        "reply_to": reply_to,
        "eeprom": bool(fields.get("eeprom", False)),
    }
    if rest[0] == "param" and len(rest) == 3 and rest[2] in ("set", "get"):
        param = _param(rest[1])
        name = "write" if rest[2] == "set" else "read"
        return Command(name=name, value=value, pnu=param[0], index=param[1], **common)
    if rest[0] != "cmd" or len(rest) != 2:
        raise ConfigError(f"topic {topic!r} is not a command topic")
    name = rest[1]
    if name not in COMMAND_NAMES:
        raise ConfigError(f"unknown command {name!r} (known: {', '.join(COMMAND_NAMES)})")
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
                raise ConfigError(f"index must be 0..254, not {index!r}")
        if name == "read":
            value = None
    key = fields.get("key", "main")
    if not isinstance(key, str):
        raise ConfigError(f"key must be a string, not {key!r}")
    return Command(name=name, value=value, pnu=pnu, index=index, key=key, **common)


def number(value: Any, what: str) -> float:
    """A number from a payload value (JSON number or text such as ``25``, ``0x047F``)."""
    if isinstance(value, bool) or value is None:
        raise ConfigError(f"{what}: expected a number, not {value!r}")
    if isinstance(value, int | float):
        result = float(value) if isinstance(value, float) else value
    elif isinstance(value, str):
        try:
            result = int(value, 0)
        except ValueError:
            try:
                result = float(value)
            except ValueError:
                raise ConfigError(f"{what}: {value!r} is not a number") from None
    else:
        raise ConfigError(f"{what}: expected a number, not {value!r}")
    if isinstance(result, float) and not math.isfinite(result):
        raise ConfigError(f"{what}: {value!r} is not a finite number")
    return result


def switch_value(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    if isinstance(value, str) and value.strip().upper() in ("ON", "OFF", "1", "0", "TRUE", "FALSE"):
        return value.strip().upper() in ("ON", "1", "TRUE")
    raise ConfigError(f"run: expected ON or OFF, not {value!r}")


def state_payload(state: DriveState) -> bytes:
    return json.dumps(state.to_dict(), separators=(",", ":")).encode()


def param_payload(reading: ParamValue) -> bytes:
    return json.dumps(reading.to_dict(), separators=(",", ":")).encode()


def reply_payload(
    command: Command,
    *,
    result: dict[str, Any] | None = None,
    error: dict[str, Any] | None = None,
    duplicate: bool = False,
) -> dict[str, Any]:
    reply: dict[str, Any] = {
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
        "model": f"profile {model.profile}, address {model.address}",
    }
    origin = {"name": "pyuss", "sw_version": __version__}
    availability = [{"topic": topics.bus_availability}, {"topic": topics.availability}]
    messages: list[tuple[str, dict[str, Any]]] = []

    def add(component: str, what: str, name: str, config: dict[str, Any]) -> None:
        unique = f"{node}_{_slug(what)}"
        config = {
            "name": name,
            "unique_id": unique,
            "object_id": unique,
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
            "state_topic": topics.state,
            "value_template": f"{{{{ value_json.setpoint.{item.key}.value }}}}",
            "min": low,
            "max": high,
            "step": 0.01,
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
                {"command_topic": topics.command(command), "payload_press": "PRESS"},
            )
    return messages
