"""The options of pyuss's own faces, one table of the configuration file each (Modbus, MQTT,
OPC UA; the whole file: `pyuss.gateway.config`), and the readers of those tables, which their
entries in the registry of faces (`pyuss.gateway.faces`) name.

Each reader checks its table and raises `ConfigError` naming the key, before anything is
opened.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyuss.errors import ConfigError
from pyuss.gateway.registers import WordOrder
from pyuss.points.config import PlantConfig, Where
from pyuss.points.endpoint import Endpoint, parse_endpoint

__all__ = [
    "ANONYMOUS",
    "DEFAULT_MODBUS",
    "DEFAULT_MQTT",
    "DEFAULT_OPCUA",
    "MAX_RATE",
    "MAX_RATE_LIMIT",
    "RECONNECT_MAX",
    "SECURITY_POLICIES",
    "STOP_WAIT",
    "ModbusOptions",
    "MqttOptions",
    "OpcuaOptions",
    "modbus_options",
    "mqtt_options",
    "opcua_options",
]

DEFAULT_MODBUS = "127.0.0.1:5020"
DEFAULT_MQTT = "mqtt://127.0.0.1:1883"
DEFAULT_OPCUA = "opc.tcp://127.0.0.1:4840"
STOP_WAIT = 5.0
"""Seconds a face's stop waits for the requests being carried out to finish and be answered
(Modbus, MQTT, OPC UA alike): no write is cut between its parts, none is left unanswered."""
RECONNECT_MAX = 60.0
"""The longest wait between two tries to reach the MQTT broker (seconds)."""
MAX_RATE = 10.0
"""The state messages a drive publishes per second at most, by default (``max_rate``): a
drive alone on a bus answers some 80 times a second, each answer of a ramping drive a state."""
MAX_RATE_LIMIT = 1000.0
"""The greatest ``max_rate`` taken (more than any bus's answers a second)."""
SECURITY_POLICIES = ("None", "Basic256Sha256_Sign", "Basic256Sha256_SignAndEncrypt")
ANONYMOUS = ("read", "write", "none")


@dataclass(frozen=True, slots=True)
class ModbusOptions:
    endpoint: Endpoint
    word_order: WordOrder = WordOrder.BIG
    read_only: bool = False
    bus_endpoints: Mapping[str, Endpoint] = field(default_factory=dict)
    """Buses with a Modbus address of their own."""


@dataclass(frozen=True, slots=True)
class MqttOptions:
    endpoint: Endpoint
    prefix: str = "uss"
    username: str | None = None
    password: str | None = field(default=None, repr=False)
    ca: str | None = None
    cert: str | None = None
    key: str | None = None
    insecure: bool = False
    client_id: str = "pyuss-{bus}"
    discovery: bool = True
    discovery_prefix: str = "homeassistant"
    read_only: bool = False
    keepalive: int = 30
    reconnect: float = 1.0
    """Seconds between attempts to reach the broker again."""
    max_rate: float = MAX_RATE
    """State messages per second per drive at most (0: one per change); a change of anything
    but the actual values (a status bit, a fault, a command's result) is published at once
    (`pyuss.gateway.payloads.StateThrottle`)."""
    deadband: float = 0.0
    """Percent of the reference an actual value must move from the value last published
    before a state is published for it (0: every change)."""

    @property
    def tls(self) -> bool:
        return self.endpoint.tls or self.ca is not None or self.cert is not None


@dataclass(frozen=True, slots=True)
class OpcuaOptions:
    endpoint: Endpoint
    security: tuple[str, ...] = ("None",)
    certificate: str | None = None
    private_key: str | None = None
    users: Mapping[str, str] = field(default_factory=dict, repr=False)
    anonymous: str = "read"
    read_only: bool = False
    namespace: str = "urn:pyuss:gateway"


def _endpoint(value: object, face: str, where: Where) -> Endpoint:
    try:
        return parse_endpoint(value, face)
    except ConfigError as exc:
        raise where.error(str(exc)) from None


def _topic_part(value: object, where: Where, *, slashes: bool = False) -> str:
    text = where.text(value)
    bad = "+#" if slashes else "+#/"
    if any(c in text for c in bad) or text.startswith("/") or text.endswith("/"):
        raise where.error(f"{text!r} cannot be part of an MQTT topic (no {' '.join(bad)})")
    if text.startswith("$"):
        raise where.error(f"{text!r}: topics that start with $ are the broker's (MQTT 5.0 4.7.2)")
    if any(ord(c) < 0x20 or 0x7F <= ord(c) < 0xA0 for c in text):
        raise where.error(f"{text!r}: no control characters in an MQTT topic (MQTT 5.0 1.5.4)")
    return text


def _file(table: Mapping[str, Any], key: str, where: Where, base: Path | None) -> str | None:
    """The file that ``key`` names (relative to ``base``); None where the table has no ``key``."""
    if key not in table:
        return None
    where = where.key(key)
    text = where.text(table[key])
    path = Path(text)
    if not path.is_absolute() and base is not None:
        path = base / path
    if not path.is_file():
        raise where.error(f"{str(path)!r}: no such file")
    return str(path)


def modbus_options(table: Mapping[str, Any], where: Where, buses: PlantConfig) -> ModbusOptions:
    table = where.table(table, ("listen", "word_order", "read_only"))
    endpoint = _endpoint(table.get("listen", DEFAULT_MODBUS), "modbus", where.key("listen"))
    try:
        order = WordOrder.parse(table.get("word_order", "big"))
    except ConfigError as exc:
        raise where.key("word_order").error(str(exc)) from None
    read_only = where.key("read_only").flag(table.get("read_only", False))
    own: dict[str, Endpoint] = {}
    for number, bus in enumerate(buses.buses):
        if "modbus" in bus.extra:
            own[bus.name] = _endpoint(
                bus.extra["modbus"], "modbus", Where("bus").key(number).key("modbus")
            )
    return ModbusOptions(endpoint, order, read_only, own)


def mqtt_options(table: Mapping[str, Any], where: Where, base: Path | None = None) -> MqttOptions:
    known = (
        "broker",
        "prefix",
        "username",
        "password",
        "ca",
        "cert",
        "key",
        "insecure",
        "client_id",
        "discovery",
        "discovery_prefix",
        "read_only",
        "keepalive",
        "reconnect",
        "max_rate",
        "deadband",
    )
    table = where.table(table, known)
    endpoint = _endpoint(table.get("broker", DEFAULT_MQTT), "mqtt", where.key("broker"))
    username = endpoint.username
    password = endpoint.password
    if "username" in table:
        username = where.key("username").text(table["username"])
    if "password" in table:
        if not isinstance(table["password"], str):
            raise where.key("password").error("expected a string")
        password = table["password"]
    if password is not None and username is None:
        raise where.key("password").error("a password needs a username")
    client_id = where.key("client_id").text(table.get("client_id", "pyuss-{bus}"))
    rest = client_id.replace("{bus}", "")
    if "{" in rest or "}" in rest:
        raise where.key("client_id").error(f"{client_id!r}: may only use {{bus}}, as it is")
    if len(rest.encode()) > 128:
        raise where.key("client_id").error("is longer than 128 bytes besides {bus}")
    keepalive = where.key("keepalive").integer(table.get("keepalive", 30), 5, 3600)
    reconnect = where.key("reconnect").seconds(table.get("reconnect", 1.0))
    if reconnect > RECONNECT_MAX:
        raise where.key("reconnect").error(
            f"{reconnect:g} s is more than the longest wait between tries, {RECONNECT_MAX:g} s"
        )
    if "key" in table and "cert" not in table:
        raise where.key("key").error("is the key of a client certificate: give cert too")
    tls = endpoint.tls or "ca" in table or "cert" in table
    if "insecure" in table and not tls:
        raise where.key("insecure").error(
            "skips the checks of TLS, which this broker's address does not use (mqtts://)"
        )
    return MqttOptions(
        endpoint=endpoint,
        prefix=_topic_part(table.get("prefix", "uss"), where.key("prefix"), slashes=True),
        username=username,
        password=password,
        ca=_file(table, "ca", where, base),
        cert=_file(table, "cert", where, base),
        key=_file(table, "key", where, base),
        insecure=where.key("insecure").flag(table.get("insecure", False)),
        client_id=client_id,
        discovery=where.key("discovery").flag(table.get("discovery", True)),
        discovery_prefix=_topic_part(
            table.get("discovery_prefix", "homeassistant"), where.key("discovery_prefix")
        ),
        read_only=where.key("read_only").flag(table.get("read_only", False)),
        keepalive=keepalive,
        reconnect=reconnect,
        max_rate=_number(table.get("max_rate", MAX_RATE), where.key("max_rate"), MAX_RATE_LIMIT),
        deadband=_number(table.get("deadband", 0.0), where.key("deadband"), 100.0),
    )


def _number(value: object, where: Where, most: float) -> float:
    """A number from 0 to ``most``; else the error naming the key."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise where.error(f"expected a number, not {value!r}")
    if not 0 <= value <= most:
        raise where.error(f"{value!r} is not 0..{most:g}")
    return float(value)


def opcua_options(table: Mapping[str, Any], where: Where, base: Path | None = None) -> OpcuaOptions:
    known = (
        "listen",
        "security",
        "certificate",
        "private_key",
        "users",
        "anonymous",
        "read_only",
        "namespace",
    )
    table = where.table(table, known)
    endpoint = _endpoint(table.get("listen", DEFAULT_OPCUA), "opcua", where.key("listen"))
    security_value = table.get("security", ["None"])
    if isinstance(security_value, str):
        security_value = [security_value]
    if not isinstance(security_value, list) or not security_value:
        raise where.key("security").error("expected a list of security policies")
    for item in security_value:
        if item not in SECURITY_POLICIES:
            raise where.key("security").error(
                f"unknown policy {item!r} (known: {', '.join(SECURITY_POLICIES)})"
            )
    security = tuple(security_value)
    certificate = _file(table, "certificate", where, base)
    private_key = _file(table, "private_key", where, base)
    if any(p != "None" for p in security) and (certificate is None or private_key is None):
        raise where.key("security").error(
            "signing policies need certificate and private_key (the server's own)"
        )
    users_value = table.get("users", {})
    if not isinstance(users_value, Mapping):
        raise where.key("users").error('expected a table of user = "password"')
    users: dict[str, str] = {}
    for name, password in users_value.items():
        if not isinstance(password, str) or not password:
            raise where.key("users").key(str(name)).error("expected a non-empty password")
        users[str(name)] = password
    anonymous = table.get("anonymous", "read")
    if anonymous not in ANONYMOUS:
        raise where.key("anonymous").error(f"expected one of {', '.join(ANONYMOUS)}")
    namespace = where.key("namespace").text(table.get("namespace", "urn:pyuss:gateway"))
    return OpcuaOptions(
        endpoint=endpoint,
        security=security,
        certificate=certificate,
        private_key=private_key,
        users=users,
        anonymous=anonymous,
        read_only=where.key("read_only").flag(table.get("read_only", False)),
        namespace=namespace,
    )
