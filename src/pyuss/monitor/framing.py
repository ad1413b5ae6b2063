"""The monitor's framing: the frames of a line's ports, cut out of what they read and merged by
time. Sans-io, like `pyuss.monitor.Monitor`, which pairs the frames (`Framer`).

Framing
    Each port has a `pyuss.protocol.Receiver` whose start pause is the monitor's ``gap``: the
    idle time that starts a telegram, by default the spec's 2 character times (A 5.1.2), and
    whose ``tolerance`` is the monitor's: how late the port may stamp a byte. On the virtual
    bus timestamps are exact (tolerance 0). Real serial ports, ptys and TCP stamp bytes when
    they are read (USB adapters deliver every 1 to 16 ms): with the tolerance of such a port
    (`pyuss.transport.base.stamp_tolerance`, 20 ms, as the master) the receiver neither cuts
    a telegram at a late burst nor takes an answer read together with its request for bytes
    without a start pause ("Coarse timestamps" in `pyuss.protocol.receiver`). The tolerance,
    plus what the gap adds to the start pause, is the monitor's timing *resolution*: timing
    rules are only enforced beyond it. A run of bytes without a start pause that still holds
    whole telegrams (an answer that followed faster than the gap) is cut into those telegrams
    again; if the pause before one was shorter than the start pause less the resolution, it
    stays a fault (``no_stx``: a slave would discard it), but is still decoded. With a
    resolution (real ports), an incomplete telegram and the bytes after the pause that cut it
    are joined again when together they form a telegram with a valid BCC within its residual
    time (A 6.3) plus the resolution: the pause was the port's, not the line's.

Two ports (4-wire line)
    Port 0 carries master to slave, port 1 slave to master. Frames of both are merged by the
    time of their last byte: a frame is passed on only when no port can still produce an
    earlier one.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import replace

from pyuss.errors import ConfigError
from pyuss.monitor.model import Frame, ms, telegram_in
from pyuss.protocol.diagnostics import FaultKind
from pyuss.protocol.receiver import Event, Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import MAX_LGE, MIN_LGE, MIN_TELEGRAM_BYTES, STX, bcc
from pyuss.protocol.timing import LineTiming
from pyuss.transport.base import LineError

__all__ = ["Framer"]
_EPS = 1e-9


class _Held:
    """A frame waiting for the other port (4-wire), ordered by end time."""

    __slots__ = ("frame", "key")

    def __init__(self, frame: Frame, seq: int) -> None:
        self.frame = frame
        self.key = (frame.end, seq)

    def __lt__(self, other: _Held) -> bool:
        return self.key < other.key


_JOINABLE = (FaultKind.NO_STX, FaultKind.RESIDUAL_TIME, FaultKind.BAD_LGE, FaultKind.BCC)


def _incomplete(frame: Frame) -> bool:
    """An incomplete telegram without line errors: STX, a valid LGE, too few bytes."""
    raw = frame.raw
    return (
        frame.fault is FaultKind.RESIDUAL_TIME
        and len(raw) >= 2
        and raw[0] == STX
        and MIN_LGE <= raw[1] <= MAX_LGE
        and len(raw) < raw[1] + 2
    )


class Framer:
    """The frames of one line: one port, or two on a 4-wire line; see the module text.

    Made by `pyuss.monitor.Monitor` with its settings: ``gap`` and ``tolerance`` for the
    receivers, ``resolution`` and ``early_limit`` (`Monitor.early_limit`) for the cutting and
    joining of telegrams, ``fixed_lengths`` (ADR -> LGE) for the receivers.
    """

    def __init__(
        self,
        baud: int,
        timing: LineTiming,
        *,
        ports: int,
        gap: float,
        tolerance: float,
        resolution: float,
        early_limit: float,
        fixed_lengths: dict[int, int],
    ) -> None:
        self.timing = timing
        self.ports = ports
        self.resolution = resolution
        self.early_limit = early_limit
        self._rx = [
            Receiver(baud, start_pause=gap, fixed_lengths=fixed_lengths, tolerance=tolerance)
            for _ in range(ports)
        ]
        self._advanced = [-math.inf] * ports
        self._prev_end = [-math.inf] * ports
        self._held: list[_Held] = []
        self._partial: list[Frame | None] = [None] * ports
        self._seq = itertools.count()

    def times(self) -> list[float]:
        """The ends of the last bytes the ports read and the times `advance` was told."""
        return [*self._advanced, *(rx.last_byte_end for rx in self._rx)]

    def check_port(self, port: int) -> None:
        if port not in range(self.ports):
            raise ConfigError(f"port {port!r}: this monitor has {self.ports} port(s)")

    def feed(
        self, port: int, data: bytes, timestamp: float, errors: Iterable[tuple[int, LineError]]
    ) -> None:
        """Bytes port ``port`` read (`Monitor.feed`)."""
        self.check_port(port)
        self.take(port, self._rx[port].feed(data, timestamp, errors))

    def advance(self, now: float, port: int | None) -> None:
        """Everything a port (every port when None) received up to ``now`` has been fed."""
        for p in range(self.ports) if port is None else (port,):
            self.check_port(p)
            self.take(p, self._rx[p].poll(now))
            self._advanced[p] = max(self._advanced[p], now)

    def add_events(self, events: Sequence[Event], port: int) -> None:
        """Receiver events cut by a receiver of the caller's (`Monitor.add_events`)."""
        self.check_port(port)
        self.take(port, list(events))

    def finish(self) -> None:
        """The end of the input: every port's open telegram ends."""
        for p in range(self.ports):
            self.take(p, self._rx[p].poll(math.inf))
            self._advanced[p] = math.inf
            partial, self._partial[p] = self._partial[p], None
            if partial is not None:
                self._queue(p, partial)

    def take(self, port: int, events: Iterable[Event]) -> None:
        """Cut frames out of a port's receiver events and queue them."""
        for event in events:
            for frame in self._frames(port, event):
                self._push(port, frame)

    def _queue(self, port: int, frame: Frame) -> None:
        heapq.heappush(self._held, _Held(frame, next(self._seq)))
        self._prev_end[port] = frame.end

    def _push(self, port: int, frame: Frame) -> None:
        """Queue a frame; with a timing resolution (real ports), an incomplete telegram waits
        for the rest that a late burst cut off (see `_join`)."""
        partial = self._partial[port]
        if partial is not None:
            self._partial[port] = None
            if self._join(port, partial, frame):
                return
            self._queue(port, partial)
        if self.resolution > 0 and _incomplete(frame):
            self._partial[port] = frame
            return
        self._queue(port, frame)

    def _join_limit(self, partial: Frame) -> float:
        """Longest a telegram may take from the start of STX (A 6.3), plus the resolution."""
        return (
            self.timing.char_time + self.timing.residual_max(partial.raw[1] - 2) + self.resolution
        )

    def _join(self, port: int, partial: Frame, frame: Frame) -> bool:
        """Rejoin an incomplete telegram and the bytes after a pause that only the port's
        timestamps made: when together they form a telegram with a valid BCC within its
        residual time (A 6.3, plus the resolution), it is one telegram."""
        if frame.ok or frame.fault not in _JOINABLE:
            return False
        raw = partial.raw + frame.raw
        need = partial.raw[1] + 2
        limit = self._join_limit(partial)
        if len(raw) < need:
            if frame.end - partial.start > limit + _EPS:
                return False
            self._partial[port] = replace(partial, raw=raw, end=frame.end)
            return True
        piece = raw[:need]
        telegram = telegram_in(piece)
        if telegram is None or bcc(piece) != 0:
            return False
        taken = need - len(partial.raw)
        end = frame.end if taken == len(frame.raw) else frame.start + taken * self.timing.char_time
        if end - partial.start > limit + _EPS:
            return False
        self._queue(port, Frame(piece, partial.start, end, telegram=telegram, port=port))
        rest = raw[need:]
        if rest:
            fault = ReceiveFault(
                FaultKind.NO_STX, rest, end, frame.end, "characters without a start pause"
            )
            for piece_frame in self._salvage(port, fault):
                self._queue(port, piece_frame)
        return True

    def _frames(self, port: int, event: Event) -> list[Frame]:
        if isinstance(event, Received):
            return [Frame(event.raw, event.start, event.end, telegram=event.telegram, port=port)]
        assert isinstance(event, ReceiveFault)
        if event.kind is FaultKind.NO_STX:
            return self._salvage(port, event)
        if event.kind is FaultKind.RESIDUAL_TIME and self.resolution > 0:
            late = self._late_by_the_port(port, event)
            if late is not None:
                return late
        return [
            Frame(
                event.raw,
                event.start,
                event.end,
                fault=event.kind,
                detail=event.detail,
                telegram=telegram_in(event.raw),
                port=port,
            )
        ]

    def _late_by_the_port(self, port: int, event: ReceiveFault) -> list[Frame] | None:
        """A telegram the receiver found over its residual time, with the bytes after it: when
        it is whole with a valid BCC and complete within its residual time plus the resolution
        (its last byte came when the receiver saw it, `ReceiveFault.whole_at`; read back from a
        capture: no later than the run's end less the bytes after it), the lateness may be the
        port's timestamps; then it is a telegram and the rest is cut like bytes without a
        start (None otherwise)."""
        raw, ct = event.raw, self.timing.char_time
        if len(raw) < MIN_TELEGRAM_BYTES or raw[0] != STX or not MIN_LGE <= raw[1] <= MAX_LGE:
            return None
        need = raw[1] + 2
        piece = raw[:need]
        telegram = telegram_in(piece)
        if telegram is None or bcc(piece) != 0:
            return None
        rest = raw[need:]
        # When its last byte came, as the receiver saw it; from a capture (no such time) at
        # the latest: the bytes after it back to back up to the run's end.
        end = event.whole_at if event.whole_at is not None else event.end - len(rest) * ct
        first = Frame(piece, event.start, end, telegram=telegram, port=port)
        if end - event.start > self._join_limit(first) + _EPS:
            return None
        frames = [first]
        if rest:
            self._prev_end[port] = end
            tail = ReceiveFault(
                FaultKind.NO_STX, rest, end, event.end, "characters without a start pause"
            )
            frames += self._salvage(port, tail)
        return frames

    def _salvage(self, port: int, event: ReceiveFault) -> list[Frame]:
        """Cut whole telegrams out of a run of bytes without a valid start."""
        raw, ct = event.raw, self.timing.char_time
        frames: list[Frame] = []
        junk_from = 0
        prev_end = self._prev_end[port]
        i = 0

        def junk(upto: int) -> None:
            if upto > junk_from:
                piece = raw[junk_from:upto]
                start = event.start + junk_from * ct
                end = event.end if upto == len(raw) else start + len(piece) * ct
                detail = event.detail if junk_from == 0 else "characters without a start pause"
                frames.append(
                    Frame(piece, start, end, fault=FaultKind.NO_STX, detail=detail, port=port)
                )

        while i + MIN_TELEGRAM_BYTES <= len(raw):
            size = raw[i + 1] + 2
            piece = raw[i : i + size]
            telegram = telegram_in(piece) if raw[i] == STX else None
            if telegram is None or bcc(piece) != 0:
                i += 1
                continue
            junk(i)
            start = event.start + i * ct
            end = start + size * ct
            pause = start - (frames[-1].end if frames else prev_end)
            if pause >= self.early_limit - _EPS:
                frames.append(Frame(piece, start, end, telegram=telegram, port=port))
            else:
                detail = f"no start pause before this telegram ({ms(max(pause, 0.0))} idle)"
                frames.append(
                    Frame(
                        piece,
                        start,
                        end,
                        fault=FaultKind.NO_STX,
                        detail=detail,
                        telegram=telegram,
                        port=port,
                    )
                )
            i += size
            junk_from = i
        junk(len(raw))
        return frames

    def _watermark(self, port: int) -> float:
        rx = self._rx[port]
        mark = rx.last_byte_end if rx.busy else max(rx.last_byte_end, self._advanced[port])
        partial = self._partial[port]
        return mark if partial is None else min(mark, partial.end)

    def release(self) -> tuple[list[Frame], float | None]:
        """The frames no port can still precede, in time order, and the time up to which every
        port has been seen whole (None while a port is inside a frame, or an incomplete
        telegram waits for its rest)."""
        out: list[Frame] = []
        for port, partial in enumerate(self._partial):
            seen = max(self._rx[port].last_byte_end, self._advanced[port])
            if partial is not None and seen - partial.start > self._join_limit(partial):
                self._partial[port] = None
                self._queue(port, partial)
        limit = math.inf if self.ports == 1 else min(map(self._watermark, range(self.ports)))
        while self._held and self._held[0].frame.end <= limit + _EPS:
            out.append(heapq.heappop(self._held).frame)
        if any(rx.busy for rx in self._rx) or any(self._partial):
            return out, None
        now = min(self._watermark(p) for p in range(self.ports))
        if self._held:
            now = min(now, self._held[0].frame.start)
        return out, now
