"""``HOST:PORT``: the one reader of a TCP address a user writes.

Every place that takes a TCP address from a person - the ``tcp://``, ``tcp-listen://`` and
``bus://`` port URLs, ``uss bus --tcp/--bus-tcp``, ``uss simulate --tcp/--bus-tcp``, ``uss web
--listen`` and the gateway's face addresses (`pyuss.points.endpoint`) - reads it here, so the
forms and the messages are the same everywhere:

==================  =============================================================
written             read as
==================  =============================================================
``HOST:PORT``       that host and port
``[::1]:PORT``      an IPv6 address, in brackets as in a URL
``:PORT``, ``PORT`` the default host where the caller has one (127.0.0.1: this machine only)
``HOST``            the default port where the caller has one
==================  =============================================================

A bare IPv6 address without brackets is refused (``::1:502`` cannot be told apart). Nothing
here opens a socket or looks a name up; whether port 0 (any free port) is allowed is the
caller's to check (`pyuss.transport.tcp.check_endpoint`).
"""

from __future__ import annotations

import urllib.parse
from dataclasses import dataclass

from pyuss.errors import ConfigError

__all__ = ["LOOPBACK", "HostPort", "parse_host_port", "split_url"]

LOOPBACK = "127.0.0.1"
"""The host of an address that names none: this machine only, never every interface."""


@dataclass(frozen=True, slots=True)
class HostPort:
    """A host and a TCP port (0 = any free port, for listeners)."""

    host: str
    port: int

    def __post_init__(self) -> None:
        if not isinstance(self.host, str) or not self.host:
            raise ConfigError(f"host must be a non-empty name or address, not {self.host!r}")
        port = self.port
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise ConfigError(f"TCP port must be an integer 0..65535, not {port!r}")

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{host}:{self.port}"


def parse_host_port(
    text: str,
    what: str,
    *,
    form: str = "HOST:PORT",
    default_host: str | None = LOOPBACK,
    default_port: int | None = None,
) -> HostPort:
    """Read ``text`` (see the module docstring). ``what`` names the address in messages (an
    option and its value, a URL); ``form`` is what the message asks for; a missing host or
    port takes ``default_host`` / ``default_port``, or is refused where that is None."""
    raw = text.strip()
    expected = ConfigError(f"{what}: expected {form}")
    if not raw:
        raise expected
    if raw.startswith("["):
        host, bracket, rest = raw[1:].partition("]")
        if not bracket or not host or (rest and not rest.startswith(":")):
            raise ConfigError(f"{what}: expected {form}, with an IPv6 address as [::1]")
        port_text = rest[1:]
    elif raw.count(":") > 1:
        raise ConfigError(f"{what}: write an IPv6 address in brackets, as in [::1]:PORT")
    elif ":" in raw:
        host, _, port_text = raw.partition(":")
    elif _digits(raw):
        host, port_text = "", raw
    else:
        host, port_text = raw, ""
    if not host:
        if default_host is None:
            raise expected
        host = default_host
    if not port_text:
        if default_port is None:
            raise expected
        return HostPort(host, default_port)
    if not _digits(port_text) or int(port_text) > 65535:
        raise ConfigError(f"{what}: the port is not a number 0..65535")
    return HostPort(host, int(port_text))


def _digits(text: str) -> bool:
    return text.isascii() and text.isdigit()


def split_url(url: str) -> urllib.parse.SplitResult:
    """``urllib.parse.urlsplit`` of a port URL; `ConfigError` naming the URL where that fails
    (an unclosed ``[`` of an IPv6 address, ``tcp://[::1``)."""
    try:
        return urllib.parse.urlsplit(url)
    except ValueError as exc:
        scheme = url.partition("://")[0] if "://" in url else "SCHEME"
        raise ConfigError(
            f"{url!r}: expected {scheme}://HOST:PORT, with an IPv6 address as [::1] ({exc})"
        ) from None
