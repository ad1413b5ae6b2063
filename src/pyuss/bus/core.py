"""The virtual RS-485 segment: stations, the wire timeline, collisions and delivery.

Timing model (A 6.1, B 3.2): a character occupies the line for one character time
``tc = 11 / baud``. A station that writes at time ``t`` puts its first character on the line at
``max(t, end of its own queued characters)``, the following ones back to back: a station waits
behind its own bytes, never behind another station's (there is no carrier sense on RS-485).
When characters of two stations overlap in time, both are garbled: the line is modelled as
dominant-low (a 0 from any driver wins), and every receiver samples the resulting levels in
the middle of each bit of the frame that began with the first start bit, so it sees a byte
with the framing and parity errors the sampling yields (`pyuss.bus.line`; the tail of a
character swallowed that way still drives the line during the next one). Each such garbled
character is part of a collision (`BusStats.collisions` counts the episodes,
`BusStats.garbled` the characters).

Delivery: never before a character's end time, in the event loop's real time, as close to the
chosen moment as the loop allows (the lag is measured by ``bench/bench_bus.py``). The first
character after idle time is handed over when it ends; the characters that follow it without a
gap (the rest of the sender's queued characters) are handed over together, all but the last
`RUN_LEAD` a little before the run ends and those when it ends, none more than `RUN_HOLD` after
its own end. A station waiting for an answer sees it begin at once and digests most of it while
its last characters are on the line: three hand-overs per telegram instead of one per character
or two. A station that holds runs (``hold=True``, every ``bus://`` client) takes the first
character at once and the rest of the run when it ends: two, each a wake-up of its process;
a master among them tells the bus with each request by when its answer must be in at the
latest (`Station.hold_answer`), and takes the answer in one piece where it ends before then.
On a loop with fine timers (`pyuss.loop`) the bus wakes up `FINE_MARGIN` before the
hand-over that ends a run and yields until it is due: a process that slept wakes up late. The
chunk timestamps are the *ideal* end times, not the moment of delivery: receivers measure exact
gaps, start pauses (A 5.1.2) and residual times (A 6.3). Contiguous characters (no idle time
between them) handed over together form one chunk; an idle gap, however short, starts a new
chunk. The bus uses the line's clock (`pyuss.system.clock`), the clock of every pyuss
transport, so stations in other processes on the same machine (``bus://``) read the same time
base.

Stations: `Segment.attach` gives an in-process station (a `Transport`). Listen-only
stations (monitors) cannot send. With ``echo=True`` a station hears its own characters, as a
2-wire adapter does (raw: the station's transport does not remove them). The bus allows at
most 32 sending stations (B 1: one master, 31 slaves); listen-only ones are not limited. When
all 32 places are taken, a station that may be evicted (an anonymous raw TCP station, see
`pyuss.bus.serve`) gives its place to the new one if it has sent nothing since it attached
(the first attached of those goes first), else if it has sent nothing for `EVICT_IDLE`
seconds (the one silent longest goes first).

Bounds: a station has at most `MAX_QUEUE` characters waiting for or on the line; what it sends
beyond that is dropped and counted (`Station.overflow`, `BusStats.overflow`), so a station that
writes a megabyte neither grows the bus's memory nor holds the line for minutes. When a station
leaves, what it had not yet started to send is dropped (`BusStats.unsent`): a character
already on the wire ends, the rest never reaches the line. `Segment.queued` tells how many
characters wait.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import logging
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

from pyuss.bus.faults import FaultEngine, FaultPlan
from pyuss.bus.line import FRAMES, frame_bits, read_levels
from pyuss.bus.line import WireChar as WireChar  # also importable from here, its old place
from pyuss.bus.line import sample as sample
from pyuss.bus.wire import check_name
from pyuss.errors import ConfigError, TransportError
from pyuss.loop import FINE_MARGIN, fine_timers
from pyuss.system import clock
from pyuss.transport.base import LineError
from pyuss.transport.queued import QueuedTransport, char_time, check_baud, shift_errors

log = logging.getLogger(__name__)

#: Stations that may send on one segment (B 1: 1 master + 31 slaves).
MAX_SENDERS = 32
#: Characters one station may have waiting for or on the line; the rest of a write is dropped.
MAX_QUEUE = 4096
#: Seconds an evictable station that has sent something must have been silent to give its
#: place to a new station (one that has sent nothing gives it at once).
EVICT_IDLE = 1.0
#: Seconds a character that continues a run may wait to be handed over with the rest of it.
RUN_HOLD = 0.002
#: Characters at the end of a run handed over when it ends; the rest of the run comes before.
RUN_LEAD = 3
#: Characters a station that holds runs (``hold=True``) keeps at most before it is handed them.
HOLD_MAX = 256
_EPS = 1e-9

Sink = Callable[[bytes, float, tuple[tuple[int, LineError], ...]], None]


@dataclass(slots=True)
class BusStats:
    """What happened on the line."""

    chars: int = 0
    collisions: int = 0
    garbled: int = 0
    lost: int = 0
    overflow: int = 0
    """Characters dropped because their station's queue was full (`MAX_QUEUE`)."""
    unsent: int = 0
    """Characters dropped because their station left before they went on the line."""
    evicted: int = 0
    """Stations that gave their place to a new one (idle raw TCP stations on a full bus)."""
    faults: Counter[str] = field(default_factory=Counter)


@dataclass(order=True, slots=True)
class _Pending:
    start: float
    seq: int
    sender: str = field(compare=False)
    frame: int = field(compare=False)
    notes: tuple[str, ...] = field(compare=False, default=())
    owner: Station | None = field(compare=False, default=None)
    """The station whose queue the character counts in (None: injected)."""


class Station(QueuedTransport):
    """A station on a `Segment`, seen as a `Transport`. Made by `Segment.attach`."""

    def __init__(
        self,
        bus: Segment,
        name: str,
        *,
        echo: bool,
        listen_only: bool,
        sink: Sink | None = None,
        hold: bool = False,
    ) -> None:
        super().__init__(baud=bus.baud)
        self.bus = bus
        self.name = name
        self.hears_own = echo
        self.listen_only = listen_only
        self._sink = sink
        self.hold = hold
        """It takes a run's first character when it ends and the rest when the run ends."""
        self.held: list[tuple[bytes, float, tuple[tuple[int, LineError], ...]]] = []
        """What a holding station is handed when the run ends."""
        self.held_chars = 0
        self.hold_until = 0.0
        """A holding station's answer hold (`hold_answer`): until then (monotonic) it takes
        the first piece of a run with the rest, not at once."""
        self._release_at: asyncio.TimerHandle | None = None
        self.heard_end = -1.0
        """End of the last character it heard (a character starting then continues a run)."""
        self.tx_free = 0.0
        self.queued = 0
        """Characters of this station waiting for or on the line (at most `max_queue`)."""
        self.max_queue = MAX_QUEUE
        """Characters it may have waiting for or on the line; what it sends beyond is dropped
        (less for a pty, whose program the bus cannot see leave: `pyuss.bus.serve`)."""
        self.overflow = 0
        """Characters this station sent beyond `MAX_QUEUE`: dropped."""
        self.attached_at = clock()
        """When it attached (monotonic): it hears no character that ended before."""
        self.last_active = self.attached_at
        """When it attached or last sent something (monotonic)."""
        self.spoke = False
        """Whether it has sent something since it attached."""
        self.evict: Callable[[], None] | None = None
        """Set by whoever may take the station off the bus for a new one (raw TCP stations):
        detaches it and closes its connection."""

    def describe(self) -> str:
        return f"bus station {self.name!r}"

    @property
    def exact_timestamps(self) -> bool:
        return True  # the bus stamps every character with its end on the line

    async def open(self) -> None:
        if self.is_open:
            return
        if self.bus.stations.get(self.name) is not self:
            raise TransportError(f"{self.describe()} was detached from its bus")
        self._mark_open()

    async def close(self) -> None:
        self.bus.detach(self.name, self)
        self._mark_closed()

    async def write(self, data: bytes) -> None:
        self._check_writable()
        if self.listen_only:
            raise TransportError(f"{self.describe()} is listen-only: it cannot send")
        self.stats.bytes_out += len(data)
        self.bus.send(self.name, bytes(data))

    async def write_at(self, data: bytes, start: float, hold_until: float | None = None) -> None:
        """Like `write`, but the first character starts at ``start`` (monotonic seconds) if
        that is later: the station keeps a pause to the microsecond without waiting for it.
        ``hold_until`` is for stations in another process (`hold_answer`); a station in this
        one is handed every piece at once, as it costs no wake-up of a process."""
        self._check_writable()
        if self.listen_only:
            raise TransportError(f"{self.describe()} is listen-only: it cannot send")
        self.stats.bytes_out += len(data)
        self.bus.send(self.name, bytes(data), at=start)

    def hand(
        self,
        data: bytes,
        start: float,
        timestamp: float,
        errors: tuple[tuple[int, LineError], ...],
        run_ends: bool,
    ) -> None:
        """The bus hands over the characters ``data`` from ``start`` to ``timestamp``;
        ``run_ends``: no character follows them without a gap. A station that holds runs
        takes the first piece of a run at once and keeps the rest until the run ends."""
        if not self.hold:
            self.receive(data, timestamp, errors)
            return
        if len(data) > HOLD_MAX:  # a hand-over come late (a loaded machine): in pieces
            tc = (timestamp - start) / len(data)
            for i in range(0, len(data), HOLD_MAX):
                part = data[i : i + HOLD_MAX]
                end = start + (i + len(part)) * tc
                last = i + HOLD_MAX >= len(data)
                self.hand(
                    part,
                    end - len(part) * tc,
                    end,
                    shift_errors(errors, i, i + len(part)),
                    run_ends and last,
                )
            return
        continues = start <= self.heard_end + _EPS
        self.heard_end = timestamp
        if continues:
            if self.held_chars + len(data) > HOLD_MAX:
                self.release()
            self.held.append((data, timestamp, errors))
            self.held_chars += len(data)
            if run_ends:
                self.release()
            return
        self.release()
        if clock() < self.hold_until - _EPS and not run_ends:
            # the answer a master waits for: it would still take it at `hold_until`, so its
            # first piece waits for the rest (one wake-up of the master's process, not two),
            # or for that moment, whichever comes first
            self.held.append((data, timestamp, errors))
            self.held_chars = len(data)
            self._release_at = asyncio.get_running_loop().call_at(self.hold_until, self._hold_over)
            return
        self.hold_until = 0.0
        self.receive(data, timestamp, errors)

    def hold_answer(self, until: float) -> None:
        """A holding station waits for an answer that it still takes if its first character
        is handed over by ``until`` (monotonic seconds): the first run that begins before
        then is handed over whole when it ends - or what there is of it at ``until``, and
        the rest when it ends. Once for the next run; a master asks again with each request
        (the send frames of `pyuss.bus.wire`)."""
        if self.hold:
            self.hold_until = until

    def _hold_over(self) -> None:
        self._release_at = None
        self.hold_until = 0.0
        if self.bus.stations.get(self.name) is self:  # (a station that left hears nothing)
            self.release()

    def release(self) -> None:
        """Hand the characters held over, as one piece (they follow each other)."""
        if self._release_at is not None:
            self._release_at.cancel()
            self._release_at = None
            self.hold_until = 0.0
        held, self.held = self.held, []
        self.held_chars = 0
        if not held:
            return
        if len(held) == 1:
            self.receive(*held[0])
            return
        errors: list[tuple[int, LineError]] = []
        offset = 0
        for data, _stamp, flags in held:
            errors += [(offset + pos, flag) for pos, flag in flags]
            offset += len(data)
        self.receive(b"".join(data for data, _, _ in held), held[-1][1], tuple(errors))

    def receive(
        self, data: bytes, timestamp: float, errors: tuple[tuple[int, LineError], ...]
    ) -> None:
        """The bus hands over characters (a sink takes them, or they wait for `read`)."""
        if self._sink is not None:
            self.stats.bytes_in += len(data)
            self._sink(data, timestamp, errors)
        else:
            self._deliver(data, timestamp, errors)

    @property
    def listening(self) -> bool:
        return self._sink is not None or self.is_open


class Segment:
    """One RS-485 segment in software. See the module docstring; `pyuss.bus.faults` for the
    fault plan, `pyuss.bus.recorder` for recordings; `pyuss.bus.virtual.VirtualBus`, the
    segment that also serves stations in other processes (`pyuss.bus.serve`)."""

    def __init__(
        self,
        baud: int = 9600,
        *,
        faults: FaultPlan | None = None,
        seed: int = 0,
    ) -> None:
        self.baud = check_baud(baud)
        self.char_time = char_time(self.baud)
        self.bit_time = self.char_time / 11
        self.seed = seed
        self.epoch = clock()
        self.stations: dict[str, Station] = {}
        self._engine = FaultEngine(faults, seed)
        self.stats = BusStats(faults=self._engine.applied)
        self._heap: list[_Pending] = []
        self._seq = itertools.count()
        self._timer: asyncio.Handle | None = None
        self._early: float | None = None
        """How long before the hand-over that ends a run the bus wakes up and then yields until
        it is due (`pyuss.loop.FINE_MARGIN` on a loop with fine timers, 0 on others); set on
        first use, when the loop is known."""
        self._timer_at = 0.0
        self._last_garbled_end = -1.0
        self._last_end = -1.0
        """End of the last character resolved (a character starting then continues a run)."""
        self._on_line: list[_Pending] = []
        self._windows: list[tuple[str, str, float, float]] = []
        self.on_char: list[Callable[[WireChar], None]] = []
        self.closers: list[Callable[[], object]] = []

    # -- stations ---------------------------------------------------------------------------
    def attach(
        self,
        name: str,
        *,
        echo: bool = False,
        listen_only: bool = False,
        sink: Sink | None = None,
        hold: bool = False,
    ) -> Station:
        """Add a station named ``name``; open the returned transport to use it.

        ``sink`` (instead of reading the transport) takes each delivery at once: the bus
        uses it to pass characters on to ptys and sockets. ``hold``: the station takes the
        first character of a run when it ends and the rest of the run when the run ends (at
        most `HOLD_MAX` characters at a time), two hand-overs per telegram: a station in
        another process (``bus://``) is woken up that many times.
        """
        check_name(name)
        if name in self.stations:
            raise ConfigError(f"a station named {name!r} is already on the bus")
        senders = sum(1 for s in self.stations.values() if not s.listen_only)
        if not listen_only and senders >= MAX_SENDERS and not self._make_room():
            raise ConfigError(
                f"the bus has {MAX_SENDERS} sending stations already (B 1: 1 master, 31 slaves); "
                f"attach {name!r} listen-only or detach one"
            )
        station = Station(self, name, echo=echo, listen_only=listen_only, sink=sink, hold=hold)
        self.stations[name] = station
        return station

    def detach(self, name: str, station: Station | None = None) -> None:
        """Remove a station; no error if absent (nor if ``station`` is given and ``name`` is
        another one now). What it had not started to send is dropped (`BusStats.unsent`)."""
        current = self.stations.get(name)
        if current is None or (station is not None and current is not station):
            return
        del self.stations[name]
        if current.queued:
            now = clock()
            keep = [p for p in self._heap if p.owner is not current or p.start <= now]
            dropped = len(self._heap) - len(keep)
            if dropped:
                heapq.heapify(keep)
                self._heap[:] = keep
                current.queued -= dropped
                self.stats.unsent += dropped
                log.info("bus: station %s left: %d characters not sent", name, dropped)

    def queued(self, name: str | None = None) -> int:
        """Characters waiting for or on the line: of station ``name``, or of all."""
        if name is None:
            return len(self._heap)
        station = self.stations.get(name)
        return 0 if station is None else station.queued

    def _make_room(self) -> bool:
        """Evict an evictable sending station: of those that never sent anything the first
        attached, else the one silent longest (at least `EVICT_IDLE`)."""
        now = clock()
        idle = [
            s
            for s in self.stations.values()
            if s.evict is not None
            and not s.listen_only
            and (not s.spoke or now - s.last_active >= EVICT_IDLE)
        ]
        if not idle:
            return False
        victim = min(idle, key=lambda s: (s.spoke, s.last_active))
        log.warning(
            "bus: all %d sending places taken: station %s, silent for %.1f s, gives its place",
            MAX_SENDERS,
            victim.name,
            now - victim.last_active,
        )
        assert victim.evict is not None
        victim.evict()
        self.detach(victim.name, victim)
        self.stats.evicted += 1
        return True

    def make_deaf(self, name: str, duration: float, *, start: float | None = None) -> None:
        """From now on (or from monotonic time ``start``), ``name`` hears no character that
        ends in the next ``duration`` seconds (one that ends right then is still heard)."""
        self._add_window("deaf", name, duration, start)

    def make_dead(self, name: str, duration: float, *, start: float | None = None) -> None:
        """From now on (or from ``start``), ``name`` neither hears nor sends for ``duration``
        seconds."""
        self._add_window("dead", name, duration, start)

    def _add_window(self, kind: str, name: str, duration: float, start: float | None) -> None:
        if duration <= 0:
            raise ConfigError(f"{kind} duration must be > 0 seconds, not {duration!r}")
        now = clock()
        begin = now if start is None else start
        self._windows = [w for w in self._windows if w[3] > now]  # the past ones are done
        self._windows.append((kind, name, begin, begin + duration))

    def _deaf(self, name: str, end: float) -> bool:
        """Whether ``name`` misses a character that ends at ``end`` (deaf or dead then): one
        that ends as a window opens is still heard."""
        if any(n == name and a < end <= b for _, n, a, b in self._windows):
            return True
        return self._engine.deaf(name, end - self.epoch)

    def _dead(self, name: str, now: float) -> bool:
        if any(k == "dead" and n == name and a <= now < b for k, n, a, b in self._windows):
            return True
        return self._engine.dead(name, now - self.epoch)

    # -- sending ----------------------------------------------------------------------------
    def send(self, sender: str, data: bytes, at: float | None = None) -> None:
        """Put ``data`` from station ``sender`` on the line (see the module docstring); with
        ``at`` (monotonic seconds) not before then, as a UART with a timed transmit does."""
        station = self.stations.get(sender)
        if station is None:
            raise TransportError(f"no station {sender!r} on the bus")
        now = clock()
        station.last_active = now
        if not data:  # nothing for the line, and nothing the station's next characters wait for
            return
        station.spoke = True
        if self._dead(sender, now):
            self.stats.lost += len(data)
            return
        room = station.max_queue - station.queued
        if len(data) > room:
            over = len(data) - max(room, 0)
            log.log(
                logging.DEBUG if station.overflow else logging.WARNING,  # warned once
                "bus: station %s sends faster than the line carries: %d characters dropped "
                "(it may have %d waiting)",
                sender,
                over,
                station.max_queue,
            )
            station.overflow += over
            self.stats.overflow += over
            data = data[: max(room, 0)]
        tc = self.char_time
        t = station.tx_free
        begin = now if at is None or at <= now else at
        if t <= begin:
            t = begin + self._engine.answer_delay(sender, now - self.epoch)
        if self._engine.character_faults:
            t = self._put_faulted(station, data, t)
        else:  # the usual case: every character as sent
            for byte in data:
                self._put(sender, t, FRAMES[byte], (), station)
                t += tc
        station.tx_free = t
        self._schedule()

    def _put_faulted(self, station: Station, data: bytes, t: float) -> float:
        """Put ``data`` on the line from ``t`` as the fault plan has each character; returns
        when the last one ends."""
        tc = self.char_time
        sender = station.name
        for byte in data:
            plan = self._engine.character(sender, byte, t - self.epoch)
            t += plan.gap_before * tc
            notes = tuple(n for n in plan.notes if n != "insert")
            if not plan.drop:
                self._put(sender, t, plan.frame, notes, station)
            t += tc
            for extra in plan.insert_after:
                self._put(sender, t, frame_bits(extra), ("insert",), station)
                t += tc
        return t

    def inject(
        self, sender: str, start: float, byte: int, flags: LineError = LineError.NONE
    ) -> None:
        """Put one character on the line at monotonic time ``start`` as ``sender`` sent it,
        with ``flags`` made real in its frame (replaying a recording)."""
        frame = frame_bits(byte)
        if flags & LineError.PARITY:
            frame ^= 1 << 9
        if flags & LineError.FRAMING:
            frame &= ~(1 << 10)
        self._put(sender, start, frame, ())
        self._schedule()

    def _put(
        self,
        sender: str,
        start: float,
        frame: int,
        notes: tuple[str, ...],
        owner: Station | None = None,
    ) -> None:
        heapq.heappush(self._heap, _Pending(start, next(self._seq), sender, frame, notes, owner))
        if owner is not None:
            owner.queued += 1

    def _schedule(self) -> None:
        if not self._heap:
            return
        head = self._heap[0]
        due = head.start + self.char_time
        if head.owner is not None and head.start <= self._last_end + _EPS:
            # It continues a run: hand it over with the rest of the run, all but the last
            # `RUN_LEAD` characters a little before the end (a receiver digests them while
            # the last are on the line), those last ones when the run ends.
            end = head.owner.tx_free
            bulk = end - RUN_LEAD * self.char_time
            due = min(bulk if due < bulk - _EPS else end, due + RUN_HOLD)
        if self._timer is not None:
            if self._timer_at <= due:
                return
            self._timer.cancel()
        loop = asyncio.get_running_loop()
        if self._early is None:
            self._early = FINE_MARGIN if fine_timers(loop) else 0.0
        self._timer_at = due
        # Where a run ends a receiver reacts (a slave answers, the master sends the next
        # request): wake up a little early there, and only there.
        ends_run = head.owner is not None and due >= head.owner.tx_free - _EPS
        self._timer = loop.call_at(due - self._early if ends_run else due, self._tick)

    # -- the line ---------------------------------------------------------------------------
    def _tick(self) -> None:
        now = clock()
        if now < self._timer_at - _EPS:  # woke up early on purpose: yield until it is due
            self._timer = asyncio.get_running_loop().call_soon(self._tick)
            return
        self._timer = None
        tc = self.char_time
        out: list[WireChar] = []
        heap = self._heap
        while heap and heap[0].start + tc <= now + _EPS:
            first = heapq.heappop(heap)
            end = first.start + tc
            group = [first]
            while heap and heap[0].start < end - _EPS:
                group.append(heapq.heappop(heap))
            for pending in group:
                if pending.owner is not None:
                    pending.owner.queued -= 1
            out.append(self._resolve(group, end))
            if end > self._last_end:
                self._last_end = end
        for char in out:
            self._record(char)
        if out:
            self._hand_over(out)
        self._schedule()

    def _resolve(self, group: list[_Pending], end: float) -> WireChar:
        first = group[0]
        tc = self.char_time
        # Frames consumed by an earlier character may still drive the line during this one
        # (their tail): the receivers sample them too.
        self._on_line = [p for p in self._on_line if p.start + tc > first.start + _EPS]
        tails = self._on_line
        if not tails and len(group) == 1:  # alone on the line: its own levels, as sampled
            byte, flags = read_levels(first.frame & 0x7FF)
            self._on_line = group
            return WireChar(first.start, end, byte, flags, first.sender, first.notes)
        frames = [(p.start, p.frame) for p in (*tails, *group)]
        byte, flags = sample(frames, first.start, self.bit_time)
        notes = tuple(n for p in group for n in p.notes)
        senders = sorted({p.sender for p in (*tails, *group)})
        if len(senders) > 1:
            self.stats.garbled += 1
            if self._last_garbled_end < first.start - _EPS:
                self.stats.collisions += 1
            self._last_garbled_end = max(self._last_garbled_end, max(p.start for p in group) + tc)
            notes = (*notes, "collision")
        self._on_line += group
        return WireChar(first.start, end, byte, flags, "+".join(senders), notes)

    def _record(self, char: WireChar) -> None:
        self.stats.chars += 1
        for listener in self.on_char:
            listener(char)

    def _hand_over(self, chars: list[WireChar]) -> None:
        # A deaf (or dead) station misses the characters that end in its window: judged by
        # the line's time, not by when the bus hands them over.
        windows = bool(self._windows) or self._engine.windows
        heap = self._heap
        run_ends = not heap or heap[0].start > chars[-1].end + _EPS
        for station in list(self.stations.values()):
            if not station.listening:
                continue
            name = station.name
            buf = bytearray()
            errors: list[tuple[int, LineError]] = []
            first = last_end = 0.0
            for char in chars:
                if not station.hears_own and name in char.sender.split("+"):
                    continue
                if char.end <= station.attached_at:  # handed over late: it was not there yet
                    continue
                if windows and self._deaf(name, char.end):
                    continue
                if buf and char.start > last_end + _EPS:
                    station.hand(bytes(buf), first, last_end, tuple(errors), True)
                    buf.clear()
                    errors.clear()
                if not buf:
                    first = char.start
                if char.flags:
                    errors.append((len(buf), char.flags))
                buf.append(char.byte)
                last_end = char.end
            if buf:
                station.hand(bytes(buf), first, last_end, tuple(errors), run_ends)
            elif station.held and run_ends:
                station.release()

    @property
    def busy_until(self) -> float:
        """Monotonic time at which everything queued so far has left the line."""
        ends = [p.start + self.char_time for p in self._heap]
        return max(ends, default=clock())

    async def drain(self, timeout: float | None = None) -> None:
        """Wait until every queued character has been delivered."""
        deadline = None if timeout is None else clock() + timeout
        while self._heap:
            wait = max(0.001, self.busy_until - clock())
            if deadline is not None:
                if clock() >= deadline:
                    raise TimeoutError("the bus did not drain in time")
                wait = min(wait, max(0.001, deadline - clock()))
            await asyncio.sleep(wait)

    async def close(self) -> None:
        """Stop serving ptys and sockets and detach every station."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        closers, self.closers = self.closers, []
        for closer in reversed(closers):
            result = closer()
            if asyncio.iscoroutine(result):
                await result
        for station in list(self.stations.values()):
            await station.close()
