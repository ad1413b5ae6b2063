"""The line under the asyncio master: `Wire` keeps the start pause, writes each telegram
(timed on a virtual bus), reads the chunks into the core and waits for an answer as the core's
`pyuss.master.core.Exchange` says. The master's loop (`pyuss.master.scheduler`) asks it for
one exchange at a time.

Time bases
    All times are the transport's ``clock()``. Transports with exact timestamps (the virtual
    bus in-process and ``bus://``) are judged exactly by the core's rules. Other transports
    (serial ports, ptys, TCP) stamp bytes when the program reads them, which USB adapters do in
    bursts every 1..16 ms; for them ``rx_tolerance`` (default 20 ms,
    `pyuss.transport.base.stamp_tolerance`) widens the receive side only: the receiver takes
    it as the tolerance of the stamps (`Receiver(tolerance=...)`, shared with the monitor: a
    gap inside a telegram shorter than the tolerance is the stamps' and closed, so the
    residual-time check of A 5.2.1.2 is not fooled by a late stamp, and the idle gap that ends
    an incomplete telegram is at least the tolerance), and the answer may begin up to the
    tolerance after the response delay limit. The master's own sending keeps at least the
    specification's start pause always. ``latency`` (default 20 ms) is how long after a
    deadline the master still waits for bytes that were on the line in time but not yet
    delivered: before it takes a telegram for broken off, and, as ``silence`` unless that is
    given, after the response window (and the end of a first character that began at its end)
    before it takes a slave for silent; that only costs time when a slave is silent.
    `pyuss.master.scan` waits `EXACT_LATENCY` there on the virtual bus, which hands characters
    over within microseconds.

    On the virtual bus the master hands each telegram over a moment before its start pause
    ends, with the time it is to start (`pyuss.bus.timed`), so the pause is kept to the
    microsecond; elsewhere it sleeps until shortly before and yields to the event loop for
    the rest (`pyuss.loop`), which is as exact as the machine allows on any event loop.
    There, for a slave of fixed layout, it also waits for the whole answer at once
    (`QueuedTransport.wait_bytes`) instead of waking for each of the bus's three hand-overs
    of a telegram: the chunks keep their end times on the line, so the answer is judged
    exactly as before, and only an answer that is not all in by the end of the response
    window is followed chunk by chunk.

    The end of a request is taken as the time the write began plus its characters' time on the
    line (or the time the write returned, if later). Over a bare pty or TCP link the answer's
    start is estimated from when its last byte was read: a peer that writes faster than a real
    line reads as answering sooner (down to 0; `uss simulate` paces its answers).
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable, Collection
from typing import TYPE_CHECKING

from pyuss.errors import ConfigError
from pyuss.loop import COARSE_MARGIN
from pyuss.loop import margin as loop_margin
from pyuss.master.core import Exchange, MasterCore, Result, Slave
from pyuss.protocol.telegram import AddressMode
from pyuss.transport.base import Chunk, Transport
from pyuss.transport.queued import check_baud
from pyuss.transport.reconnect import LinkDown, ReconnectingTransport

if TYPE_CHECKING:
    from pyuss.bus.timed import TimedWrite

__all__ = ["LineDown", "Wire", "line_down", "line_transport"]

WaitBytes = Callable[[int, float], Awaitable[None]]
"""``wait_bytes(count, timeout)`` of `pyuss.transport.queued.QueuedTransport`."""


def _timed_writer(transport: Transport) -> TimedWrite | None:
    """`pyuss.bus.timed.timed_writer` (imported only here: the bus is loaded for its stations),
    also through a reconnecting ``bus://`` station."""
    from pyuss.bus.timed import timed_writer

    if isinstance(transport, ReconnectingTransport):
        return transport.timed_writer()
    return timed_writer(transport)


class LineDown(Exception):
    """A telegram could not be sent: the link is down (`MasterCore.line_down`)."""


def line_transport(transport: Transport | str, baud: int | None) -> Transport:
    """The transport of a master: a URL opened (at ``baud``, 9600 by default), or the given
    transport, whose rate ``baud`` must be if given."""
    if isinstance(transport, str):
        from pyuss.transport.url import open_transport

        transport = open_transport(transport, baud=check_baud(baud or 9600))
    elif not isinstance(transport, Transport):
        raise ConfigError(f"transport must be a Transport or a URL, not {transport!r}")
    if baud is not None and check_baud(baud) != transport.baud:
        raise ConfigError(f"baud {baud} given, but the transport runs at {transport.baud}")
    return transport


def line_down(core: MasterCore, error: LinkDown) -> None:
    """Tell ``core`` the link is down; requests are refused with a `LinkDown` saying why."""
    core.line_down(LinkDown(f"the line is down, being reopened ({error}): not sent"))


class Wire:
    """The asyncio I/O of one master's line (see the module docstring)."""

    def __init__(self, core: MasterCore, transport: Transport) -> None:
        self.core = core
        self.transport = transport
        # where the transport has them (`QueuedTransport`): a look for chunks without a
        # coroutine, and a wait for the whole answer at once (in `transact`)
        self._read_nowait: Callable[[], Chunk | None] | None = getattr(
            transport, "read_nowait", None
        )
        self._wait_bytes: WaitBytes | None = getattr(transport, "wait_bytes", None)
        self.margin = COARSE_MARGIN
        """How close to a moment the loop's timers are trusted (`pyuss.loop`), once started."""
        self.write_at = _timed_writer(transport)

    def start(self) -> None:
        self.margin = loop_margin()

    async def listen(self, until: float) -> None:
        """Take in what arrives until ``until`` (plus latency) and the line is quiet."""
        core = self.core
        while True:
            await self.drain()
            wait = core.listen_done(until, self.transport.clock())
            if wait is None:
                return
            chunk = await self.transport.read(wait)
            if chunk is not None:
                core.between(core.feed(chunk))

    async def send(
        self,
        frame: bytes | Callable[[], bytes],
        pause_chars: float,
        answer_within: float | None = None,
        early: bool = False,
    ) -> tuple[float, float]:
        """Keep the start pause, send ``frame`` (or what ``frame()`` builds then); returns the
        telegram's start and end time. ``answer_within``: the time after its end in which an
        answer must begin (response window and tolerance): on a virtual bus the answer may
        then be handed over whole, as long as its first character comes by the time it
        would be handed over at the latest anyway (`TimedWrite`).

        ``early`` (a telegram to another slave than the one whose last answer woke tasks
        waiting for it): on a virtual bus it is handed over at once, the start pause still
        ahead, before what the last answer's subscribers left for later runs - the faces'
        work is done while the telegram is on the line, not before it. Else the woken tasks
        run first: one may have a job for this very telegram."""
        core = self.core
        # On a virtual bus the telegram is handed over a moment early with its start time
        # (`timed_writer`); elsewhere the last moments of the pause pass yielding to the loop.
        early = early and self.write_at is not None
        ahead = 0.0
        if self.write_at is not None:
            pause = max(2.0, pause_chars) * core.timing.char_time
            ahead = max(self.margin, core.timing.char_time, pause if early else 0.0)
        if not early:
            await asyncio.sleep(0)  # let tasks woken by the last answer queue their jobs first
        clock = self.transport.clock
        while True:
            await self.drain()
            due = core.send_due(pause_chars)
            left = due - clock()
            if left <= ahead:
                break
            sleep = left - max(ahead, self.margin)
            if sleep > 0:  # sleep while the loop's timers are precise enough
                chunk = await self.transport.read(sleep)
                if chunk is not None:
                    core.between(core.feed(chunk))
            else:
                await asyncio.sleep(0)
        core.sending(clock() if core.receiver.busy else 0.0)
        if callable(frame):
            frame = frame()
        start = clock()
        on_line = core.timing.transmit(len(frame))
        try:
            if self.write_at is not None:
                # late for the pause (the last answer took longer than it): at once, and the
                # answer's moment counted from now, so that it is still handed over whole
                start = max(due, start)
                hold = None
                if answer_within is not None:
                    # the first character of an answer that begins at the deadline ends one
                    # character time after it: that is when it must be here at the latest
                    hold = start + on_line + answer_within + core.timing.char_time
                await self.write_at(frame, start, hold)
            else:
                await self.transport.write(frame)
        except LinkDown as exc:
            line_down(core, exc)
            raise LineDown from exc
        if core.down is not None:  # the first telegram after an outage went out
            core.line_back()
        core.sent(frame, start, on_line, clock())
        return start, core.line_free

    async def drain(self) -> None:
        """Take in what arrived between exchanges."""
        core = self.core
        if (read_nowait := self._read_nowait) is not None:
            while (chunk := read_nowait()) is not None:
                core.between(core.feed(chunk))
        else:
            while (chunk := await self.transport.read(0)) is not None:
                core.between(core.feed(chunk))
        if core.receiver.busy:
            core.settle(self.transport.clock())

    async def transact(
        self,
        frame: bytes | Callable[[], bytes],
        address: int,
        modes: Collection[AddressMode],
        limit: float,
        pause_chars: float,
        slave: Slave | None,
        *,
        early: bool = False,
    ) -> Result:
        """Send ``frame`` and wait for the answer of ``address`` (A 5.2, `Exchange`);
        ``early``: see `send`."""
        core = self.core
        start, end = await self.send(frame, pause_chars, limit + core.rx_tolerance, early)
        exchange = Exchange(core, address, modes, limit, slave, start, end)
        whole, expected = None, 0
        if slave is not None and self._wait_bytes is not None and core.exact:
            lge = slave.layout.lge  # a fixed length: the whole answer is waited for at once
            if lge is not None:
                whole, expected = self._wait_bytes, lge + 2
        clock = self.transport.clock
        read_nowait = self._read_nowait
        while True:
            now = clock()
            # every chunk that is in is fed before time is judged (a read may time out just
            # as a chunk arrives)
            if read_nowait is not None:
                while (chunk := read_nowait()) is not None:
                    exchange.feed(chunk)
            else:
                while (chunk := await self.transport.read(0)) is not None:
                    exchange.feed(chunk)
            wait = exchange.step(now)
            if isinstance(wait, Result):
                return wait
            if wait is None:
                await asyncio.sleep(0)  # what is due is handed over first
                chunk = await self.transport.read(0)
                if chunk is None:
                    return exchange.give_up(clock())
                exchange.feed(chunk)
            elif whole is not None and not core.receiver.busy:
                # nothing of the answer yet: wake once, when all of it may be in (the
                # chunks keep their timestamps, the answer is judged as it would be anyway)
                await whole(expected, wait)
            elif (chunk := await self.transport.read(wait)) is not None:
                exchange.feed(chunk)
