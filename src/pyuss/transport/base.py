"""The byte-pipe contract shared by master, slave, monitor and the virtual bus.

A transport moves bytes, nothing else: it knows no telegrams. What it reads comes as `Chunk`s,
each stamped with the time its last byte arrived, so the sans-io receiver
(`pyuss.protocol.receiver`) can measure start pauses and residual times (A 5.1.2, A 5.2.1.2).

Only the virtual bus knows when a byte was on the line (`Transport.exact_timestamps`). Every
other transport stamps a byte when the program reads it: USB serial adapters hand over bytes
every 1 to 16 ms, ptys and TCP when the event loop or the reading thread gets to them. The
master and the monitor read such a line with a tolerance of `STAMP_TOLERANCE` (20 ms,
`stamp_tolerance`): see "Coarse timestamps" in `pyuss.protocol.receiver`.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from types import TracebackType
from typing import Self

from pyuss.protocol.line import LineError

__all__ = ["STAMP_TOLERANCE", "Chunk", "LineError", "Transport", "stamp_tolerance"]

STAMP_TOLERANCE = 0.020
"""How much later than on the line a transport without exact timestamps may stamp a byte
(seconds): USB adapters deliver every 1 to 16 ms (an FTDI chip's latency timer: 16 ms)."""


@dataclass(frozen=True, slots=True)
class Chunk:
    """Bytes read in one go.

    ``timestamp`` is the time (in the transport's ``clock()`` base, seconds) at which the last
    byte of ``data`` was completely received. Backends that deliver contiguous bursts (the
    virtual bus) put one burst per chunk, so a gap between chunks is a gap on the wire.
    ``errors`` lists ``(position in data, LineError)`` for characters the backend flagged.
    """

    data: bytes
    timestamp: float
    errors: tuple[tuple[int, LineError], ...] = field(default=())


class Transport(abc.ABC):
    """An async byte pipe. Constructors never touch an event loop; `open()` does the work."""

    @property
    def exact_timestamps(self) -> bool:
        """True when chunk timestamps are the times the bytes ended on the line (the virtual
        bus), False when they are the times the program read them (serial ports, ptys, TCP)."""
        return False

    @abc.abstractmethod
    async def open(self) -> None:
        """Open the pipe. Raises `pyuss.errors.TransportError` naming what failed."""

    @abc.abstractmethod
    async def close(self) -> None:
        """Close the pipe; idempotent."""

    @abc.abstractmethod
    async def write(self, data: bytes) -> None:
        """Send bytes; returns once they are handed to the line."""

    @abc.abstractmethod
    async def read(self, timeout: float | None = None) -> Chunk | None:
        """Wait for the next chunk; ``None`` when ``timeout`` (seconds) passes without data.

        Raises `pyuss.errors.TransportError` when the pipe is closed or lost.
        """

    @abc.abstractmethod
    def flush_input(self) -> None:
        """Discard whatever input is buffered and not yet read."""

    @abc.abstractmethod
    def clock(self) -> float:
        """The time base of chunk timestamps (seconds, monotonic)."""

    @property
    @abc.abstractmethod
    def baud(self) -> int:
        """The line's baud rate, for character timing."""

    async def __aenter__(self) -> Self:
        await self.open()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()


def stamp_tolerance(transport: Transport) -> float:
    """How late ``transport`` may stamp a byte (seconds): 0 for exact timestamps, else
    `STAMP_TOLERANCE`."""
    return 0.0 if transport.exact_timestamps else STAMP_TOLERANCE
