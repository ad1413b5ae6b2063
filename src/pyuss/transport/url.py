"""Choose a transport by URL.

=============================  ==============================================================
URL                            transport
=============================  ==============================================================
``tcp://HOST:PORT``            `TcpTransport`: a serial line over TCP (converter, simulator)
``tcp-listen://HOST:PORT``     `TcpServerTransport`: serve the line to one TCP peer at a time
``bus://HOST:PORT``            a station on a virtual bus served by ``uss bus --bus-tcp``
                               (exact character times and line errors); query options
                               ``name=``, ``echo=1``, ``listen_only=1``
anything else                  `SerialTransport`: what pyserial's ``serial_for_url`` accepts
                               (``/dev/ttyUSB0``, ``COM3``, ``socket://``, ``rfc2217://``,
                               ``loop://``)
=============================  ==============================================================
"""

from __future__ import annotations

import urllib.parse

from pyuss.errors import ConfigError
from pyuss.transport.base import Transport
from pyuss.transport.reconnect import ReconnectingTransport
from pyuss.transport.serialport import RS485Mode, SerialTransport
from pyuss.transport.tcp import TcpServerTransport, TcpTransport, check_endpoint

_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


def split_endpoint(url: str) -> tuple[str, int]:
    """``scheme://host:port`` -> (host, port); `ConfigError` naming what is missing."""
    parts = urllib.parse.urlsplit(url)
    try:
        port = parts.port
    except ValueError:
        raise ConfigError(f"{url!r}: the port is not a number 0..65535") from None
    if not parts.hostname or port is None:
        raise ConfigError(f"{url!r}: expected {parts.scheme}://HOST:PORT")
    if parts.path not in ("", "/"):
        raise ConfigError(f"{url!r}: unexpected path {parts.path!r}")
    return parts.hostname, port


def query_flags(url: str, allowed: tuple[str, ...]) -> dict[str, str]:
    """The query options of ``url``, each given once and among ``allowed``."""
    query = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query, keep_blank_values=True)
    options: dict[str, str] = {}
    for key, values in query.items():
        if key not in allowed:
            raise ConfigError(f"{url!r}: unknown option {key!r} (known: {', '.join(allowed)})")
        if len(values) != 1:
            raise ConfigError(f"{url!r}: option {key!r} given more than once")
        options[key] = values[0]
    return options


def flag(url: str, key: str, value: str) -> bool:
    """A yes/no query option."""
    low = value.lower()
    if low in _TRUE:
        return True
    if low in _FALSE:
        return False
    raise ConfigError(f"{url!r}: option {key}={value!r} is not 1/0, yes/no, true/false")


def open_transport(
    url: str,
    *,
    baud: int = 9600,
    echo: bool = False,
    rs485: RS485Mode | str = RS485Mode.AUTO,
    parity: str = "E",
    stopbits: float = 1,
    reconnect: bool = False,
    backoff_initial: float = 0.1,
    backoff_max: float = 5.0,
) -> Transport:
    """Build the transport ``url`` names (see the module docstring); nothing is opened yet:
    use ``async with open_transport(...) as t:`` or ``await t.open()``.

    ``reconnect=True`` wraps it in a `ReconnectingTransport`. Bad URLs and settings raise
    `ConfigError` naming what was wrong.
    """
    if not isinstance(url, str) or not url.strip():
        raise ConfigError(f"transport URL must be a non-empty string, not {url!r}")
    url = url.strip()
    scheme = urllib.parse.urlsplit(url).scheme.lower() if "://" in url else ""

    def build() -> Transport:
        if scheme == "tcp":
            query_flags(url, ())
            host, port = check_endpoint(*split_endpoint(url))
            return TcpTransport(host, port, baud=baud, echo=echo)
        if scheme == "tcp-listen":
            query_flags(url, ())
            host, port = check_endpoint(*split_endpoint(url), allow_zero=True)
            return TcpServerTransport(host, port, baud=baud, echo=echo)
        if scheme == "bus":
            from pyuss.bus.client import BusClientTransport

            options = query_flags(url, ("name", "echo", "listen_only"))
            host, port = check_endpoint(*split_endpoint(url))
            return BusClientTransport(
                host,
                port,
                baud=baud,
                name=options.get("name"),
                echo=echo,
                bus_echo=flag(url, "echo", options.get("echo", "0")),
                listen_only=flag(url, "listen_only", options.get("listen_only", "0")),
            )
        return SerialTransport(
            url, baud=baud, parity=parity, stopbits=stopbits, rs485=rs485, echo=echo
        )

    transport = build()
    if reconnect:
        return ReconnectingTransport(
            build, backoff_initial=backoff_initial, backoff_max=backoff_max
        )
    return transport
