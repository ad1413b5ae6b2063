"""An in-process `Transport` end: what is written goes to a callback, what is delivered is read.

The ring simulator (`pyuss.bass.ring`) hands one of these to a master living in the same
process: the master's writes go round the ring, and what comes back is delivered to the port.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

from pyuss.bass.codec import BAUD
from pyuss.errors import TransportError
from pyuss.transport.base import Chunk, Transport


class InProcessPort(Transport):
    """A byte pipe end inside the process. ``on_write`` receives every write once open."""

    def __init__(
        self,
        on_write: Callable[[bytes], None] | None = None,
        *,
        baud: int = BAUD,
        name: str = "in-process",
    ) -> None:
        self.on_write = on_write
        self.name = name
        self._baud = baud
        self._queue: asyncio.Queue[Chunk | None] | None = None
        self._closed = False

    @property
    def is_open(self) -> bool:
        return self._queue is not None and not self._closed

    async def open(self) -> None:
        if not self.is_open:
            self._queue = asyncio.Queue()
            self._closed = False

    async def close(self) -> None:
        """Close; a reader waiting at this end wakes up with `TransportError`."""
        if self.is_open:
            assert self._queue is not None
            self._closed = True
            self._queue.put_nowait(None)

    def deliver(self, data: bytes) -> None:
        """Make ``data`` readable at this end (dropped while the end is not open, like a line)."""
        if data and self.is_open:
            assert self._queue is not None
            self._queue.put_nowait(Chunk(bytes(data), self.clock()))

    async def write(self, data: bytes) -> None:
        if not self.is_open:
            raise TransportError(f"{self.name}: write on a closed port")
        if self.on_write is not None:
            self.on_write(bytes(data))

    async def read(self, timeout: float | None = None) -> Chunk | None:
        if not self.is_open:
            raise TransportError(f"{self.name}: read on a closed port")
        assert self._queue is not None
        try:
            chunk = await asyncio.wait_for(self._queue.get(), timeout)
        except TimeoutError:
            return None
        if chunk is None:
            raise TransportError(f"{self.name}: port closed")
        return chunk

    def flush_input(self) -> None:
        if self.is_open:
            assert self._queue is not None
            while not self._queue.empty():
                self._queue.get_nowait()

    def clock(self) -> float:
        return time.monotonic()

    @property
    def baud(self) -> int:
        return self._baud
