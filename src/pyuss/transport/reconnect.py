"""Reconnect after a lost link (USB adapter unplugged, TCP connection dropped).

`ReconnectingTransport` wraps a factory of transports. When the link is lost, the loss is
reported (``on_loss`` callback and a warning on the ``pyuss.transport.reconnect`` logger,
``losses`` counts it) and a new transport is made and opened, waiting ``backoff_initial``
seconds before the first try and doubling the wait after each failed try up to
``backoff_max``. Readers meanwhile just wait (a read with a timeout returns ``None``): a master
sees its slaves not answering, which is what happened on the wire. Writes while the link is
down raise `LinkDown` (a `TransportError`): the bytes were not sent, and the caller must know.

Each failed try is logged with its error and the next wait. Readers get a `TransportError`
only when reconnecting is given up: after ``max_attempts`` failed tries in a row (``None``:
never) or when `give_up()` is called, or when reconnecting itself breaks. The first `open()` is
not retried: a wrong port name or address is reported at once.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable, Iterator

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.base import Transport
from pyuss.transport.queued import EchoError, QueuedTransport

log = logging.getLogger(__name__)


def backoff(initial: float, cap: float) -> Iterator[float]:
    """The waits before each reconnect try: ``initial``, then doubled each time up to ``cap``."""
    delay = initial
    while True:
        yield delay
        delay = min(delay * 2, cap)


class LinkDown(TransportError):
    """A write while the link is lost and being re-established."""


class ReconnectingTransport(QueuedTransport):
    """A transport that re-opens its link after a loss; see the module docstring."""

    def __init__(
        self,
        factory: Callable[[], Transport],
        *,
        backoff_initial: float = 0.1,
        backoff_max: float = 5.0,
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
        self._initial = backoff_initial
        self._max = backoff_max
        self._max_attempts = max_attempts
        self._on_loss = on_loss
        self._on_reconnect = on_reconnect
        self._connected = False
        self._task: asyncio.Task[None] | None = None
        self._giving_up: asyncio.Event | None = None
        self.losses = 0
        self.reconnects = 0

    @property
    def exact_timestamps(self) -> bool:
        return self._inner.exact_timestamps

    @property
    def inner(self) -> Transport:
        """The transport in use now."""
        return self._inner

    @property
    def connected(self) -> bool:
        return self._connected

    def describe(self) -> str:
        describe = getattr(self._inner, "describe", None)
        return f"reconnecting {describe() if callable(describe) else type(self._inner).__name__}"

    def clock(self) -> float:
        return self._inner.clock()

    async def open(self) -> None:
        if self.is_open:
            return
        await self._inner.open()
        self._connected = True
        self._giving_up = asyncio.Event()
        self._mark_open()
        self._task = asyncio.create_task(self._supervise(), name="uss reconnect")
        self._task.add_done_callback(self._supervisor_ended)

    def _supervisor_ended(self, task: asyncio.Task[None]) -> None:
        """Whatever stops the supervisor unexpectedly reaches the readers, never only a log."""
        if task.cancelled() or task.exception() is None:
            return
        exc = task.exception()
        log.error("%s: reconnecting failed: %r", self.describe(), exc)
        self._lose(TransportError(f"{self.describe()}: reconnecting failed: {exc!r}"))

    def give_up(self) -> None:
        """Stop reconnecting: readers get a `TransportError` once the link is down."""
        if self._giving_up is not None:
            self._giving_up.set()

    async def _supervise(self) -> None:
        while self.is_open:
            try:
                chunk = await self._inner.read()
            except EchoError as exc:
                self._echo_error = exc
                self._signal()
                continue
            except TransportError as exc:
                self._connected = False
                self.losses += 1
                log.warning("%s: link lost: %s", self.describe(), exc)
                if self._on_loss is not None:
                    self._on_loss(exc)
                with contextlib.suppress(TransportError):
                    await self._inner.close()
                failure = await self._reconnect(exc)
                if failure is not None:
                    self._lose(failure)
                    return
                continue
            if chunk is not None:
                self._deliver(chunk.data, chunk.timestamp, chunk.errors)

    async def _reconnect(self, cause: TransportError) -> TransportError | None:
        assert self._giving_up is not None
        delays = backoff(self._initial, self._max)
        delay = next(delays)
        attempts = 0
        last = cause
        while True:
            if self._giving_up.is_set():
                return TransportError(f"{self.describe()}: gave up reconnecting; last: {last}")
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(delay):
                    await self._giving_up.wait()
                continue
            inner = self._factory()
            try:
                await inner.open()
            except TransportError as exc:
                attempts += 1
                last = exc
                if self._max_attempts is not None and attempts >= self._max_attempts:
                    log.warning("%s: reconnect try %d failed: %s", self.describe(), attempts, exc)
                    return TransportError(
                        f"{self.describe()}: gave up after {attempts} tries; last: {exc}"
                    )
                delay = next(delays)
                log.info(
                    "%s: reconnect try %d failed: %s; next try in %g s",
                    self.describe(),
                    attempts,
                    exc,
                    delay,
                )
                continue
            self._inner = inner
            self._connected = True
            self.reconnects += 1
            log.warning("%s: link back after %d failed tries", self.describe(), attempts)
            if self._on_reconnect is not None:
                self._on_reconnect()
            return None

    async def write(self, data: bytes) -> None:
        self._check_writable()
        if not self._connected:
            raise LinkDown(
                f"{self.describe()}: link down, reconnecting; {len(data)} bytes not sent"
            )
        await self._inner.write(data)
        self.stats.bytes_out += len(data)

    def flush_input(self) -> None:
        super().flush_input()
        if self._connected:
            self._inner.flush_input()

    async def close(self) -> None:
        if not self.is_open:
            return
        self._mark_closed()
        if self._task is not None:
            task, self._task = self._task, None
            task.cancel()
            await asyncio.wait({task})  # its failure, if any, was reported to the readers
        self._connected = False
        await self._inner.close()
