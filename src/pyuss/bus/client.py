"""``bus://HOST:PORT``: a station on a virtual bus in another process (``uss bus --bus-tcp``).

Unlike a raw TCP or pty station, it receives the bus's ideal character end times and its line
error flags (see `pyuss.bus.wire`), so a receiver measures the same gaps and sees the same
parity and framing errors as an in-process station. Timestamps are the bus's
``time.monotonic()``, which is the clock of every process on the same machine.
"""

from __future__ import annotations

import asyncio
import json

from pyuss.bus.wire import FrameDecoder
from pyuss.errors import ConfigError, ProtocolError, TransportError
from pyuss.transport.tcp import TcpTransport

_ANSWER_TIMEOUT = 5.0


class BusClientTransport(TcpTransport):
    """A ``bus://`` station.

    ``name``: the station's name on the bus (the bus picks one when ``None``).
    ``echo``: the station's adapter echoes: the bus sends its own characters back and this
    transport checks and removes them (a garbled echo reveals a collision, `EchoError`).
    ``bus_echo``: the bus sends them back and they are delivered as they are.
    ``listen_only``: a monitor that cannot send.
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        baud: int = 9600,
        name: str | None = None,
        echo: bool = False,
        bus_echo: bool = False,
        listen_only: bool = False,
        connect_timeout: float = 5.0,
    ) -> None:
        super().__init__(host, port, baud=baud, echo=echo, connect_timeout=connect_timeout)
        if name is not None and (not name or "+" in name):
            raise ConfigError(f"station name must be non-empty without '+', not {name!r}")
        self.name = name
        self._bus_echo = bus_echo or echo
        self.listen_only = listen_only

    @property
    def exact_timestamps(self) -> bool:
        return True  # the bus's own end times of the characters

    def describe(self) -> str:
        return f"bus://{self.host}:{self.port} station {self.name or '(unnamed)'}"

    async def _handshake(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        hello = {"name": self.name, "echo": self._bus_echo, "listen_only": self.listen_only}
        try:
            writer.write(json.dumps(hello).encode() + b"\n")
            async with asyncio.timeout(_ANSWER_TIMEOUT):
                line = await reader.readline()
            answer = json.loads(line)
        except (OSError, TimeoutError, ValueError) as exc:
            raise TransportError(
                f"{self.describe()}: no valid answer from the bus: {exc or 'timeout'}"
            ) from None
        if not isinstance(answer, dict) or not answer.get("ok"):
            why = answer.get("error") if isinstance(answer, dict) else answer
            raise TransportError(f"{self.describe()}: the bus refused the station: {why}")
        if answer.get("baud") != self.baud:
            raise TransportError(
                f"{self.describe()}: the bus runs at {answer.get('baud')} baud, not {self.baud}"
            )
        self.name = str(answer.get("name"))

    async def _run(self, reader: asyncio.StreamReader) -> None:
        decoder = FrameDecoder()
        why = "connection closed by the bus"
        try:
            while True:
                data = await reader.read(65536)
                if not data:
                    break
                for payload, timestamp, errors in decoder.feed(data):
                    self._deliver(payload, timestamp, errors)
        except (OSError, ProtocolError) as exc:
            why = str(exc)
        if self.is_open:
            self._lose(TransportError(f"{self.describe()}: {why}"))

    async def write(self, data: bytes) -> None:
        if self.listen_only:
            raise TransportError(f"{self.describe()} is listen-only: it cannot send")
        await super().write(data)
