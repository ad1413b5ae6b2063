"""Where a face listens or connects: one parser for every endpoint address.

As `pyuss.transport.url` does for ports, one string carries an endpoint and its options, so
commands and configuration files pass it through and never deal with sockets themselves:

=================================  =========================================================
address                            meaning
=================================  =========================================================
``HOST:PORT``, ``:PORT``, ``PORT``  the face's own scheme; a missing host is 127.0.0.1
``modbus://HOST[:PORT]``           Modbus TCP server (default port 502)
``mqtt://[USER[:PASS]@]HOST[:PORT]``  MQTT broker (default port 1883)
``mqtts://...``                    MQTT broker over TLS (default port 8883)
``opc.tcp://HOST[:PORT][/PATH]``   OPC UA server (default port 4840)
``http://HOST[:PORT]``             web page (default port 8080)
=================================  =========================================================

Listening faces (Modbus, OPC UA, web) bind to the host given; nothing binds to every interface
unless the address says so (``0.0.0.0``, ``::``). An address carries no options: a query
(``?read_only=1``) is refused naming it, since a face's options are its table's keys and
flags, and one written in the address would otherwise be left unapplied without a word (a
Modbus face taking writes that was meant to refuse them).
"""

from __future__ import annotations

import ipaddress
import urllib.parse
from collections.abc import Mapping
from dataclasses import dataclass, field

from pyuss.errors import ConfigError
from pyuss.transport.address import LOOPBACK, parse_host_port

__all__ = ["DEFAULT_PORTS", "Endpoint", "parse_endpoint"]

DEFAULT_PORTS: Mapping[str, int] = {
    "modbus": 502,
    "mqtt": 1883,
    "mqtts": 8883,
    "opc.tcp": 4840,
    "http": 8080,
}

_FACE_SCHEMES: Mapping[str, tuple[str, ...]] = {
    "modbus": ("modbus",),
    "mqtt": ("mqtt", "mqtts"),
    "opcua": ("opc.tcp",),
    "web": ("http",),
}


@dataclass(frozen=True, slots=True)
class Endpoint:
    """A parsed endpoint address (see the module docstring)."""

    scheme: str
    host: str
    port: int
    path: str = ""
    username: str | None = None
    password: str | None = field(default=None, repr=False)
    options: Mapping[str, str] = field(default_factory=dict)
    """Always empty: `parse_endpoint` refuses options in an address."""

    @property
    def tls(self) -> bool:
        return self.scheme == "mqtts"

    @property
    def loopback(self) -> bool:
        """Only this machine can reach it."""
        if self.host == "localhost":
            return True
        try:
            return ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            return False

    @property
    def url(self) -> str:
        """The address as a URL, without the password."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        user = f"{self.username}@" if self.username else ""
        return f"{self.scheme}://{user}{host}:{self.port}{self.path}"

    def __str__(self) -> str:
        return self.url


def parse_endpoint(text: object, face: str) -> Endpoint:
    """Parse the address of ``face`` (``modbus``, ``mqtt``, ``opcua`` or ``web``); bad input
    raises `ConfigError` naming what was wrong."""
    schemes = _FACE_SCHEMES.get(face)
    if schemes is None:
        raise ConfigError(f"unknown face {face!r} (known: {', '.join(_FACE_SCHEMES)})")
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"{face} address must be a non-empty string, not {text!r}")
    raw = text.strip()
    if "://" not in raw:
        if raw.isdigit():
            raw = f":{raw}"
        if raw.startswith(":"):
            raw = LOOPBACK + raw
        raw = f"{schemes[0]}://{raw}"
    parts = urllib.parse.urlsplit(raw)
    scheme = parts.scheme.lower()
    if scheme not in schemes:
        raise ConfigError(
            f"{text!r}: a {face} address starts with {' or '.join(s + '://' for s in schemes)}"
        )
    where = parse_host_port(
        parts.netloc.rpartition("@")[2],
        repr(text),
        form=f"{scheme}://HOST:PORT",
        default_host=None,
        default_port=DEFAULT_PORTS[scheme],
    )
    host, port = where.host, where.port
    if port == 0 and face == "mqtt":
        raise ConfigError(f"{text!r}: a broker's port cannot be 0")
    path = parts.path
    if path not in ("", "/") and scheme != "opc.tcp":
        raise ConfigError(f"{text!r}: unexpected path {path!r}")
    if path == "/":
        path = ""
    if (parts.username or parts.password) and face != "mqtt":
        raise ConfigError(f"{text!r}: user and password belong in the {face} options, not here")
    if "?" in raw:
        names = ", ".join(repr(k) for k in urllib.parse.parse_qs(parts.query, True))
        raise ConfigError(
            f"{text!r}: a {face} address takes no options{f' ({names})' if names else ''}: "
            f"give them in the [{face}] table or as flags"
        )
    if parts.fragment:
        raise ConfigError(f"{text!r}: unexpected fragment {parts.fragment!r}")
    return Endpoint(
        scheme=scheme,
        host=host,
        port=port,
        path=path,
        username=urllib.parse.unquote(parts.username) if parts.username else None,
        password=urllib.parse.unquote(parts.password) if parts.password is not None else None,
    )
