"""The Home Assistant discovery messages of a drive (MQTT discovery), without a broker: the
entities Home Assistant makes of the topics of `pyuss.gateway.topics` and the messages of
`pyuss.gateway.payloads`.

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
from collections.abc import Mapping
from typing import Any

from pyuss import __version__
from pyuss.gateway.payloads import param_places
from pyuss.gateway.topics import DriveTopics
from pyuss.points.model import DriveModel
from pyuss.points.state import DriveState, process_decimals, setpoint_span
from pyuss.profiles import get_profile
from pyuss.protocol.pzd import STATUS_BITS

__all__ = [
    "DEVICE_CLASSES",
    "OWN_BITS",
    "STATE_CLASSES",
    "discovery",
    "discovery_node",
    "of_bus",
    "status_bit_names",
]

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


def of_bus(payload: object, availability: str) -> bool:
    """A discovery message of an entity available through the bus availability topic
    ``availability``: one of that bus's gateway."""
    if not isinstance(payload, bytes | str) or not payload:
        return False
    try:
        config = json.loads(payload)
    except ValueError:
        return False
    entries = config.get("availability") if isinstance(config, dict) else None
    return isinstance(entries, list) and {"topic": availability} in entries
