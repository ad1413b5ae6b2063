"""The streaming receiver: timestamped bytes in, telegrams and classified faults out (A 5.2).

Feed it what the transport reads, chunk by chunk, with the time the last byte of the chunk was
complete; call `Receiver.poll` when time passes without bytes. It returns events:
`Received` for a good telegram and `ReceiveFault` for everything else, classified by
`FaultKind` as A 5.2.2 lists them.

Time model
    ``feed(data, timestamp)``: ``timestamp`` is the time the *last* byte of ``data`` was
    complete. The bytes before it are taken as sent back to back, one character time (11 bits,
    A 6.1) each, so byte ``i`` of ``n`` ended at ``timestamp - (n - 1 - i) * char_time``. A gap
    can therefore only lie before the first byte of a chunk. A transport must deliver timestamps
    that fit the line: a backend that hands over bytes faster than the baud rate allows makes
    them look back to back, and pauses before them look shorter (or absent).

Framing rules
    - A telegram starts only with an STX after a start pause: an idle gap of at least
      ``start_pause`` (default 2 character times, A 5.1.2, reading 2). Before the first byte the
      line counts as idle.
    - On STX the residual-time deadline is loaded for n = 252 net bytes, after LGE for the
      announced n: ``1.5 (n + 3)`` character times from the end of STX (A 5.2.1.2, A 6.3).
    - LGE outside 2..254 is `FaultKind.BAD_LGE`. With ``fixed_lengths`` (ADR address -> LGE,
      fixed-length operation, A 4.2.2, A 5.2) a normal or mirror telegram to a listed address
      whose LGE differs is `FaultKind.BAD_LGE` as well; other addresses, broadcasts and special
      telegrams are framed by their LGE.
    - Any idle gap of a start pause ends whatever is being received (reading 2): an incomplete
      telegram is `FaultKind.RESIDUAL_TIME` (it cannot complete any more), as is one that is
      not complete by its deadline.
    - A complete telegram (LGE + 2 bytes) is checked: a character flagged by the transport
      gives that line error's kind (`FaultKind.FRAMING` - a break counts as framing -,
      `FaultKind.PARITY`, `FaultKind.OVERRUN`, first flagged character wins), then a wrong BCC
      gives `FaultKind.BCC`, then undefined ADR bits give `FaultKind.BAD_ADR`; otherwise it is
      `Received`.
    - Bytes that start no telegram (not STX after a pause, anything after a complete telegram
      without a pause, the rest of a telegram after its fault) are collected into one fault
      per run of bytes: `FaultKind.NO_STX` when the run began without a valid start,
      otherwise the fault that ended the telegram. A run longer than 256 bytes is split.

Coarse timestamps (``tolerance``)
    Only the virtual bus stamps bytes with their time on the line. A serial port, a pty or a TCP
    link stamps them when the program reads them: USB adapters hand over bytes every 1 to 16 ms,
    so a stamp may come up to ``tolerance`` seconds late, and the bytes a read holds may have
    had pauses between them that the stamps cannot show. With ``tolerance`` > 0 the receiver
    judges the line by what the stamps can tell:

    - While a telegram or a run of bytes is open, a chunk that comes no more than ``tolerance``
      after the byte before it is taken as following it back to back: the gap was the port's,
      so it neither ends the telegram nor counts against its residual time (A 5.2.1.2). An
      open telegram or run ends only after an idle gap of ``max(start_pause, tolerance)``
      (`Receiver.gap`).
    - After a complete telegram, the next byte counts as after a start pause unless the stamps
      show an idle gap shorter than ``start_pause - tolerance``: an answer read together with
      the end of its request, or a pause of the line hidden inside one read, is not taken for
      bytes without a start pause.

    ``tolerance`` 0 (the default) keeps the rules above exactly; the master and the monitor
    pass `pyuss.transport.base.stamp_tolerance` of their transport.

Resynchronisation
    A pause the times fed cannot show may still have been a start pause: one the tolerance of
    coarse stamps bridged (above), or one the feeder took out as a writer's hold-up and names
    in ``feed(..., held=...)`` (the simulator's untimed line, `pyuss.slave.server.PacedLine`).
    An open telegram notes where an STX began a read after such a pause of at least
    ``start_pause``. Should the telegram fail (wrong LGE, BCC, ADR, line error, residual time,
    or cut short by an idle line), the bytes before the first noted STX are reported as a
    telegram cut short by that pause (`FaultKind.RESIDUAL_TIME`, or the line error in them),
    and the receiver starts again at that STX with the bytes after it, at the times they were
    fed: one stray character before a telegram costs the telegram nothing. A telegram that
    does not fail is never cut at such a mark, and nothing is resynchronised where no pause
    was (the receiver does not hunt for STX in what it has: A 5.1.2). A run of bytes without
    a start ends at a ``held`` pause as at one the times show.

Every byte fed ends up in the ``raw`` of exactly one event, in order, so a monitor can show
the whole line. Faults whose end is known (wrong BCC, undefined ADR, line errors in a complete
telegram) are reported with their last byte; faults whose extent is unknown (bad LGE, residual
time, bytes without a start) are reported once the line has been idle for a start pause, by
`Receiver.feed` (a pause before the next chunk) or by `Receiver.poll`. `Receiver.next_poll`
tells when polling can next produce something. Call ``poll(now)`` only after every chunk that
arrived up to ``now`` has been fed.

A `Diagnostics` object, if given, is updated for every event (`Diagnostics.record_received`,
`Diagnostics.record_fault`); the receiver does not know addresses, so it counts all good
telegrams on the line.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from pyuss.errors import ConfigError
from pyuss.protocol.diagnostics import Diagnostics, FaultKind
from pyuss.protocol.frozen import builder
from pyuss.protocol.line import LineError
from pyuss.protocol.telegram import (
    MAX_ADDRESS,
    MAX_LGE,
    MAX_NET_BYTES,
    MAX_TELEGRAM_BYTES,
    MIN_LGE,
    STX,
    AddressError,
    AddressMode,
    Telegram,
    bcc,
    parse_adr,
)
from pyuss.protocol.timing import LineTiming

__all__ = ["Event", "FaultKind", "ReceiveFault", "Received", "Receiver", "fixed_length_fault"]

_IDLE, _TELEGRAM, _JUNK = 0, 1, 2
_FIXED_MODES = (AddressMode.NORMAL.value, AddressMode.MIRROR.value)
_ADR_MODES = frozenset(mode.value for mode in AddressMode)
_LINE_FLAGS = {
    FaultKind.FRAMING: LineError.FRAMING,
    FaultKind.PARITY: LineError.PARITY,
    FaultKind.OVERRUN: LineError.OVERRUN,
}


@dataclass(frozen=True, slots=True)
class Received:
    """A telegram received without fault: ``start`` is the start of its STX, ``end`` the end of
    its BCC (seconds, in the time base of the timestamps fed)."""

    telegram: Telegram
    raw: bytes
    start: float
    end: float


@dataclass(frozen=True, slots=True)
class ReceiveFault:
    """Bytes discarded for ``kind``; ``detail`` says what was wrong in words.

    ``whole_at``: for `FaultKind.RESIDUAL_TIME`, when the last of the telegram's LGE + 2 bytes
    was complete, if they all came before the run ended (``raw`` then runs on past them);
    otherwise None. A reader whose timestamps are coarser than the line (a monitor on a USB
    adapter) tells from it how late the telegram really was.
    """

    kind: FaultKind
    raw: bytes
    start: float
    end: float
    detail: str
    whole_at: float | None = None


Event = Received | ReceiveFault

_received = builder(Received)
_telegram = builder(Telegram)
"""`Received` and `Telegram` of a telegram the receiver framed and checked (`builder`)."""


def fixed_length_fault(adr: int, lge: int, fixed: int | None) -> str | None:
    """Fixed-length operation (A 4.2.2, A 5.2): a normal or mirror telegram with ADR byte
    ``adr`` to an address whose fixed length is ``fixed`` (None: not fixed) must carry that
    LGE. The `FaultKind.BAD_LGE` detail when ``lge`` is another, else None."""
    if fixed is None or adr & 0xE0 not in _FIXED_MODES or lge == fixed:
        return None
    return f"LGE {lge}, but address {adr & 0x1F} uses the fixed length LGE {fixed}"


def _line_kind(flags: LineError) -> FaultKind:
    if flags & (LineError.FRAMING | LineError.BREAK):
        return FaultKind.FRAMING
    if flags & LineError.PARITY:
        return FaultKind.PARITY
    return FaultKind.OVERRUN


class Receiver:
    """Streaming USS receiver for one line (see the module text for the rules).

    ``baud`` sets the character time; ``start_pause`` (seconds) overrides the idle gap that
    starts a telegram (default 2 character times; a profile may demand more); ``tolerance``
    (seconds) is how much later than on the line the transport may stamp a byte (see "Coarse
    timestamps" in the module text; 0 for exact timestamps); ``fixed_lengths`` maps slave
    addresses to the LGE they use in fixed-length operation (the dict is copied to
    ``self.fixed_lengths`` and may be changed later); ``diagnostics`` is updated for every
    event.
    """

    def __init__(
        self,
        baud: float,
        *,
        fixed_lengths: Mapping[int, int] | None = None,
        start_pause: float | None = None,
        diagnostics: Diagnostics | None = None,
        residual_extra_chars: float = 0.0,
        tolerance: float = 0.0,
    ) -> None:
        self.timing = LineTiming(baud, residual_extra_chars=residual_extra_chars)
        self._ct = self.timing.char_time
        if start_pause is None:
            start_pause = self.timing.start_pause
        elif isinstance(start_pause, bool) or not isinstance(start_pause, int | float):
            raise ConfigError(f"start pause must be a number of seconds, got {start_pause!r}")
        elif not start_pause > 0:
            raise ConfigError(f"start pause must be positive, got {start_pause!r}")
        self.start_pause = float(start_pause)
        if isinstance(tolerance, bool) or not isinstance(tolerance, int | float):
            raise ConfigError(f"tolerance must be a number of seconds, got {tolerance!r}")
        if not 0 <= tolerance < math.inf:
            raise ConfigError(f"tolerance must be >= 0 seconds, got {tolerance!r}")
        self.tolerance = float(tolerance)
        self.gap = max(self.start_pause, self.tolerance)
        """The idle time that ends an open telegram or run of bytes."""
        self.fixed_lengths: dict[int, int] = {}
        for address, lge in (fixed_lengths or {}).items():
            if not isinstance(address, int) or not 0 <= address <= MAX_ADDRESS:
                raise ConfigError(f"fixed length given for address {address!r}, not 0..31")
            if not isinstance(lge, int) or not MIN_LGE <= lge <= MAX_LGE:
                raise ConfigError(
                    f"fixed length (LGE) for address {address} must be {MIN_LGE}..{MAX_LGE}, "
                    f"got {lge!r}"
                )
            self.fixed_lengths[address] = lge
        self.diagnostics = diagnostics
        self._eps = self._ct * 1e-3
        # After a complete telegram: the shortest idle gap the stamps must show for the next
        # byte to count as after a start pause (a start pause less what the stamps may hide).
        self._fresh_after = self.start_pause - self.tolerance
        self._first_deadline = self.timing.residual_max(MAX_NET_BYTES)
        self._residual: dict[int, float] = {}
        """`LineTiming.residual_max` by net byte count, as LGEs come (computed once each)."""
        self.last_byte_end = -math.inf
        """When the last byte fed was complete (``-inf`` before the first byte)."""
        self._state = _IDLE
        self.busy = False
        """True while a telegram or a run of bytes is open (not yet reported): kept with the
        state, a plain attribute (the master asks several times per exchange)."""
        self._buf = bytearray()
        self._start = 0.0
        self._stx_end = 0.0
        self._need = 0
        self._deadline = 0.0
        self._adr_checked = False
        self._line: FaultKind | None = None
        self._line_pos = 0
        self._junk_kind = FaultKind.NO_STX
        self._junk_detail = ""
        self._late_need = 0
        self._whole_at: float | None = None
        self._marks: list[tuple[int, float]] = []
        """Where a hidden pause lies in the open telegram: (buffer position of an STX that
        began a read after a pause the times do not show, the held time); see `feed`."""
        self._times: list[float] = []
        """End times of the open telegram's bytes from the first mark on (empty without one)."""

    # -- public ----------------------------------------------------------------------------

    @property
    def receiving(self) -> bool:
        """True while a telegram is open (a run of bytes without a start is not one)."""
        return self._state == _TELEGRAM

    def line_idle(self, now: float) -> bool:
        """True when no byte was received for at least `gap` (the start pause, or the
        tolerance of coarse timestamps if longer) before ``now``."""
        return now - self.last_byte_end >= self.gap - self._eps

    def next_poll(self) -> float | None:
        """The time from which `poll` reports the open run if no byte arrives; None when idle."""
        if self._state == _IDLE:
            return None
        return self.last_byte_end + self.gap

    def reset(self) -> None:
        """Drop whatever is being received, without an event; the line counts as idle."""
        if self._state != _IDLE:
            self._state = _IDLE
            self.busy = False
            self._buf = bytearray()  # (when idle, the next byte begins a buffer of its own)
        self._marks = []
        self._times = []
        self.last_byte_end = -math.inf

    def feed(
        self,
        data: bytes | bytearray | memoryview,
        timestamp: float,
        errors: Iterable[tuple[int, LineError]] = (),
        *,
        held: float = 0.0,
    ) -> list[Event]:
        """Process one chunk; ``timestamp`` is when its last byte was complete and ``errors``
        lists ``(position, LineError)`` for characters the transport flagged.

        ``held``: the idle time before the chunk that the feeder took out as a writer's
        hold-up (the times fed show the chunk back to back with the byte before; the server's
        untimed line, `pyuss.slave.server.PacedLine`). Such a pause, or one the tolerance of
        coarse stamps bridges, may have been a real start pause: see "Resynchronisation" in
        the module text."""
        data = bytes(data)
        n = len(data)
        events: list[Event] = []
        if n == 0:
            return events
        ct = self._ct
        first_end = timestamp - (n - 1) * ct
        idle = (first_end - ct) - self.last_byte_end
        if idle < 0:
            # More bytes than the line carries in the time since the last one (a program that
            # read late, a backend without timing): they follow back to back, never overlap.
            first_end -= idle
            idle = 0.0
        # When byte 0 of this read ended, as the open telegram (if any) takes it.
        base = first_end
        if self._state == _TELEGRAM:
            if self.tolerance and idle <= self.tolerance + self._eps:
                # The port's stamps, not the line: the open telegram goes on back to back.
                base = first_end - idle
                held = max(held, idle)
            elif idle >= self.gap - self._eps:
                self._end_run(events)
            if (
                self._state == _TELEGRAM
                and held >= self.start_pause - self._eps
                and data[0] == STX
                and not any(pos == 0 and flag for pos, flag in errors)
            ):
                # A pause that may have been a start pause: should the open telegram fail,
                # this STX may begin the next one.
                self._marks.append((len(self._buf), held))
        elif self._state == _JUNK and (
            idle >= self.gap - self._eps
            or held >= self.start_pause - self._eps
            or (
                self.tolerance
                and data[0] == STX
                and idle >= self._fresh_after - self._eps
                and not any(pos == 0 and flag for pos, flag in errors)
            )
        ):
            # An idle line ends a run of bytes; on coarse stamps so does an STX that may
            # have come after a start pause (the next telegram after a damaged one).
            self._end_run(events)
        flags: dict[int, FaultKind] = {}
        for pos, flag in errors:
            if flag and 0 <= pos < n:
                flags[pos] = _line_kind(LineError(flag))
        pos = 0
        while pos < n:
            if self._state == _TELEGRAM:
                pos = self._telegram(data, pos, base, flags, events)
            elif self._state == _JUNK:
                take = min(n - pos, MAX_TELEGRAM_BYTES - len(self._buf))
                had = len(self._buf)
                if had < self._late_need <= had + take:  # a late telegram's last byte
                    self._whole_at = base + (pos + self._late_need - had - 1) * ct
                self._buf += data[pos : pos + take]
                pos += take
                self.last_byte_end = base + (pos - 1) * ct
                if len(self._buf) >= MAX_TELEGRAM_BYTES:
                    self._end_run(events)
            else:
                # A new telegram or run: from here on the read's own times. After a complete
                # telegram a byte counts as after a start pause unless the stamps show less
                # idle time than a start pause less the tolerance.
                base = first_end
                end = base + pos * ct
                fresh = (end - ct) - self.last_byte_end >= self._fresh_after - self._eps or (
                    pos == 0 and held >= self.start_pause - self._eps
                )
                self._begin(data[pos], end, flags.get(pos), fresh)
                pos += 1
        self.last_byte_end = base + (n - 1) * ct
        return events

    def poll(self, now: float) -> list[Event]:
        """Report what time alone decides: an open run once the line has been idle for a start
        pause, and the residual-time deadline of an incomplete telegram."""
        events: list[Event] = []
        if self._state == _IDLE:
            return events
        if self.line_idle(now):
            self._end_run(events)
        elif self._state == _TELEGRAM and now > self._deadline + self._eps:
            self._to_junk(FaultKind.RESIDUAL_TIME, self._late_detail(), events)
        return events

    # -- internals -------------------------------------------------------------------------

    def _begin(self, byte: int, end: float, line: FaultKind | None, fresh: bool) -> None:
        """Start a telegram or a run of bytes with ``byte``, which was complete at ``end``."""
        self._buf = bytearray((byte,))
        self._start = end - self._ct
        self.last_byte_end = end
        if fresh and byte == STX and line is None:
            self._state = _TELEGRAM
            self.busy = True
            if self._marks:
                self._marks = []
                self._times = []
            self._stx_end = end
            self._deadline = end + self._first_deadline
            self._need = 0
            self._adr_checked = False
            self._line = None
            return
        self._state = _JUNK
        self.busy = True
        self._late_need = 0
        if line is not None:
            self._junk_kind = line
            self._junk_detail = f"{line.name.lower()} error on the first character"
        elif fresh:
            self._junk_kind = FaultKind.NO_STX
            self._junk_detail = f"first character after the start pause is {byte:02X}h, not STX"
        else:
            self._junk_kind = FaultKind.NO_STX
            self._junk_detail = "characters without a start pause before them"

    def _telegram(
        self,
        data: bytes,
        pos: int,
        first_end: float,
        flags: dict[int, FaultKind],
        events: list[Event],
    ) -> int:
        """Take the bytes of the open telegram from ``data[pos:]``; return the next position."""
        ct = self._ct
        buf = self._buf
        want = (self._need or 2) - len(buf)
        take = min(want, len(data) - pos)
        last = pos + take - 1
        if first_end + last * ct > self._deadline + self._eps:
            # Keep the bytes that arrived in time; the telegram failed at its deadline.
            in_time = math.floor((self._deadline + self._eps - first_end) / ct) - pos + 1
            take = max(0, min(take, in_time))
            buf += data[pos : pos + take]
            if self._marks:
                self._times.extend(first_end + i * ct for i in range(pos, pos + take))
            if flags:
                self._note_line_errors(flags, pos, take, len(buf) - take)
            if take:
                self.last_byte_end = first_end + (pos + take - 1) * ct
            self._to_junk(FaultKind.RESIDUAL_TIME, self._late_detail(), events)
            return pos + take
        buf += data[pos : pos + take]
        if self._marks:
            self._times.extend(first_end + i * ct for i in range(pos, pos + take))
        if flags:
            self._note_line_errors(flags, pos, take, len(buf) - take)
        self.last_byte_end = first_end + last * ct
        pos += take
        if self._need == 0:
            lge = buf[1]
            if self._line is not None and self._line_pos == 1:
                self._to_junk(self._line, f"{self._line.name.lower()} error on LGE", events)
            elif not MIN_LGE <= lge <= MAX_LGE:
                why = f"LGE {lge} is out of range {MIN_LGE}..{MAX_LGE}"
                self._to_junk(FaultKind.BAD_LGE, why, events)
            else:
                self._need = lge + 2
                residual = self._residual.get(lge)
                if residual is None:
                    residual = self._residual[lge] = self.timing.residual_max(lge - 2)
                self._deadline = self._stx_end + residual
            return pos
        if not self._adr_checked and len(buf) >= 3:
            self._adr_checked = True
            adr = buf[2]
            detail = fixed_length_fault(adr, buf[1], self.fixed_lengths.get(adr & 0x1F))
            if detail is not None:
                self._to_junk(FaultKind.BAD_LGE, detail, events)
                return pos
        if len(buf) == self._need:
            self._complete(events)
        return pos

    def _note_line_errors(
        self, flags: dict[int, FaultKind], pos: int, take: int, offset: int
    ) -> None:
        if self._line is not None or not flags:
            return
        for i in range(pos, pos + take):
            kind = flags.get(i)
            if kind is not None:
                self._line = kind
                self._line_pos = offset + i - pos
                return

    def _line_detail(self) -> str:
        kind = self._line.name.lower() if self._line is not None else "line"
        return f"{kind} error at byte {self._line_pos} (STX = 0)"

    def _late_detail(self) -> str:
        need = self._need or "?"
        ms = (self._deadline - self._stx_end) * 1000
        return (
            f"telegram not complete within its residual time ({ms:.3f} ms after STX): "
            f"{len(self._buf)} of {need} bytes"
        )

    def _to_junk(self, kind: FaultKind, detail: str, events: list[Event]) -> None:
        if self._resync(events):
            return
        if self._line is not None and kind != self._line:
            kind = self._line
            detail = f"{self._line_detail()}; {detail}"
        self._state = _JUNK
        self.busy = True
        # a telegram over its residual time: note when its last byte comes, if it does
        self._late_need = self._need if kind is FaultKind.RESIDUAL_TIME else 0
        self._whole_at = None
        self._junk_kind = kind
        self._junk_detail = detail

    def _complete(self, events: list[Event]) -> None:
        raw = bytes(self._buf)
        if self._marks and self._failed(raw) and self._resync(events):
            return
        self._state = _IDLE
        self.busy = False
        self._buf = bytearray()
        if self._marks:
            self._marks = []
            self._times = []
        start, end = self._start, self.last_byte_end
        if self._line is not None:
            kind = self._line
            self._emit_fault(events, kind, raw, self._line_detail())
            return
        if bcc(raw):  # the BCC of a whole telegram, its own included, is 0 when it is right
            expected = bcc(raw[:-1])
            detail = f"BCC is {raw[-1]:02X}h, expected {expected:02X}h"
            self._emit_fault(events, FaultKind.BCC, raw, detail)
            return
        try:
            address, mode = parse_adr(raw[2])
        except AddressError as exc:
            self._emit_fault(events, FaultKind.BAD_ADR, raw, str(exc))
            return
        events.append(_received(_telegram(address, mode, raw[3:-1]), raw, start, end))
        if self.diagnostics is not None:
            self.diagnostics.record_received(end)

    def _end_run(self, events: list[Event]) -> None:
        """The open run is over (idle line or size limit): report it."""
        if self._state == _TELEGRAM and self._resync(events):
            if self._state != _IDLE:
                self._end_run(events)  # what follows the hidden pause is over as well
            return
        raw = bytes(self._buf)
        if self._state == _TELEGRAM:
            kind = self._line if self._line is not None else FaultKind.RESIDUAL_TIME
            need = self._need or "?"
            detail = f"telegram incomplete when the line fell idle: {len(raw)} of {need} bytes"
            if self._line is not None:
                detail = f"{self._line_detail()}; {detail}"
        else:
            kind, detail = self._junk_kind, self._junk_detail
        whole_at = self._whole_at if self._state == _JUNK and self._late_need else None
        self._state = _IDLE
        self.busy = False
        self._buf = bytearray()
        self._late_need = 0
        self._emit_fault(events, kind, raw, detail, whole_at)

    def _failed(self, raw: bytes) -> bool:
        """Whether the complete telegram ``raw`` is a fault (line error, BCC, ADR)."""
        return self._line is not None or bcc(raw) != 0 or raw[2] & 0xE0 not in _ADR_MODES

    def _resync(self, events: list[Event]) -> bool:
        """The open telegram has failed: if an STX in it began a read after a pause the times
        could not show (`feed`'s ``held``, or the tolerance of coarse stamps), the bytes before
        it are reported as a telegram cut short by that pause, and the receiver starts again at
        that STX, with the bytes after it as they came. False (nothing done) without one."""
        buf = bytes(self._buf)
        marks = [mark for mark in self._marks if mark[0] < len(buf)]  # bytes taken after it
        times, self._times = self._times, []
        self._marks = []
        if not marks:
            return False
        first = marks[0][0]
        times = times[len(times) - (len(buf) - first) :]
        head, tail = buf[:first], buf[first:]
        tail_times = times[: len(tail)]
        line_pos = self._line_pos - first if self._line is not None else -1
        line_kind = self._line
        ct = self._ct
        self.last_byte_end = tail_times[0] - ct
        if line_kind is not None and line_pos < 0:
            kind = line_kind
            detail = f"{self._line_detail()}; telegram cut short by a pause"
        else:
            kind = FaultKind.RESIDUAL_TIME
            need = self._need or "?"
            detail = f"telegram incomplete when a pause came: {len(head)} of {need} bytes"
        self._state = _IDLE
        self.busy = False
        self._buf = bytearray()
        self._line = None
        self._emit_fault(events, kind, head, detail)
        # The bytes from the STX on, again: the first after a start pause, the later marks
        # with their pauses, each byte at its own time.
        later = {pos - first: pause for pos, pause in marks[1:]}
        self.last_byte_end = tail_times[0] - ct - self.gap
        for i, byte in enumerate(tail):
            errors = ((0, _LINE_FLAGS[line_kind]),) if i == line_pos and line_kind else ()
            events += self.feed(bytes((byte,)), tail_times[i], errors, held=later.get(i, 0.0))
        return True

    def _emit_fault(
        self,
        events: list[Event],
        kind: FaultKind,
        raw: bytes,
        detail: str,
        whole_at: float | None = None,
    ) -> None:
        end = self.last_byte_end
        events.append(ReceiveFault(kind, raw, self._start, end, detail, whole_at))
        if self.diagnostics is not None:
            self.diagnostics.record_fault(kind, end)
