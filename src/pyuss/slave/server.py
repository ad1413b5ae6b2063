"""`SlaveServer`: one or more slave engines on one line (a `pyuss.transport.Transport`).

The server reads the line, frames telegrams with the protocol core's `Receiver` (start pause,
residual time, LGE, BCC, line errors: A 5.2; the fixed lengths of the engines with fixed
layouts), hands every good telegram to the engine it is addressed to (broadcasts to all), and
sends the answer:

- not before the profile's earliest answer, which is never less than the start pause after the
  request's last character (A 5.1.2, A 5.2.1.1), and
- within the profile's response delay (20 ms by A 5.2.1.1; 2 ms for Baumueller, 2.5..17.5 ms
  for the 6SE21). ``response_delay`` (seconds) chooses a fixed delay inside that window;
  ``manual_delay`` has each drive answer after the response delay its parameter file gives
  (``[profile] response_delay_ms``: the family's manual, SINAMICS V20 20 ms), inside the
  window; by default, and for a drive whose file gives none, the earliest moment is aimed
  at. An answer that could not start in time (a loaded machine) is still sent; if it is more
  than `LATE_MARGIN` (1 ms) late it is counted in `ServerStats.late` and logged as a warning.

Times are the transport's. On the virtual bus (in-process or ``bus://``) and on serial ports a
chunk's timestamp is when its last character ended, and the delay is measured from there. A
pty or a TCP socket carries no timing: bytes arrive at once, a whole telegram in one read. The
server then keeps a line of its own at the baud rate (`PacedLine`, sans-io): each read starts
on it when it arrived (or when the characters before it would have left it) and takes one
character time per byte, so start pauses and residual times (A 5.1.2, A 6.3) are measured on
that line. When bytes arrive is up to the writing program and the machine, not a UART: inside
a telegram, a read held up by a start pause or more, but at most `STAMP_TOLERANCE`, follows
the one before back to back, so a program that writes a telegram byte by byte and is held up
for a few milliseconds does not end its own telegram; between telegrams every pause counts as
it came. At most one telegram's worth (`MAX_TELEGRAM_BYTES` characters) waits on the line:
what a peer writes faster than the line carries beyond that is dropped (`ServerStats.dropped`),
so a peer that floods the line and leaves costs the peers after it at most one telegram time.
The answer starts the response delay after the request's last character ended on that line
(A 5.2.1.1) and is written then, all at once, as a pty or a socket carries it: the master has
the whole answer within the response delay at any baud rate (on a wire its characters would
still be coming for a telegram time). ``timed`` overrides the choice (default: timed unless
the transport is a pty or a raw TCP one). Short waits are finished by polling the clock, as
the event loop's timers are only as fine as a millisecond.
A pty or TCP line with one drive on it follows that drive's baud rate parameter (C 3): a
change written to it is answered at the old rate, then the line runs at the new one (pacing,
start pause, response window). Other lines keep their rate while they run.
Characters reach the program some time after they ended on the line; the receiver decides that
the line has fallen idle (the end of an incomplete telegram) only ``latency`` later (20 ms by
default), so that late bytes are not mistaken for a pause.

All engines on a port share one `Diagnostics` (A 5.2.3): the line's faults belong to the port.
Each exchange is logged at debug level on ``pyuss.slave`` (request and answer, decoded), the
raw frames on ``pyuss.wire`` (`pyuss.log.log_frame`). `run` serves until the ``stop`` event is
set or the task is cancelled; a lost line raises `TransportError` at the next read. An answer
the line does not take (a pty whose reader has stopped reading, its buffer full) is dropped with
a warning and counted in `ServerStats.unsent`, as a drive on RS-485 goes on answering a master
that does not listen; the server keeps serving.
"""

from __future__ import annotations

import asyncio
import logging
import math
from dataclasses import dataclass

from pyuss.bus.timed import is_station, timed_writer
from pyuss.errors import ConfigError, TelegramError, TransportError
from pyuss.log import log_frame
from pyuss.loop import sleep_until
from pyuss.protocol.diagnostics import Diagnostics
from pyuss.protocol.layout import Layout
from pyuss.protocol.receiver import Event, Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import MAX_TELEGRAM_BYTES, AddressMode, Telegram
from pyuss.slave.diagnostic import software_version
from pyuss.slave.engine import SlaveEngine
from pyuss.transport.base import STAMP_TOLERANCE, LineError, Transport
from pyuss.transport.pty import PtyPort
from pyuss.transport.queued import EchoError
from pyuss.transport.tcp import TcpServerTransport, TcpTransport

__all__ = ["PacedLine", "ServerStats", "SlaveServer", "describe", "serve"]

log = logging.getLogger("pyuss.slave")

_IDLE_READ = 0.1
"""Longest single wait for the line, so that a stop request is seen soon."""
_GUARD = 1e-9
"""Answers aim this much past their moment, so that rounding never puts them a hair early."""
LATE_MARGIN = 0.001
"""An answer is counted late when it starts more than this after the profile's latest moment
(the clock and the event loop have some jitter; a window may be a single moment)."""
DEFAULT_LATENCY = 0.020
"""How long bytes may take from the line to the program (a USB adapter's latency timer, the
virtual bus's delivery): the line counts as idle only that much after the receiver says so."""


@dataclass(slots=True)
class ServerStats:
    """What a server did."""

    received: int = 0
    """Good telegrams read from the line (for any address)."""
    faults: int = 0
    """Telegrams and bytes discarded by the receiver."""
    answers: int = 0
    unsent: int = 0
    """Answers the line did not take (nobody reads a pty): dropped, the server goes on."""
    late: int = 0
    """Answers that started after the latest moment the profile allows."""
    dropped: int = 0
    """Bytes a peer wrote on a pty or TCP line beyond the one telegram's worth that may wait
    on it (`PacedLine`): dropped before the receiver sees them."""


class PacedLine:
    """The line a server keeps for a transport without timing (a pty, a TCP socket), sans-io.

    ``char_time``: one character (11 bits, A 6.1). Times are seconds on the transport's clock;
    nothing here reads a clock.

    - `take` puts a read on the line: it starts when it arrived, or when the characters before
      it have left the line, and its bytes follow back to back.
    - While a telegram is being received (``going_on``), a read that comes at least a start
      pause (2 characters, A 5.1.2) but no more than ``hold`` after the one before would have
      ended, had that started when it arrived, follows it back to back: the writing program
      was held up (the scheduler, the network), and that is no pause of the line. A shorter
      gap is kept as it came, so a writer that paces its characters like a UART is measured
      against the residual time (A 6.3) as on a wire; a longer one ends the telegram. The line
      then runs `lag` behind the arrivals until the next telegram.
    - At most `MAX_TELEGRAM_BYTES` characters' time may be pending behind an arrival; the bytes
      of a read beyond that are not taken (a serial device server's full buffer).
    - `answer` gives the moment an answer starts.
    """

    __slots__ = ("char_time", "free", "heard", "held", "hold")

    def __init__(self, char_time: float, *, hold: float = STAMP_TOLERANCE) -> None:
        self.char_time = char_time
        self.hold = hold
        self.free = -math.inf
        """When the last character taken ends on the line (``-inf``: nothing yet)."""
        self.heard = -math.inf
        """When the last read taken would have ended, had it started when it arrived."""
        self.held = 0.0
        """The hold-up the last `take` took out (0: none): the receiver is told of it, as it
        may have been a start pause after all (`pyuss.protocol.receiver`, resynchronisation)."""

    @property
    def most(self) -> float:
        """The longest time characters may wait on the line: one longest telegram."""
        return MAX_TELEGRAM_BYTES * self.char_time

    @property
    def lag(self) -> float:
        """How far the line runs behind the arrivals (the hold-ups it took out)."""
        return max(0.0, self.heard - self.free)

    def take(self, size: int, arrival: float, *, going_on: bool = False) -> int:
        """Put ``size`` bytes read at ``arrival`` on the line; return how many of them (the
        first ones) it took. The last one taken ends at `free`. ``going_on``: a telegram (or a
        run of bytes) is being received."""
        self.held = 0.0
        if not going_on:  # a new telegram: the line catches up with the arrivals
            start = max(arrival, self.free)
        elif 2 * self.char_time <= arrival - self.heard <= self.hold:  # a hold-up
            start = self.free
            self.held = arrival - self.heard
        else:
            start = max(arrival - self.lag, self.free)
        room = math.floor((arrival + self.most - start) / self.char_time + 1e-6)
        taken = min(size, max(0, room))
        if taken:
            self.free = start + taken * self.char_time
            self.heard = arrival + taken * self.char_time
        return taken

    def answer(self, request_end: float, delay: float) -> float:
        """When an answer starts: ``delay`` after the request ended (``request_end``, as the
        receiver saw it), after the last character taken and after the last read would have
        ended, whichever is latest. The answer is written at once then; the line is free from
        then on for what the peer sends next, which has the whole answer in hand."""
        start = max(request_end, self.free, self.heard) + delay
        self.free = max(self.free, start)
        return start


def describe(telegram: Telegram, layout: Layout | None = None) -> str:
    """A telegram in one line: type, address and the net data split by ``layout``."""
    head = f"{telegram.mode.label} adr {telegram.address}"
    if layout is not None:
        try:
            net = layout.unpack(telegram.data)
        except TelegramError:
            pass
        else:
            parts = []
            if net.pkw is not None:
                parts.append("PKW " + " ".join(f"{w:04X}" for w in net.pkw.words()))
            if net.pzd:
                parts.append("PZD " + " ".join(f"{w:04X}" for w in net.pzd))
            return f"{head}: {', '.join(parts) or 'no net data'}"
    return f"{head}: {telegram.data.hex(' ').upper() or 'no net data'}"


class SlaveServer:
    """Serve ``engines`` (distinct addresses) on ``transport``; see the module docstring."""

    def __init__(
        self,
        transport: Transport,
        *engines: SlaveEngine,
        response_delay: float | None = None,
        diagnostics: Diagnostics | None = None,
        timed: bool | None = None,
        latency: float = DEFAULT_LATENCY,
        manual_delay: bool = False,
    ) -> None:
        if not engines:
            raise ConfigError("a slave server needs at least one engine")
        if manual_delay and response_delay is not None:
            raise ConfigError("a response delay of its own or the manual's, not both")
        if not 0 <= latency <= 1:
            raise ConfigError(f"latency must be 0..1 s, not {latency!r}")
        self.engines: dict[int, SlaveEngine] = {}
        for engine in engines:
            if engine.address in self.engines:
                raise ConfigError(f"two engines have bus address {engine.address}")
            self.engines[engine.address] = engine
        self.transport = transport
        self.baud = transport.baud
        self.timed = _timed(transport) if timed is None else timed
        # A pty or TCP line has no rate of its own: with one drive on it, it follows that
        # drive's baud rate parameter (C 3); other lines keep theirs while they run.
        follows = not self.timed and len(engines) == 1
        for engine in engines:
            engine.set_line_baud(self.baud, follows=follows)  # the drives show it (C 3)
            low, high = engine.response_window(self.baud)
            if response_delay is not None and not low <= response_delay <= high:
                raise ConfigError(
                    f"response delay {response_delay * 1000:g} ms is outside the window "
                    f"{low * 1000:.3f}..{high * 1000:.3f} ms of address {engine.address} "
                    f"(profile {engine.profile.name}, {self.baud} baud)"
                )
        self.response_delay = response_delay
        self.manual_delay = manual_delay
        self.diagnostics = diagnostics or Diagnostics(software_version=software_version())
        for engine in engines:
            engine.use_diagnostics(self.diagnostics)
        self.receiver = self._receiver()
        self.stats = ServerStats()
        self.latency = latency
        self.line = PacedLine(11 / self.baud)
        """The line of an untimed transport (see the module docstring)."""
        self._flooded = False
        self._due: float | None = None
        self._write_at = timed_writer(transport)

    def _receiver(self) -> Receiver:
        engines = self.engines.values()
        fixed = {e.address: e.layout.lge for e in engines if e.layout.lge is not None}
        return Receiver(
            self.baud,
            fixed_lengths=fixed,
            diagnostics=self.diagnostics,
            # one receiver per line: the most lenient device on it sets the deadline
            residual_extra_chars=max(e.profile.residual_extra_chars for e in engines),
        )

    def _follow_baud(self) -> None:
        """Switch the line to a rate a drive's baud rate parameter was set to (C 3), after the
        answer to that change went out at the old rate."""
        for engine in self.engines.values():
            baud = engine.pending_baud
            if baud is None:
                continue
            log.info("address %d: the line runs at %d baud from now on", engine.address, baud)
            self.baud = baud
            self.line.char_time = 11 / baud
            self.receiver = self._receiver()
            engine.set_line_baud(baud, follows=True)

    # -- serving ----------------------------------------------------------------------------

    async def run(self, stop: asyncio.Event | None = None) -> None:
        """Serve until ``stop`` is set (or the task is cancelled). Opens the transport if it is
        not open, and closes it again at the end in that case."""
        transport = self.transport
        opened = False
        if not getattr(transport, "is_open", False):
            await transport.open()
            opened = True
        try:
            while stop is None or not stop.is_set():
                await self._step()
        finally:
            if opened:
                await transport.close()

    async def _step(self) -> None:
        transport = self.transport
        now = transport.clock()
        wait = _IDLE_READ
        poll = self.receiver.next_poll()
        # the receiver's times are the untimed line's, which may run behind the clock
        behind = self.latency + (0.0 if self.timed else self.line.lag)
        if poll is not None:
            wait = min(wait, max(0.0, poll + behind - now))
        if self._due is not None:
            wait = min(wait, max(0.0, self._due - now))
        try:
            chunk = await transport.read(wait)
        except EchoError as exc:
            log.warning("line: %s", exc)
            return
        if chunk is None:
            events = self.receiver.poll(transport.clock() - behind)
        elif self.timed:
            events = self.receiver.feed(chunk.data, chunk.timestamp, chunk.errors)
        else:
            events = self._paced(chunk.data, chunk.timestamp, chunk.errors)
        for event in events:
            if isinstance(event, Received):
                await self._received(event)
            else:
                self._fault(event)
        # The engines' deadlines (telegram failure times) move with the telegrams they get;
        # between telegrams they are looked at again on every idle read.
        if chunk is None or events:
            self._due = self._next_due()
        if self._due is not None:
            now = transport.clock()
            if now >= self._due:
                for engine in self.engines.values():
                    engine.tick(now)
                self._due = self._next_due()
        if events:  # a telegram may have set a drive's baud rate parameter
            self._follow_baud()

    def _paced(
        self, data: bytes, arrival: float, errors: tuple[tuple[int, LineError], ...]
    ) -> list[Event]:
        """Put a read of an untimed line on `line` and feed what it took to the receiver."""
        taken = self.line.take(len(data), arrival, going_on=self.receiver.receiving)
        if taken < len(data):
            self.stats.dropped += len(data) - taken
            if not self._flooded:
                log.warning(
                    "line: a peer writes faster than %d baud carries: %d bytes dropped (at most "
                    "one telegram's worth waits on the line)",
                    self.baud,
                    len(data) - taken,
                )
            self._flooded = True
        else:
            self._flooded = False
        if not taken:
            return []
        kept = [(pos, flag) for pos, flag in errors if pos < taken]
        return self.receiver.feed(data[:taken], self.line.free, kept, held=self.line.held)

    def _next_due(self) -> float | None:
        """The first moment an engine's `SlaveEngine.tick` has something to do."""
        due = None
        for engine in self.engines.values():
            deadline = engine.next_deadline()
            if deadline is not None and (due is None or deadline < due):
                due = deadline
        return due

    def _fault(self, event: ReceiveFault) -> None:
        self.stats.faults += 1
        note = f"discarded: {event.kind.name.lower()}: {event.detail}"
        log_frame("rx", event.raw, event.end, note)
        log.debug("line: %d bytes %s", len(event.raw), note)

    async def _received(self, event: Received) -> None:
        self.stats.received += 1
        telegram = event.telegram
        log_frame("rx", event.raw, event.end)
        if telegram.mode in (AddressMode.BROADCAST, AddressMode.SPECIAL_BROADCAST):
            for engine in self.engines.values():
                engine.handle(telegram, event.end)
            if log.isEnabledFor(logging.DEBUG):
                log.debug("%s (broadcast, no answer)", describe(telegram))
            return
        target = self.engines.get(telegram.address)
        if target is None:
            return
        await self._answer(target, event)

    async def _answer(self, engine: SlaveEngine, event: Received) -> None:
        telegram = event.telegram
        answer = engine.handle(telegram, event.end)
        layout = engine.layout if telegram.mode is AddressMode.NORMAL else None
        if answer is None:
            if log.isEnabledFor(logging.DEBUG):
                log.debug("%s -> no answer", describe(telegram, layout))
            return
        low, high = engine.response_window(self.baud)
        chosen = engine.manual_delay(self.baud) if self.manual_delay else self.response_delay
        delay = low if chosen is None else min(max(chosen, low), high)
        end = event.end
        if not self.timed:
            # the request's end on the untimed line (the receiver may have taken a writer's
            # short hold-ups as back to back, `PacedLine.answer`)
            target = self.line.answer(end, delay + _GUARD)
            end = target - delay - _GUARD
        else:
            target = end + delay + _GUARD
        data = answer.encode()
        try:
            if self._write_at is not None:  # the bus starts it at ``target`` exactly
                await self._write_at(data, target)
                start = max(self.transport.clock(), target)
            else:  # an untimed line's answer too: written at once when it starts
                await self._wait_until(target)
                start = self.transport.clock()
                await self.transport.write(data)
        except TransportError as exc:  # a line that is really lost ends `run` at the next read
            self.stats.unsent += 1
            log.warning("address %d: answer not sent: %s", engine.address, exc)
            return
        self.stats.answers += 1
        log_frame("tx", data, start)
        if log.isEnabledFor(logging.DEBUG):
            log.debug("%s -> %s", describe(telegram, layout), describe(answer, layout))
        if start - end > high + LATE_MARGIN:
            self.stats.late += 1
            log.warning(
                "address %d: answer started %.3f ms after the request, later than the %.3f ms "
                "the profile allows",
                engine.address,
                (start - end) * 1000,
                high * 1000,
            )

    async def _wait_until(self, target: float) -> None:
        await sleep_until(target, self.transport.clock)

    # -- helpers ----------------------------------------------------------------------------

    def close(self) -> None:
        """End the engines' change subscriptions."""
        for engine in self.engines.values():
            engine.close()


def _timed(transport: Transport) -> bool:
    """Whether the transport's timestamps follow the line (see the module docstring)."""
    if is_station(transport):
        return True
    return not isinstance(transport, PtyPort | TcpTransport | TcpServerTransport)


async def serve(
    transport: Transport,
    *engines: SlaveEngine,
    stop: asyncio.Event | None = None,
    response_delay: float | None = None,
) -> SlaveServer:
    """Run a `SlaveServer` until ``stop`` is set; return it (with its statistics)."""
    server = SlaveServer(transport, *engines, response_delay=response_delay)
    try:
        await server.run(stop)
    finally:
        server.close()
    return server
