"""Reconnect after a lost link (USB adapter unplugged, TCP connection dropped).

`ReconnectingTransport` wraps a factory of transports and hands reads and writes to the one
in use. When the link is lost (a read or a write finds it gone), a new transport is made and
opened: the first try at once, then after ``backoff_initial`` seconds (`BACKOFF_INITIAL`,
0.5 s), the wait doubling after each failed try up to ``backoff_max`` (`BACKOFF_MAX`, 10 s):
0, 0.5, 1, 2, 4, 8, 10, 10 ... seconds. Readers meanwhile just wait (a read with a timeout
returns ``None``): a master sees its slaves not answering, which is what happened on the
wire. Writes while the link is down raise `LinkDown` (a `TransportError`): the bytes were not
sent, and the caller must know (`connected` says whether the link is up).

An outage is logged (logger ``pyuss.transport.reconnect``, WARNING) once when it begins, once
a minute while it lasts (`REPORT_EVERY`: its duration, the tries so far and the last error)
and once when it ends, with its duration; each try is logged at DEBUG. A link that comes back
and is lost again within `SETTLE` seconds (a converter that takes the connection and drops
it) continues the outage: the waits go on doubling, and its end is logged once the link has
stayed up that long.

Readers get a `TransportError` only when reconnecting is given up: after ``max_attempts``
failed tries in a row (``None``: never), or when `give_up()` is called, or when reconnecting
itself breaks (an ``on_loss`` callback that raises). The first `open()` is not retried: a
wrong port name or address is reported at once.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable, Coroutine, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.base import Chunk
from pyuss.transport.queued import EchoError, QueuedTransport

if TYPE_CHECKING:
    from pyuss.bus.timed import TimedWrite

__all__ = [
    "BACKOFF_INITIAL",
    "BACKOFF_MAX",
    "REPORT_EVERY",
    "SETTLE",
    "LinkDown",
    "ReconnectingTransport",
    "backoff",
    "duration_text",
]

log = logging.getLogger(__name__)

BACKOFF_INITIAL = 0.5
"""Seconds between the first failed try (made at once) and the second."""
BACKOFF_MAX = 10.0
"""The longest wait between two tries: a line that comes back is in use within 10 s."""
SETTLE = 1.0
"""Seconds a link that came back must stay up for its outage to end (and be logged ended)."""
REPORT_EVERY = 60.0
"""Seconds between two log lines of one outage while it lasts."""


def backoff(initial: float, cap: float) -> Iterator[float]:
    """The waits between failed tries: ``initial``, then doubled each time up to ``cap``."""
    delay = initial
    while True:
        yield delay
        delay = min(delay * 2, cap)


def duration_text(seconds: float) -> str:
    """``4.2 s``, ``3 min 5 s``, ``2 h 7 min``: how long an outage lasted, for a log line."""
    if seconds < 60:
        return f"{seconds:.1f} s"
    whole = int(seconds)
    if whole < 3600:
        return f"{whole // 60} min {whole % 60} s"
    return f"{whole // 3600} h {whole % 3600 // 60} min"


class LinkDown(TransportError):
    """A write while the link is lost and being re-established: nothing was sent."""


@dataclass(slots=True)
class _Outage:
    """One outage: from the loss until the link has been back for `SETTLE` seconds."""

    began: float
    delays: Iterator[float]
    told: float
    """When the outage was last logged (its start, then each minute)."""
    tries: int = 0
    last: str = ""
    resumed: bool = False
    """The link came back and was lost again within `SETTLE`: wait before the next try."""
    back: float = field(default=math.nan)
    """When the link came back last."""


class ReconnectingTransport(QueuedTransport):
    """A transport that re-opens its link after a loss; see the module docstring.

    Reads and writes go to the transport in use (`inner`), so what it offers - its
    timestamps, `read_nowait`, `wait_bytes`, a virtual bus station's timed sends
    (`timed_writer`) - is there as if it were used directly; its counters are
    ``inner.stats``. A loss is noticed by the next read or write (a master reads all the
    time), or by asking `connected`."""

    def __init__(
        self,
        factory: Callable[[], QueuedTransport],
        *,
        backoff_initial: float = BACKOFF_INITIAL,
        backoff_max: float = BACKOFF_MAX,
        max_attempts: int | None = None,
        on_loss: Callable[[TransportError], None] | None = None,
        on_reconnect: Callable[[], None] | None = None,
    ) -> None:
        if not 0 < backoff_initial <= backoff_max:
            raise ConfigError(
                f"back-off must satisfy 0 < initial <= max, not {backoff_initial!r}, "
                f"{backoff_max!r}"
            )
        if max_attempts is not None and max_attempts < 1:
            raise ConfigError(f"max_attempts must be >= 1 or None, not {max_attempts!r}")
        self._factory = factory
        self._inner = factory()
        super().__init__(baud=self._inner.baud)
        self.clock = self._inner.clock
        """The clock of the transport in use, bound to it (rebound when the link is back): the
        master reads it several times per exchange, without a forwarding call each time."""
        self._initial = backoff_initial
        self._max = backoff_max
        self._max_attempts = max_attempts
        self._on_loss = on_loss
        self._on_reconnect = on_reconnect
        self._connected = False
        self._up: asyncio.Event | None = None
        """Set while the link is up, and when reading is to stop waiting (given up, closed)."""
        self._task: asyncio.Task[None] | None = None
        self._giving_up: asyncio.Event | None = None
        self._outage: _Outage | None = None
        self._settle: asyncio.TimerHandle | None = None
        self.losses = 0
        self.reconnects = 0
        self._timed: tuple[QueuedTransport, TimedWrite | None] | None = None
        """The transport in use and its timed send (`write_at`), looked up once."""

    @property
    def exact_timestamps(self) -> bool:
        return self._inner.exact_timestamps

    @property
    def inner(self) -> QueuedTransport:
        """The transport in use now."""
        return self._inner

    @property
    def connected(self) -> bool:
        """Whether the link is up: False while it is being re-established. A loss no read or
        write noticed yet counts: asking notices it (and reopening begins)."""
        failure = self._inner._failure
        if self._connected and failure is not None:
            try:
                asyncio.get_running_loop()
            except RuntimeError:  # (asked outside the loop: the next read notices it)
                return False
            self._lost(failure)
        return self._connected

    def describe(self) -> str:
        return self._inner.describe()

    def timed_writer(self) -> TimedWrite | None:
        """`write_at` where the link is a station of a virtual bus (`pyuss.bus.timed`): the
        telegrams keep their start times to the microsecond over a reconnecting ``bus://``."""
        from pyuss.bus.timed import timed_writer

        return self.write_at if timed_writer(self._inner) is not None else None

    # -- open and close ------------------------------------------------------------------------
    async def open(self) -> None:
        if self.is_open:
            return
        await self._inner.open()
        self._connected = True
        self._giving_up = asyncio.Event()
        self._mark_open()
        self._up = asyncio.Event()
        self._up.set()

    async def close(self) -> None:
        if not self.is_open:
            return
        self._mark_closed()
        if self._settle is not None:
            self._settle.cancel()
            self._settled()  # it was back: say so
        if self._task is not None:
            task, self._task = self._task, None
            task.cancel()
            await asyncio.wait({task})
        self._connected = False
        if self._up is not None:
            self._up.set()  # readers see it closed
        await self._inner.close()

    def give_up(self) -> None:
        """Stop reconnecting: readers get a `TransportError` once the link is down."""
        if self._giving_up is None:
            return
        self._giving_up.set()
        if not self._connected and self._outage is not None:
            self._fail(f"gave up reconnecting; last: {self._outage.last or 'none'}")

    # -- reading and writing -------------------------------------------------------------------
    def read_nowait(self) -> Chunk | None:
        if self._failure is not None:
            raise self._failure
        if not self._open:
            raise TransportError(f"{self.describe()} is closed")
        if not self._connected:
            return None
        inner = self._inner
        if (
            not inner._chunks
            and inner._echo_error is None
            and inner._failure is None
            and inner._open
            and inner._ready is not None
        ):
            return None  # what the inner transport says then, without the call (asked often)
        try:
            return inner.read_nowait()
        except EchoError:
            raise
        except TransportError as exc:
            self._lost(exc)
            return self.read_nowait()  # the failure, if reconnecting broke at once

    async def read(self, timeout: float | None = None) -> Chunk | None:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            chunk = self.read_nowait()
            if chunk is not None:
                return chunk
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                return None
            if not self._connected:
                if not await self._wait_up(left):
                    return None
                continue
            try:
                return await self._inner.read(left)
            except EchoError:
                raise
            except TransportError as exc:
                self._lost(exc)

    def wait_bytes(self, count: int, timeout: float) -> Coroutine[Any, Any, None]:
        """`QueuedTransport.wait_bytes` of the transport in use, its coroutine itself (no
        coroutine of its own around it: the master waits like this at every exchange); while
        the link is down, until it is back."""
        if self._connected:
            return self._inner.wait_bytes(count, timeout)
        return self._wait_down(timeout)

    async def _wait_down(self, timeout: float) -> None:
        if self.is_open and self._failure is None:
            await self._wait_up(timeout)

    async def _wait_up(self, timeout: float | None) -> bool:
        """Wait until the link is back (or reading is to stop); False when ``timeout`` passed."""
        up = self._up
        assert up is not None
        try:
            async with asyncio.timeout(timeout):
                await up.wait()
        except TimeoutError:
            return False
        return True

    def _link(self, size: int) -> QueuedTransport:
        """The transport to write ``size`` bytes to; `LinkDown` while the link is down."""
        if self._failure is not None or not self._open:
            self._check_writable()  # raises
        if not self._connected:
            raise LinkDown(f"{self.describe()}: link down, reconnecting; {size} bytes not sent")
        return self._inner

    async def write(self, data: bytes) -> None:
        inner = self._link(len(data))
        try:
            await inner.write(data)
        except TransportError as exc:
            self._lost(exc)
            raise LinkDown(f"{exc}; {len(data)} bytes not sent") from exc

    async def write_at(self, data: bytes, start: float, hold_until: float | None = None) -> None:
        """`write` with the start time of the virtual bus's timed sends (`timed_writer`)."""
        inner = self._link(len(data))
        timed = self._timed
        if timed is None or timed[0] is not inner:  # looked up once per transport in use
            from pyuss.bus.timed import timed_writer

            timed = self._timed = (inner, timed_writer(inner))
        write_at = timed[1]
        assert write_at is not None, "write_at needs a station of a virtual bus"
        try:
            await write_at(data, start, hold_until)
        except TransportError as exc:
            self._lost(exc)
            raise LinkDown(f"{exc}; {len(data)} bytes not sent") from exc

    def flush_input(self) -> None:
        if self._connected:
            self._inner.flush_input()

    # -- the outage ----------------------------------------------------------------------------
    def _lost(self, error: TransportError) -> None:
        """The link is lost: say so (unless it continues an outage) and reconnect."""
        if not self._connected or not self._open:
            return
        self._connected = False
        assert self._up is not None and self._giving_up is not None
        self._up.clear()
        self.losses += 1
        now = time.monotonic()
        outage = self._outage
        if self._settle is not None and outage is not None:  # back for less than SETTLE
            self._settle.cancel()
            self._settle = None
            outage.resumed = True
            outage.last = str(error)
        else:
            outage = self._outage = _Outage(now, backoff(self._initial, self._max), now)
            outage.last = str(error)
            log.warning(
                "%s: link lost: %s; reconnecting (at once, then after %g s, the wait doubling "
                "up to %g s)",
                self.describe(),
                error,
                self._initial,
                self._max,
            )
        if self._on_loss is not None:
            try:
                self._on_loss(error)
            except Exception as exc:
                self._fail(f"reconnecting failed: {exc!r}")
                return
        if self._giving_up.is_set():
            self._fail(f"gave up reconnecting; last: {error}")
            return
        self._task = asyncio.get_running_loop().create_task(
            self._reconnect(self._inner, outage), name="uss reconnect"
        )
        self._task.add_done_callback(self._reconnect_ended)

    def _fail(self, why: str) -> None:
        """Reconnecting is over: readers get a `TransportError` saying ``why``."""
        self._lose(TransportError(f"{self.describe()}: {why}"))
        log.info("%s: %s", self.describe(), why)
        if self._up is not None:
            self._up.set()

    def _reconnect_ended(self, task: asyncio.Task[None]) -> None:
        """Whatever stops reconnecting unexpectedly reaches the readers, never only a log."""
        if task.cancelled() or task.exception() is None:
            return
        exc = task.exception()
        log.error("%s: reconnecting failed: %r", self.describe(), exc)
        self._fail(f"reconnecting failed: {exc!r}")

    async def _reconnect(self, old: QueuedTransport, outage: _Outage) -> None:
        assert self._giving_up is not None and self._up is not None
        with contextlib.suppress(TransportError):
            await old.close()
        if outage.resumed and not await self._pause(outage, next(outage.delays)):
            return
        while True:
            inner = self._factory()
            try:
                await inner.open()
            except TransportError as exc:
                outage.tries += 1
                outage.last = str(exc)
                log.debug("%s: reconnect try %d failed: %s", self.describe(), outage.tries, exc)
                if self._max_attempts is not None and outage.tries >= self._max_attempts:
                    self._fail(f"gave up after {outage.tries} tries; last: {exc}")
                    return
                if not await self._pause(outage, next(outage.delays)):
                    return
                continue
            self._inner = inner
            self.clock = inner.clock
            self._connected = True
            self.reconnects += 1
            outage.tries += 1
            outage.back = time.monotonic()
            self._up.set()
            loop = asyncio.get_running_loop()
            self._settle = loop.call_later(SETTLE, self._settled)
            if self._on_reconnect is not None:
                self._on_reconnect()
            return

    async def _pause(self, outage: _Outage, delay: float) -> bool:
        """Wait ``delay`` seconds before the next try, logging the outage each minute; False
        when reconnecting is given up meanwhile (readers told)."""
        assert self._giving_up is not None
        end = time.monotonic() + delay
        while True:
            now = time.monotonic()
            due = outage.told + REPORT_EVERY
            wait = min(end, due) - now
            if wait > 0:
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(wait):
                        await self._giving_up.wait()
            if self._giving_up.is_set():
                self._fail(f"gave up reconnecting; last: {outage.last}")
                return False
            now = time.monotonic()
            if now >= due:
                outage.told = now
                log.warning(
                    "%s: link still lost after %s (%d tries so far); last: %s",
                    self.describe(),
                    duration_text(now - outage.began),
                    outage.tries,
                    outage.last,
                )
            if now >= end:
                return True

    def _settled(self) -> None:
        """The link stayed up: the outage is over."""
        self._settle = None
        outage, self._outage = self._outage, None
        if outage is None:
            return
        log.warning(
            "%s: link back after %s (%d %s)",
            self.describe(),
            duration_text(outage.back - outage.began),
            outage.tries,
            "try" if outage.tries == 1 else "tries",
        )
