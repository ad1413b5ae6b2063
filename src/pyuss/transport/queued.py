"""The machinery every concrete transport shares: a queue of timestamped chunks, reads with a
timeout, input flush, loss reporting and local-echo suppression.

A backend (serial worker thread, pty or socket reader, virtual bus) hands what it received to
`QueuedTransport._deliver` on the event loop; `read()` hands it on as `Chunk`s, one per
delivery. A lost link is reported with `_lose()`: buffered chunks are still read first, then
`read()` raises the `TransportError`.

Local echo (B 2.3: a 2-wire RS-485 adapter hears its own driver): with ``echo=True`` every
written byte is expected back on the input. Echoed bytes are compared with what was written
and removed; when they differ (a collision, a broken adapter), or when they do not come back
in time, the next `read()` raises `EchoError` once, naming what was sent and what came back,
and `stats.echo_errors` counts it.
"""

from __future__ import annotations

import asyncio
from collections import deque
from dataclasses import dataclass

from pyuss import system
from pyuss.errors import ConfigError, TransportError
from pyuss.protocol.frozen import builder
from pyuss.protocol.timing import BAUD_RATES, BITS_PER_CHAR, char_time, check_baud
from pyuss.transport.base import Chunk, LineError, Transport

__all__ = [
    "BAUD_RATES",
    "BITS_PER_CHAR",
    "EchoError",
    "QueuedTransport",
    "TransportStats",
    "char_time",
    "check_baud",
    "shift_errors",
]


class EchoError(TransportError):
    """The local echo differed from what was sent, or did not come back."""

    def __init__(self, message: str, *, sent: bytes, received: bytes) -> None:
        super().__init__(message)
        self.sent = sent
        self.received = received


@dataclass(slots=True)
class TransportStats:
    """Counters a transport keeps; all start at zero."""

    bytes_in: int = 0
    bytes_out: int = 0
    chunks_in: int = 0
    line_errors: int = 0
    echo_bytes: int = 0
    echo_errors: int = 0
    dropped_out: int = 0


def shift_errors(
    errors: tuple[tuple[int, LineError], ...], start: int, stop: int | None = None
) -> tuple[tuple[int, LineError], ...]:
    """The error list of ``data[start:stop]`` given that of ``data``."""
    return tuple(
        (pos - start, flag) for pos, flag in errors if pos >= start and (stop is None or pos < stop)
    )


_chunk = builder(Chunk)
"""`Chunk` of what a backend delivered (`pyuss.protocol.frozen.builder`)."""


def _wake(waiter: asyncio.Future[None]) -> None:
    if not waiter.done():
        waiter.set_result(None)


class QueuedTransport(Transport):
    """Base of the concrete transports; see the module docstring.

    ``echo_timeout`` is how long after the last written character would have left the line
    (``len(data)`` character times after `write()`) its echo may still come back.
    """

    def __init__(self, *, baud: int, echo: bool = False, echo_timeout: float = 0.2) -> None:
        self._baud = check_baud(baud)
        self._echo = echo
        if echo_timeout <= 0:
            raise ConfigError(f"echo_timeout must be > 0 seconds, not {echo_timeout!r}")
        self._echo_timeout = echo_timeout
        self._chunks: deque[Chunk] = deque()
        self._ready: asyncio.Event | None = None
        self._failure: TransportError | None = None
        self._pending_echo = bytearray()
        self._echo_sent = bytearray()
        self._echo_timer: asyncio.TimerHandle | None = None
        self._echo_error: EchoError | None = None
        self._waiters: list[tuple[int, asyncio.Future[None]]] = []
        self._queued_bytes = 0
        self._open = False
        self.stats = TransportStats()

    # -- the contract ---------------------------------------------------------------------------
    @property
    def baud(self) -> int:
        return self._baud

    @property
    def echo(self) -> bool:
        """Whether the local echo is expected and removed."""
        return self._echo

    @property
    def is_open(self) -> bool:
        return self._open

    clock = staticmethod(system.clock)
    """The time base of chunk timestamps: the line's clock (`pyuss.system.clock`) itself,
    called without a Python frame of its own (the master reads it several times per exchange)."""

    def flush_input(self) -> None:
        self._chunks.clear()
        self._queued_bytes = 0
        if self._ready is not None:
            self._ready.clear()

    async def read(self, timeout: float | None = None) -> Chunk | None:
        chunk = self.read_nowait()
        if chunk is not None or (timeout is not None and timeout <= 0):
            return chunk
        assert self._ready is not None
        deadline = None if timeout is None else system.clock() + timeout
        while True:
            self._ready.clear()
            if deadline is None:
                await self._ready.wait()
            else:
                left = deadline - system.clock()
                if left <= 0:
                    return None
                await self._wait(left, 1)
            chunk = self.read_nowait()
            if chunk is not None:
                return chunk

    def read_nowait(self) -> Chunk | None:
        """`read` with a timeout of 0 without a coroutine: the next chunk, or None when none
        waits (raising as `read` does: an echo error first, then, once the chunks are read, a
        lost or closed link). A reader that looks for chunks several times per telegram (the
        master) spares itself a coroutine each time."""
        if self._ready is None:
            raise TransportError(f"{self.describe()} is not open")
        if self._echo_error is not None:
            error, self._echo_error = self._echo_error, None
            raise error
        chunks = self._chunks
        if chunks:
            chunk = chunks.popleft()
            self._queued_bytes -= len(chunk.data)
            if not chunks:
                self._ready.clear()
            return chunk
        if self._failure is not None:
            raise self._failure
        if not self._open:
            raise TransportError(f"{self.describe()} is closed")
        return None

    async def wait_bytes(self, count: int, timeout: float) -> None:
        """Return once ``count`` bytes wait to be read, the link is lost or closed, an echo
        error waits to be raised, or ``timeout`` seconds have passed: whichever comes first.
        Nothing is read. A reader that knows how long the telegram it awaits is (the master,
        for a slave of fixed length) is woken once for it instead of once per delivery; the
        chunks keep the timestamps they were delivered with."""
        if self._ready is None:
            raise TransportError(f"{self.describe()} is not open")
        if (
            self._queued_bytes < count
            and self._echo_error is None
            and self._failure is None
            and self._open
            and timeout > 0
        ):
            await self._wait(timeout, count)

    async def _wait(self, timeout: float, count: int) -> None:
        """Wait until ``count`` bytes are queued (or the link is lost, or closed) or
        ``timeout`` has passed. One future and one timer that only wakes the reader: a
        fraction of the CPU time of ``asyncio.timeout`` around ``Event.wait``, whose expiry
        cancels the task and unwinds the wait by an exception (the master waits like this
        at every exchange)."""
        loop = asyncio.get_running_loop()
        waiter: asyncio.Future[None] = loop.create_future()
        entry = (count, waiter)
        self._waiters.append(entry)
        timer = loop.call_later(timeout, _wake, waiter)
        try:
            await waiter
        finally:
            timer.cancel()
            if entry in self._waiters:  # (a reader woken by `_signal` is out already)
                self._waiters.remove(entry)

    def _signal(self, everyone: bool = True) -> None:
        """Wake the readers: all of them when the link was lost or closed or an echo error
        came (``everyone``), else those waiting for no more bytes than are queued."""
        ready = self._ready
        if ready is not None and not ready.is_set():
            ready.set()
        if not self._waiters:
            return
        queued = self._queued_bytes
        keep = []
        for entry in self._waiters:
            if everyone or entry[0] <= queued:
                _wake(entry[1])
            else:
                keep.append(entry)
        self._waiters = keep

    # -- what subclasses use --------------------------------------------------------------------
    def describe(self) -> str:
        """A short name for messages ("serial port /dev/ttyUSB0", ...)."""
        return type(self).__name__

    def _mark_open(self) -> None:
        self._ready = asyncio.Event()
        self._failure = None
        self._echo_error = None
        self._pending_echo.clear()
        self._echo_sent.clear()
        self._open = True

    def _mark_closed(self) -> None:
        self._open = False
        if self._echo_timer is not None:
            self._echo_timer.cancel()
            self._echo_timer = None
        self._signal()

    def _lose(self, error: TransportError) -> None:
        """Report a lost link: readers get ``error`` once the buffered chunks are read."""
        if self._failure is None:
            self._failure = error
        self._signal()

    def _check_writable(self) -> None:
        if self._failure is not None:
            raise self._failure
        if not self._open:
            raise TransportError(f"{self.describe()} is not open")

    def _arm_echo(self, data: bytes) -> None:
        """Call just before ``data`` goes to the line: the echo of it is expected from now on."""
        if not self._echo or not data:
            return
        self._pending_echo += data
        self._echo_sent += data
        loop = asyncio.get_running_loop()
        if self._echo_timer is not None:
            self._echo_timer.cancel()
        wait = len(self._pending_echo) * char_time(self._baud) + self._echo_timeout
        self._echo_timer = loop.call_later(wait, self._echo_missing)

    def _echo_missing(self) -> None:
        self._echo_timer = None
        if self._pending_echo:
            got = bytes(self._echo_sent[: len(self._echo_sent) - len(self._pending_echo)])
            self._echo_failed(
                f"{self.describe()}: local echo missing: sent {bytes(self._echo_sent).hex(' ')}, "
                f"got back {got.hex(' ') or 'nothing'}",
                got,
            )

    def _echo_failed(self, message: str, received: bytes) -> None:
        self.stats.echo_errors += 1
        self._echo_error = EchoError(message, sent=bytes(self._echo_sent), received=received)
        self._pending_echo.clear()
        self._echo_sent.clear()
        if self._echo_timer is not None:
            self._echo_timer.cancel()
            self._echo_timer = None
        self._signal()

    def _deliver(
        self, data: bytes, timestamp: float, errors: tuple[tuple[int, LineError], ...] = ()
    ) -> None:
        """Queue received bytes (call on the event loop)."""
        if not data or not self._open:
            return
        if self._pending_echo:
            data, timestamp, errors = self._strip_echo(data, timestamp, errors)
            if not data:
                return
        size = len(data)
        stats = self.stats
        stats.bytes_in += size
        stats.chunks_in += 1
        if errors:
            stats.line_errors += len(errors)
        self._chunks.append(_chunk(data, timestamp, errors))
        self._queued_bytes += size
        self._signal(everyone=False)

    def _strip_echo(
        self, data: bytes, timestamp: float, errors: tuple[tuple[int, LineError], ...]
    ) -> tuple[bytes, float, tuple[tuple[int, LineError], ...]]:
        n = min(len(self._pending_echo), len(data))
        head = data[:n]
        flagged = any(pos < n for pos, _ in errors)
        if head != self._pending_echo[:n] or flagged:
            got = bytes(self._echo_sent[: len(self._echo_sent) - len(self._pending_echo)]) + head
            what = "flagged as line errors" if head == self._pending_echo[:n] else "differs"
            self._echo_failed(
                f"{self.describe()}: local echo {what}: sent {bytes(self._echo_sent).hex(' ')}, "
                f"got back {got.hex(' ')}",
                got,
            )
        else:
            del self._pending_echo[:n]
            self.stats.echo_bytes += n
            if not self._pending_echo:
                self._echo_sent.clear()
                if self._echo_timer is not None:
                    self._echo_timer.cancel()
                    self._echo_timer = None
        rest = data[n:]
        # The remaining bytes are the last ones of the delivery: the timestamp stays theirs.
        return rest, timestamp, shift_errors(errors, n)
