"""The gateway's configuration: the plant (`pyuss.points.config`) and the faces' options.

One TOML file (``uss gateway --config plant.toml``) holds the buses and drives (``[[bus]]``
tables, see `pyuss.points.config`) and one table per face::

    [modbus]
    listen = "127.0.0.1:5020"        # default; a bus may have its own: modbus = "..." in [[bus]]
    word_order = "big"               # of 32-bit values: "big" (high word first) or "little"
    read_only = false

    [mqtt]
    broker = "mqtt://127.0.0.1:1883" # mqtts:// for TLS; user and password may stand in the URL
    prefix = "uss"
    username = "gateway"             # or in the URL
    password = "..."
    ca = "/etc/ssl/certs/ca.pem"     # TLS: CA file, client certificate and key (optional)
    cert = "client.pem"
    key = "client.key"
    client_id = "pyuss-{bus}"        # one MQTT session per bus; {bus} is its name
    discovery = true                 # Home Assistant discovery
    discovery_prefix = "homeassistant"
    read_only = false
    max_rate = 10                    # state messages per drive and second at most (0: no limit)
    deadband = 0.0                   # % of the reference an actual value moves to be sent again

    [opcua]
    listen = "opc.tcp://127.0.0.1:4840"
    security = ["None"]              # and/or "Basic256Sha256_Sign", "Basic256Sha256_SignAndEncrypt"
    certificate = "server.der"       # needed by the signing policies
    private_key = "server.pem"
    users = { operator = "secret" }  # may write and call commands
    anonymous = "read"               # "read" (default), "write" or "none"
    read_only = false

A face without its table is not started. Bad configuration raises `ConfigError` naming the key,
before anything is opened. Which tables there are comes from the registry of faces
(`pyuss.gateway.faces`): each face's entry reads its own table (the options of pyuss's faces
and their readers are in `pyuss.gateway.options`; the options and `mqtt_options` are imported
from here too).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from pyuss.errors import ConfigError
from pyuss.gateway.faces import faces
from pyuss.gateway.options import ModbusOptions, MqttOptions, OpcuaOptions, mqtt_options
from pyuss.points.config import PlantConfig, Where, parse_plant
from pyuss.points.endpoint import Endpoint
from pyuss.points.model import resolve
from pyuss.userfile import in_file, parse_toml, read_text

__all__ = [
    "GatewayConfig",
    "ModbusOptions",
    "MqttOptions",
    "OpcuaOptions",
    "check_listening",
    "listening",
    "load_config",
    "mqtt_options",
    "parse_config",
]


@dataclass(frozen=True, slots=True)
class GatewayConfig:
    """The plant and the options of each face configured (None: not started). pyuss's faces
    have a field each; the options of other faces (`pyuss.gateway.faces`) are in ``faces``.
    `face` and `with_face` treat them alike."""

    plant: PlantConfig
    modbus: ModbusOptions | None = None
    mqtt: MqttOptions | None = None
    opcua: OpcuaOptions | None = None
    faces: Mapping[str, Any] = field(default_factory=dict)

    def face(self, name: str) -> Any:
        """The options of the face ``name``, None if it is not configured."""
        if name in _FIELDS:
            return getattr(self, name)
        return self.faces.get(name)

    def with_face(self, name: str, options: Any) -> GatewayConfig:
        """This configuration with the options of the face ``name`` (None: not started)."""
        if name in _FIELDS:
            return replace(self, **{name: options})
        others = {key: value for key, value in self.faces.items() if key != name}
        if options is not None:
            others[name] = options
        return replace(self, faces=others)


_FIELDS = frozenset(f.name for f in fields(GatewayConfig)) - {"plant", "faces"}


def parse_config(data: Mapping[str, Any], base: Path | None = None) -> GatewayConfig:
    """The gateway configuration from a TOML document (already parsed): ``[[bus]]``, a table
    per face of the registry, and ``[web]``, which belongs to ``uss web`` (left alone)."""
    registry = faces()
    Where("").table(data, ("bus", *registry, "web"))
    bus_keys = tuple(key for spec in registry.values() for key in spec.bus_keys)
    plant = parse_plant(data.get("bus"), Where("bus"), face_keys=bus_keys)
    config = GatewayConfig(plant)
    for name, spec in registry.items():
        if name in data:
            config = config.with_face(name, spec.read(data[name], Where(name), plant, base))
            continue
        for number, bus in enumerate(plant.buses):
            for key in spec.bus_keys:
                if key in bus.extra:  # would be left unapplied: no such face starts
                    raise (
                        Where("bus")
                        .key(number)
                        .key(key)
                        .error(
                            f"belongs to the {name} face, which has no [{name}] table: add one "
                            "(it may be empty)"
                        )
                    )
    if config.mqtt is not None and config.mqtt.discovery:
        _distinct_devices(plant)
    return config


def _distinct_devices(plant: PlantConfig) -> None:
    """`ConfigError` if two drives would be one Home Assistant device (``pyuss_BUS_DRIVE``:
    bus ``a_b`` and drive ``c`` of bus ``a`` named ``b_c``): the discovery messages of the
    one would replace the other's."""
    seen: dict[str, str] = {}
    for number, bus in enumerate(plant.buses):
        for index, drive in enumerate(bus.drives):
            node = f"pyuss_{bus.name}_{drive.name}"
            if node in seen:
                raise (
                    Where("bus")
                    .key(number)
                    .key("drive")
                    .key(index)
                    .key("name")
                    .error(
                        f"drive {drive.name!r} of bus {bus.name!r} and drive {seen[node]} would "
                        f"be one Home Assistant device ({node}): rename one"
                    )
                )
            seen[node] = f"{drive.name!r} of bus {bus.name!r}"


def listening(config: GatewayConfig) -> list[tuple[str, Endpoint]]:
    """The addresses pyuss's faces listen on, each with the face's name as printed (``modbus
    line1``: a bus's own Modbus server); a shared Modbus address no bus uses is left out."""
    found: list[tuple[str, Endpoint]] = []
    if config.modbus is not None:
        own = config.modbus.bus_endpoints
        if any(bus.name not in own for bus in config.plant.buses):
            found.append(("modbus", config.modbus.endpoint))
        found.extend((f"modbus {bus}", endpoint) for bus, endpoint in own.items())
    if config.opcua is not None:
        found.append(("opcua", config.opcua.endpoint))
    return found


def check_listening(config: GatewayConfig) -> None:
    """`ConfigError` if two faces would listen on one port of one host (or one of them on
    every interface), found before any port opens."""
    seen: list[tuple[str, Endpoint]] = []
    for name, endpoint in listening(config):
        for other, there in seen:
            wildcard = {endpoint.host, there.host} & {"0.0.0.0", "::", ""}
            if (
                endpoint.port
                and endpoint.port == there.port
                and (endpoint.host == there.host or wildcard)
            ):
                raise ConfigError(
                    f"{name} {endpoint} and {other} {there} listen on one port: give each "
                    "face and bus an address of its own"
                )
        seen.append((name, endpoint))


def load_config(path: str | Path) -> GatewayConfig:
    """Read and check a configuration file; `ConfigError` names the file and the key."""
    path = Path(path)
    text = read_text(path, "the configuration")
    data = parse_toml(text, str(path))
    try:
        config = parse_config(data, path.parent)
        resolve(config.plant)  # what the points cannot show is bad configuration too
        return config
    except ConfigError as exc:
        raise in_file(path, text, exc) from None
