"""An in-process `Transport` end: what is written goes to a callback, what is delivered is read.

The ring simulator (`pyuss.bass.ring`) hands one of these to a master living in the same
process: the master's writes go round the ring, and what comes back is delivered to the port.
"""

from __future__ import annotations

from collections.abc import Callable

from pyuss.bass.codec import BAUD
from pyuss.transport.queued import QueuedTransport


class InProcessPort(QueuedTransport):
    """A byte pipe end inside the process. ``on_write`` receives every write while open."""

    def __init__(
        self,
        on_write: Callable[[bytes], None] | None = None,
        *,
        baud: int = BAUD,
        name: str = "in-process port",
    ) -> None:
        super().__init__(baud=baud)
        self.on_write = on_write
        self.name = name

    def describe(self) -> str:
        return self.name

    async def open(self) -> None:
        if not self.is_open:
            self._mark_open()

    async def close(self) -> None:
        """Close; a reader waiting at this end wakes up with `TransportError`."""
        self._mark_closed()

    def deliver(self, data: bytes) -> None:
        """Make ``data`` readable at this end (dropped while the end is closed, like a line)."""
        self._deliver(bytes(data), self.clock())

    async def write(self, data: bytes) -> None:
        self._check_writable()
        self.stats.bytes_out += len(data)
        if self.on_write is not None:
            self.on_write(bytes(data))
