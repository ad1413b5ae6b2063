"""Home Assistant's MQTT discovery schema, as far as the gateway uses it, written from Home
Assistant's documentation of MQTT discovery and of the MQTT sensor, binary sensor, number,
switch and button integrations: the topic structure, the required and the known options of
each component, the device classes and the units each sensor device class accepts, and the
entity id a discovery message may suggest (``default_entity_id``, ``DOMAIN.slug``; the
deprecated ``object_id`` is ignored from Home Assistant Core 2026.4).

Also: the device block's known keys (``manufacturer``, ``model``, ``model_id``...), the origin
block (``name`` required), ``availability`` never beside ``availability_topic``, a
``json_attributes_template`` only with its topic, the energy device class only with a
``total`` or ``total_increasing`` state class, sensors never of entity category
``config``, a number's step at least 0.001.

`check(topic, config)` returns the list of what breaks the schema (empty: valid)."""

from __future__ import annotations

import re
from typing import Any

TOPIC = re.compile(
    r"^(?P<prefix>[^/#+]+)/(?P<component>[a-z_]+)/(?:(?P<node>[a-zA-Z0-9_-]+)/)?"
    r"(?P<object>[a-zA-Z0-9_-]+)/config$"
)

COMMON = {
    "name",
    "unique_id",
    "default_entity_id",
    "device",
    "origin",
    "availability",
    "availability_mode",
    "availability_topic",
    "payload_available",
    "payload_not_available",
    "entity_category",
    "enabled_by_default",
    "icon",
    "qos",
    "json_attributes_topic",
    "json_attributes_template",
    "encoding",
}

COMPONENTS: dict[str, tuple[set[str], set[str]]] = {
    # component: (required options, further known options)
    "sensor": (
        {"state_topic"},
        {
            "value_template",
            "unit_of_measurement",
            "device_class",
            "state_class",
            "expire_after",
            "force_update",
            "suggested_display_precision",
            "last_reset_value_template",
            "options",
        },
    ),
    "binary_sensor": (
        {"state_topic"},
        {
            "value_template",
            "payload_on",
            "payload_off",
            "device_class",
            "expire_after",
            "force_update",
            "off_delay",
        },
    ),
    "number": (
        {"command_topic"},
        {
            "command_template",
            "state_topic",
            "value_template",
            "min",
            "max",
            "step",
            "mode",
            "unit_of_measurement",
            "device_class",
            "optimistic",
            "payload_reset",
            "retain",
        },
    ),
    "switch": (
        {"command_topic"},
        {
            "state_topic",
            "value_template",
            "payload_on",
            "payload_off",
            "state_on",
            "state_off",
            "device_class",
            "optimistic",
            "retain",
            "command_template",
        },
    ),
    "button": (
        {"command_topic"},
        {"payload_press", "device_class", "retain", "command_template"},
    ),
}

SENSOR_UNITS: dict[str, set[str | None]] = {
    "current": {"A", "mA"},
    "duration": {"d", "h", "min", "s", "ms"},
    "energy": {"J", "kJ", "MJ", "GJ", "mWh", "Wh", "kWh", "MWh", "GWh", "TWh", "cal", "kcal"},
    "frequency": {"Hz", "kHz", "MHz", "GHz"},
    "power": {"mW", "W", "kW", "MW", "GW", "TW"},
    "power_factor": {"%", None},
    "temperature": {"°C", "°F", "K"},
    "voltage": {"V", "mV", "µV", "kV", "MV"},
}
"""Sensor device classes the gateway may use, with the units Home Assistant accepts."""

NUMBER_UNITS = {k: v for k, v in SENSOR_UNITS.items() if k != "power_factor"}
TOTALS = {"energy": {"total", "total_increasing"}}
"""Sensor device classes that take only these state classes (not ``measurement``)."""
DEVICE_KEYS = {
    "configuration_url",
    "connections",
    "identifiers",
    "name",
    "manufacturer",
    "model",
    "model_id",
    "hw_version",
    "sw_version",
    "suggested_area",
    "serial_number",
    "via_device",
}
ORIGIN_KEYS = {"name", "sw_version", "support_url"}
NUMBER_STEP = 0.001
"""The smallest step a number takes."""

BINARY_SENSOR_CLASSES = {
    "battery",
    "connectivity",
    "moving",
    "power",
    "problem",
    "running",
    "safety",
}
BUTTON_CLASSES = {"identify", "restart", "update"}
SWITCH_CLASSES = {"outlet", "switch"}
STATE_CLASSES = {"measurement", "measurement_angle", "total", "total_increasing"}
ENTITY_CATEGORIES = {"config", "diagnostic"}
WILDCARDS = re.compile(r"[#+]")
ENTITY_ID = re.compile(r"^(?P<domain>[a-z_]+)\.[a-z0-9_]+$")
DEPRECATED = {
    "object_id": "object_id is ignored from Home Assistant Core 2026.4: use default_entity_id",
}


def check(topic: str, config: dict[str, Any]) -> list[str]:
    problems: list[str] = []
    match = TOPIC.match(topic)
    if match is None:
        return [f"{topic}: not <prefix>/<component>/[<node_id>/]<object_id>/config"]
    component = match["component"]
    if component not in COMPONENTS:
        return [f"{topic}: component {component!r} is not one the gateway uses"]
    required, known = COMPONENTS[component]
    for key in sorted(required - config.keys()):
        problems.append(f"{topic}: {key} is required")
    for key in sorted(config.keys() & DEPRECATED.keys()):
        problems.append(f"{topic}: {DEPRECATED[key]}")
    for key in sorted(config.keys() - required - known - COMMON - DEPRECATED.keys()):
        problems.append(f"{topic}: {key} is not an option of {component}")
    if "default_entity_id" in config:
        entity = ENTITY_ID.match(str(config["default_entity_id"]))
        if entity is None or entity["domain"] != component:
            problems.append(f"{topic}: default_entity_id must be {component}.<lower-case slug>")
    precision = config.get("suggested_display_precision", 0)
    if isinstance(precision, bool) or not isinstance(precision, int) or precision < 0:
        problems.append(f"{topic}: suggested_display_precision must be a whole number >= 0")
    for key, value in config.items():
        if key.endswith("_topic") and (not isinstance(value, str) or WILDCARDS.search(value)):
            problems.append(f"{topic}: {key} must be a topic without wildcards")
    if "unique_id" not in config:
        problems.append(f"{topic}: a device needs entities with unique_id")
    device = config.get("device")
    if not isinstance(device, dict) or not (device.get("identifiers") or device.get("connections")):
        problems.append(f"{topic}: device needs identifiers or connections")
    elif device.keys() - DEVICE_KEYS:
        problems.append(f"{topic}: device keys {sorted(device.keys() - DEVICE_KEYS)} unknown")
    origin = config.get("origin", {"name": "-"})
    if not isinstance(origin, dict) or "name" not in origin or origin.keys() - ORIGIN_KEYS:
        problems.append(f"{topic}: origin needs a name and knows {sorted(ORIGIN_KEYS)}")
    if "json_attributes_template" in config and "json_attributes_topic" not in config:
        problems.append(f"{topic}: json_attributes_template needs json_attributes_topic")
    if "availability" in config and "availability_topic" in config:
        problems.append(f"{topic}: availability and availability_topic exclude each other")
    for item in config.get("availability", []):
        if "topic" not in item:
            problems.append(f"{topic}: availability entries need a topic")
    if config.get("availability_mode", "latest") not in ("all", "any", "latest"):
        problems.append(f"{topic}: availability_mode must be all, any or latest")
    if "entity_category" in config and config["entity_category"] not in ENTITY_CATEGORIES:
        problems.append(f"{topic}: entity_category must be config or diagnostic")
    device_class = config.get("device_class")
    unit = config.get("unit_of_measurement")
    if component == "sensor":
        if device_class is not None:
            if device_class not in SENSOR_UNITS:
                problems.append(f"{topic}: unknown sensor device class {device_class!r}")
            elif unit not in SENSOR_UNITS[device_class]:
                problems.append(f"{topic}: unit {unit!r} is not one of {device_class}")
        if "state_class" in config and config["state_class"] not in STATE_CLASSES:
            problems.append(f"{topic}: state_class {config['state_class']!r}")
        if device_class in TOTALS and config.get("state_class") not in TOTALS[device_class]:
            problems.append(f"{topic}: {device_class} takes state_class {TOTALS[device_class]}")
        if config.get("entity_category") == "config":
            problems.append(f"{topic}: a sensor cannot be of entity_category config")
    elif component == "binary_sensor":
        if config.get("entity_category") == "config":
            problems.append(f"{topic}: a binary sensor cannot be of entity_category config")
        if device_class is not None and device_class not in BINARY_SENSOR_CLASSES:
            problems.append(f"{topic}: unknown binary sensor device class {device_class!r}")
    elif component == "number":
        if device_class is not None and (
            device_class not in NUMBER_UNITS or unit not in NUMBER_UNITS[device_class]
        ):
            problems.append(f"{topic}: device class {device_class!r} with unit {unit!r}")
        low, high = config.get("min", 1), config.get("max", 100)
        if not low < high:
            problems.append(f"{topic}: min must be below max")
        if config.get("step", 1) < NUMBER_STEP:
            problems.append(f"{topic}: step must be {NUMBER_STEP} or more")
        if config.get("mode", "auto") not in ("auto", "box", "slider"):
            problems.append(f"{topic}: mode must be auto, box or slider")
    elif component == "button":
        if device_class is not None and device_class not in BUTTON_CLASSES:
            problems.append(f"{topic}: unknown button device class {device_class!r}")
    elif component == "switch" and device_class is not None and device_class not in SWITCH_CLASSES:
        problems.append(f"{topic}: unknown switch device class {device_class!r}")
    return problems
