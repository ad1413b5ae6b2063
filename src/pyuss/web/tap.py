"""A transport that lets the page see the master's own traffic.

`TapTransport` wraps the master's transport and passes everything through unchanged; it
also hands what the master wrote (port 0, master to slave) and what it read (port 1, slave to
master) to a sink, as `Chunk`s stamped in the wrapped transport's clock. A 4-wire
`pyuss.monitor.Monitor` fed from the sink pairs and decodes the telegrams as `uss monitor`
does, without a second port on the line.

A write is stamped with the end of its last character on the line: the time the write began
plus the characters' time at the line's baud rate (11 bits a character, B 3.2), the same
estimate the master makes of its own request's end.
"""

from __future__ import annotations

from collections.abc import Callable

from pyuss.protocol.timing import LineTiming
from pyuss.transport.base import Chunk, Transport

__all__ = ["Sink", "TapTransport"]

Sink = Callable[[int, Chunk], None]
"""Called with the port (0: written by the master, 1: read by it) and the chunk."""


class TapTransport(Transport):
    """``inner`` with every byte written or read also handed to ``sink``."""

    def __init__(self, inner: Transport, sink: Sink) -> None:
        self.inner = inner
        self._sink = sink
        self._char_time = LineTiming(inner.baud).char_time

    async def open(self) -> None:
        await self.inner.open()

    async def close(self) -> None:
        await self.inner.close()

    async def write(self, data: bytes) -> None:
        start = self.inner.clock()
        await self.inner.write(data)
        self._sink(0, Chunk(bytes(data), start + len(data) * self._char_time))

    async def read(self, timeout: float | None = None) -> Chunk | None:
        chunk = await self.inner.read(timeout)
        if chunk is not None:
            self._sink(1, chunk)
        return chunk

    def flush_input(self) -> None:
        self.inner.flush_input()

    def clock(self) -> float:
        return self.inner.clock()

    @property
    def baud(self) -> int:
        return self.inner.baud

    @property
    def exact_timestamps(self) -> bool:
        return self.inner.exact_timestamps

    @property
    def connected(self) -> bool:
        """Whether the link is up: a reconnecting line's own (`pyuss.transport.reconnect`),
        else always."""
        return bool(getattr(self.inner, "connected", True))
