"""Choose a transport by URL.

=============================  ==============================================================
URL                            transport
=============================  ==============================================================
``tcp://HOST:PORT``            `TcpTransport`: a serial line over TCP (converter, simulator)
``tcp-listen://HOST:PORT``     `TcpServerTransport`: serve the line to TCP peers, several at
                               once (an idle one gives way to a new one)
``bus://HOST:PORT``            a station on a virtual bus served by ``uss bus --bus-tcp``
                               (exact character times and line errors); query options
                               ``name=``, ``echo=1``, ``listen_only=1``
anything else                  `SerialTransport`: what pyserial's ``serial_for_url`` accepts
                               (``/dev/ttyUSB0``, ``COM3``, ``socket://``, ``rfc2217://``,
                               ``loop://``)
=============================  ==============================================================

Line options in the query, so that every command taking a port URL can use them:

- serial ports: ``rs485=auto|kernel|rts`` (direction control), ``echo=1`` (the adapter returns
  what it sends: checked and removed), ``low_latency=0`` (leave the driver's low-latency mode
  off, see `pyuss.transport.serialport`), ``reconnect=0|1``; e.g.
  ``/dev/ttyUSB0?rs485=rts&echo=1``.
  Other query options (``socket://h:p?logging=debug``) go to pyserial.
- ``tcp://``: ``echo=1`` (the converter echoes), ``reconnect=0|1``.
- ``bus://``: ``name=``, ``echo=1`` (the bus returns the station's own characters, raw),
  ``listen_only=1``, ``reconnect=0|1``.

A query option overrides the keyword argument of the same name: ``reconnect`` is off for a
caller that says nothing (the one-shot commands fail fast), on for the long-running commands
(``uss gateway``, ``uss web``, ``uss log``, ``uss run``), and ``?reconnect=0`` turns it off
for them, ``?reconnect=1`` on for any.
"""

from __future__ import annotations

import urllib.parse

from pyuss.errors import ConfigError
from pyuss.transport.address import parse_host_port, split_url
from pyuss.transport.base import Transport
from pyuss.transport.queued import QueuedTransport
from pyuss.transport.reconnect import BACKOFF_INITIAL, BACKOFF_MAX, ReconnectingTransport
from pyuss.transport.serialport import RS485Mode, SerialTransport
from pyuss.transport.tcp import TcpServerTransport, TcpTransport, check_endpoint

_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


def split_endpoint(url: str) -> tuple[str, int]:
    """``scheme://host:port`` -> (host, port); `ConfigError` naming what is missing."""
    parts = split_url(url)
    if parts.path not in ("", "/"):
        raise ConfigError(f"{url!r}: unexpected path {parts.path!r}")
    where = parse_host_port(
        parts.netloc, repr(url), form=f"{parts.scheme}://HOST:PORT", default_host=None
    )
    return where.host, where.port


def query_flags(url: str, allowed: tuple[str, ...]) -> dict[str, str]:
    """The query options of ``url``, each given once and among ``allowed``."""
    query = urllib.parse.parse_qs(split_url(url).query, keep_blank_values=True)
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


#: Query options pyuss takes from a serial port URL (the others are pyserial's).
SERIAL_OPTIONS = ("rs485", "echo", "low_latency", "reconnect")


def serial_options(url: str) -> tuple[str, dict[str, str]]:
    """Split ``url`` into the URL pyserial gets and the `SERIAL_OPTIONS` given in its query."""
    base, sep, query = url.partition("?")
    if not sep:
        return url, {}
    ours: dict[str, str] = {}
    rest: list[str] = []
    for item in query.split("&"):
        key, _, value = item.partition("=")
        if key in SERIAL_OPTIONS:
            if key in ours:
                raise ConfigError(f"{url!r}: option {key!r} given more than once")
            ours[key] = value
        elif item:
            rest.append(item)
    return (f"{base}?{'&'.join(rest)}" if rest else base), ours


def open_transport(
    url: str,
    *,
    baud: int = 9600,
    echo: bool = False,
    rs485: RS485Mode | str = RS485Mode.AUTO,
    parity: str = "E",
    stopbits: float = 1,
    reconnect: bool = False,
    low_latency: bool = True,
    backoff_initial: float = BACKOFF_INITIAL,
    backoff_max: float = BACKOFF_MAX,
) -> Transport:
    """Build the transport ``url`` names (see the module docstring); nothing is opened yet:
    use ``async with open_transport(...) as t:`` or ``await t.open()``.

    ``reconnect=True`` (overridden by the URL's ``reconnect=0|1``) wraps it in a
    `ReconnectingTransport` that reopens a lost link: the first try at once, then after
    ``backoff_initial`` seconds, the wait doubling up to ``backoff_max``.
    ``low_latency=False`` leaves a serial driver's low-latency mode off. Bad URLs and settings raise
    `ConfigError` naming what was wrong.
    """
    if not isinstance(url, str) or not url.strip():
        raise ConfigError(f"transport URL must be a non-empty string, not {url!r}")
    url = url.strip()
    scheme = split_url(url).scheme.lower() if "://" in url else ""
    port_url = url
    if scheme == "tcp":
        options = query_flags(url, ("echo", "reconnect"))
    elif scheme == "bus":
        options = query_flags(url, ("name", "echo", "listen_only", "reconnect"))
    elif scheme == "tcp-listen":
        options = query_flags(url, ())
        reconnect = False  # a server is not lost with a peer: it waits for the next one
    else:
        port_url, options = serial_options(url)
        rs485 = RS485Mode.parse(options.get("rs485", rs485))
        if "low_latency" in options:
            low_latency = flag(url, "low_latency", options["low_latency"])
    if "echo" in options and scheme != "bus":
        echo = flag(url, "echo", options["echo"])
    if "reconnect" in options:
        reconnect = flag(url, "reconnect", options["reconnect"])

    def build() -> QueuedTransport:
        if scheme == "tcp":
            host, port = check_endpoint(*split_endpoint(url))
            return TcpTransport(host, port, baud=baud, echo=echo)
        if scheme == "tcp-listen":
            host, port = check_endpoint(*split_endpoint(url), allow_zero=True)
            return TcpServerTransport(host, port, baud=baud, echo=echo)
        if scheme == "bus":
            from pyuss.bus.client import BusClientTransport

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
            port_url,
            baud=baud,
            parity=parity,
            stopbits=stopbits,
            rs485=rs485,
            echo=echo,
            low_latency=low_latency,
        )

    transport = build()
    if reconnect:
        return ReconnectingTransport(
            build, backoff_initial=backoff_initial, backoff_max=backoff_max
        )
    return transport
