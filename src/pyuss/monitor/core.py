"""The sans-io monitor: timestamped bytes (or frames) in, decoded exchanges out.

`Monitor` never sends and never reads a clock: it is fed what the ports read, with the times
the transports stamped, and is told when time passes (`Monitor.advance`).

Framing and two ports (4-wire line)
    `pyuss.monitor.framing` cuts the frames out of what each port read, with the monitor's
    ``gap`` and ``tolerance`` (its timing *resolution*), and merges the two ports of a 4-wire
    line by time: port 0 carries master to slave, port 1 slave to master.

Pairing (A 5.1, A 5.2.1.1)
    A request to an address is answered by the telegram that starts within the response delay
    limit (20 ms, at least a start pause; plus the resolution) after the request's last byte.
    On a 4-wire line the port says what is a request and what an answer. On a 2-wire line the
    monitor goes by timing and position: a telegram with no request open is a request, one
    that starts within the limit after a request is its answer. When that rule is stretched
    the exchange says so in ``unsure``: an answer from another address (or a damaged request
    that was answered), and a late answer: a telegram to the same address after the limit
    (but within ``late_limit``) that looks like an answer (its PZD1 was seen as a status word
    of that address before, or its PKW answers the request's job, C Table 4.3) rather than the
    master repeating itself. A request whose late limit passes without an answer is reported
    as not answered. Broadcasts expect no answer (A 3); an answer to one, or to nothing, is
    ``unexpected``. A damaged request expects none either (A 5.2.2). Bytes without a telegram
    within the response delay limit are the damaged answer unless a telegram that answers
    the request follows (a driver switching on can put a stray character before the answer):
    then they are noise after the exchange.

Counters (A 5.2.3)
    `Monitor.summary` keeps the 16 diagnostic counters for the line and for each address,
    with the monitor's own counts and response times (`pyuss.monitor.stats`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import replace

from pyuss.errors import ConfigError
from pyuss.monitor.decode import decode, job_notes, learn, unpack
from pyuss.monitor.framing import Framer
from pyuss.monitor.infer import LayoutBook, LayoutChoice
from pyuss.monitor.model import (
    Direction,
    Exchange,
    Frame,
    Issue,
    LayoutSource,
    Problem,
    ms,
    problem_of,
)
from pyuss.monitor.stats import Summary
from pyuss.protocol.diagnostics import FaultKind
from pyuss.protocol.receiver import Event, fixed_length_fault
from pyuss.protocol.telegram import AddressMode
from pyuss.protocol.timing import MAX_RESPONSE_DELAY, LineTiming, check_baud
from pyuss.transport.base import LineError

__all__ = ["Monitor", "default_gap"]
_LATE_FACTOR = 10
_ROUNDING = 1e-8
_HISTORY = 64
_EPS = 1e-9
_STAMP_ROUNDING = 1e-6
"""Times in captures are rounded to 1 us: a delay closer to 0 than that is 0."""


def default_gap(baud: int) -> float:
    """The idle gap that starts a telegram: the start pause (A 5.1.2)."""
    return LineTiming(check_baud(baud)).start_pause


class Monitor:
    """Passive USS monitor for one line; see the module text.

    ``baud``: one of the rates of B 2.4. ``four_wire``: two ports, 0 master to slave and 1
    slave to master. ``layouts``: the given layouts (others are inferred). ``gap``: the idle
    time that starts a telegram (default: the start pause). ``response_limit``: the response
    delay limit (default 20 ms, never less than the start pause, A 5.2.1.1). ``late_limit``:
    how long after a request an answer is still taken as late rather than the request as not
    answered (default 10 x the response limit). ``tolerance``: how much later than on the line
    the ports may stamp a byte (0: exact timestamps, the virtual bus; ports that stamp bytes
    when read: `pyuss.transport.base.stamp_tolerance`).
    """

    def __init__(
        self,
        baud: int,
        *,
        four_wire: bool = False,
        layouts: LayoutBook | None = None,
        gap: float | None = None,
        response_limit: float | None = None,
        late_limit: float | None = None,
        tolerance: float = 0.0,
    ) -> None:
        self.baud = check_baud(baud)
        self.timing = LineTiming(self.baud)
        start_pause = self.timing.start_pause
        for name, value in (("gap", gap), ("response limit", response_limit)):
            if value is not None and (isinstance(value, bool) or not value > 0):
                raise ConfigError(f"{name} must be a positive number of seconds, got {value!r}")
        self.gap = start_pause if gap is None else float(gap)
        if start_pause - _ROUNDING <= self.gap < start_pause:
            self.gap = start_pause  # a start pause written to a file with fewer digits
        if self.gap < start_pause:
            raise ConfigError(
                f"gap {ms(self.gap)} is shorter than the start pause {ms(start_pause)} at "
                f"{self.baud} baud (A 5.1.2): characters inside telegrams would start new ones"
            )
        if isinstance(tolerance, bool) or not 0 <= tolerance < math.inf:
            raise ConfigError(f"tolerance must be >= 0 seconds, got {tolerance!r}")
        self.tolerance = float(tolerance)
        self.resolution = self.gap - start_pause + self.tolerance
        limit = MAX_RESPONSE_DELAY if response_limit is None else float(response_limit)
        self.response_limit = max(limit, start_pause)
        if late_limit is not None and not late_limit >= self.response_limit:
            raise ConfigError(
                f"late limit must be at least the response limit ({ms(self.response_limit)})"
            )
        self.late_limit = _LATE_FACTOR * self.response_limit if late_limit is None else late_limit
        self.layouts = layouts if layouts is not None else LayoutBook()
        self.four_wire = four_wire
        self.ports = 2 if four_wire else 1
        self._framer = Framer(
            self.baud,
            self.timing,
            ports=self.ports,
            gap=self.gap,
            tolerance=self.tolerance,
            resolution=self.resolution,
            early_limit=self.early_limit,
            fixed_lengths=self.layouts.fixed_lengths(),
        )
        self._count = itertools.count(1)
        self._pending: Frame | None = None
        self._tail: list[Frame] = []
        self._suspects: list[Frame] = []
        self._last: Frame | None = None
        self._broadcast: Frame | None = None
        self._control: dict[int, int] = {}
        self._status: dict[int, int] = {}
        self._seen_control: dict[int, set[int]] = {}
        self._seen_status: dict[int, set[int]] = {}
        self.summary = Summary()

    # -- timing ----------------------------------------------------------------------------

    @property
    def now(self) -> float | None:
        """The latest time the monitor knows of: the end of the last byte or frame, or a later
        time `advance` was told (None before anything came). The summary's per-minute rates
        are taken up to it, so they fall when the line goes quiet."""
        times = self._framer.times()
        if self.summary.last is not None:
            times.append(self.summary.last)
        known = [t for t in times if math.isfinite(t)]
        return max(known) if known else None

    @property
    def answer_window(self) -> float:
        """An answer that starts this long after the request's end is in time."""
        return self.response_limit + self.resolution

    @property
    def early_limit(self) -> float:
        """An answer that starts sooner than this after the request came without the start
        pause (A 5.2.1.1: the response delay is never less than the start pause)."""
        return self.timing.start_pause - self.resolution

    def response_delay(self, request: Frame, answer: Frame) -> tuple[float | None, str]:
        """The response delay from the request's last byte to the answer's first (A 5.2.1.1),
        as the stamps tell it, or None with the reason when they cannot tell it:

        - on a port that stamps bytes when they are read (a resolution above 0), an answer
          whose first byte the receiver laid right after the request's last (the port
          delivered them in one read, or more bytes than the line carried since the last read)
          hides the pause between them;
        - an answer that seems to start before the request ended (the two ports of a 4-wire
          line stamp their bytes apart) has no delay to show.

        The rounding of capture files (1 us) is no pause and no overlap."""
        delay = answer.start - request.end
        if delay < -_STAMP_ROUNDING:
            return None, (
                f"delay unknown: the answer's stamps put its start {ms(-delay)} before the end "
                "of the request (each port stamps its bytes when they are read)"
            )
        if self.resolution > 0 and delay < _STAMP_ROUNDING:
            return None, (
                "delay unknown: the port delivered the answer together with the end of the "
                f"request, so its stamps hide the pause between them (resolution "
                f"{ms(self.resolution)})"
            )
        return max(delay, 0.0), ""

    # -- input -----------------------------------------------------------------------------

    def feed(
        self,
        data: bytes,
        timestamp: float,
        errors: Iterable[tuple[int, LineError]] = (),
        *,
        port: int = 0,
    ) -> list[Exchange]:
        """Bytes a port read; ``timestamp`` is when the last one was complete (see
        `pyuss.protocol.Receiver.feed`). Returns the exchanges that are complete now."""
        self._framer.feed(port, data, timestamp, errors)
        return self._release()

    def advance(self, now: float, *, port: int | None = None) -> list[Exchange]:
        """Everything a port (every port when None) received up to ``now`` has been fed."""
        self._framer.advance(now, port)
        return self._release()

    def add_events(self, events: Sequence[Event], *, port: int = 0) -> list[Exchange]:
        """Receiver events cut by a receiver of the caller's (the monitor's own receiver for
        ``port`` is bypassed)."""
        self._framer.add_events(events, port)
        return self._release()

    def add_frame(self, frame: Frame, layout: LayoutChoice | None = None) -> list[Exchange]:
        """A frame read back from a capture (frames must come in time order). Its direction is
        used unless it was guessed; a ``layout`` that was given when the capture was made becomes
        the address's given layout, unless this monitor was given one."""
        address = frame.address
        given = layout is not None and layout.source is LayoutSource.GIVEN
        if given and address is not None and self.layouts.given(address) is None:
            assert layout is not None
            self.layouts.per_address[address] = layout.layout
        if frame.guessed:
            frame = replace(frame, direction=Direction.UNKNOWN, guessed=False)
        frame = self._check_fixed_length(frame)
        out = self._on_frame(frame)
        out += self._expire(frame.end)
        return out

    def _check_fixed_length(self, frame: Frame) -> Frame:
        """A telegram read back from a capture, judged like the receiver judges live bytes: a
        normal or mirror telegram whose LGE is not the fixed length given for its address is
        `FaultKind.BAD_LGE` (A 4.2.2, A 5.2)."""
        tg = frame.telegram
        if frame.fault is not None or tg is None:
            return frame
        layout = self.layouts.given(tg.address)
        fixed = None if layout is None else layout.lge
        detail = fixed_length_fault(frame.raw[2], frame.raw[1], fixed)
        if detail is None:
            return frame
        return replace(frame, fault=FaultKind.BAD_LGE, detail=detail)

    def finish(self) -> list[Exchange]:
        """The end of the input: report whatever is still open."""
        self._framer.finish()
        out = self._release()
        out += self._expire(math.inf)
        return out

    def _release(self) -> list[Exchange]:
        """Pair the frames the framer lets go, then expire what waited too long."""
        frames, now = self._framer.release()
        out: list[Exchange] = []
        for frame in frames:
            out += self._on_frame(frame)
        if now is not None:
            out += self._expire(now)
        return out

    # -- pairing ---------------------------------------------------------------------------

    def _expire(self, now: float) -> list[Exchange]:
        p = self._pending
        if p is None:
            return []
        if self._suspects and now - p.end > self.answer_window + _EPS:
            return self._pair_suspect(p)
        window = self.late_limit if p.ok else self.answer_window
        if now - p.end > window + _EPS:
            return self._unanswered(p)
        return []

    def _on_frame(self, frame: Frame) -> list[Exchange]:
        out = self._expire(frame.start)
        if frame.direction is Direction.UNKNOWN and self.four_wire:
            side = Direction.REQUEST if frame.port == 0 else Direction.RESPONSE
            frame = replace(frame, direction=side)
        last = self._last
        if (
            frame.telegram is None
            and last is not None
            and last.port == frame.port
            and frame.start - last.end < self.early_limit - _EPS
        ):
            # Bytes that follow a frame without a start pause: the same sender's tail.
            return out + self._noise(replace(frame, direction=last.direction, guessed=last.guessed))
        if self._suspects:
            held = self._settle(frame)
            if held is None:
                return out
            out += held
        if frame.direction is Direction.RESPONSE:
            return out + self._on_answer(frame)
        if frame.direction is Direction.REQUEST:
            return out + self._on_request(frame)
        return out + self._on_two_wire(frame)

    def _noise(self, frame: Frame) -> list[Exchange]:
        """Bytes that form no telegram and answer nothing: after the open request, if any."""
        self._last = frame
        if self._pending is not None:
            self._tail.append(frame)
            return []
        return [self._build(frame, None)]

    def _on_two_wire(self, frame: Frame) -> list[Exchange]:
        p = self._pending
        as_request = replace(frame, direction=Direction.REQUEST, guessed=True)
        answer = replace(frame, direction=Direction.RESPONSE, guessed=True)
        if p is None and self._answers_broadcast(frame):
            self._last = answer
            unsure = (
                "came within the response delay limit after a broadcast, and its PZD1 was seen "
                f"as a status word of address {frame.address} before; taken as an answer"
            )
            return [self._unexpected(answer, unsure)]
        if p is None or (frame.mode is not None and frame.mode.is_broadcast):
            return self._on_request(as_request)
        delay = frame.start - p.end
        if delay <= self.answer_window + _EPS:
            if frame.telegram is None:
                return self._suspect(answer)
            unsure = ""
            if not p.ok:
                if frame.address is not None and frame.address != p.address:
                    return self._on_request(as_request)
                unsure = _DAMAGED_REQUEST
            elif frame.address is not None and frame.address != p.address:
                if self._pzd1_seen(frame, self._seen_control, self._seen_status):
                    return self._on_request(as_request)  # the master did not wait
                unsure = (
                    f"a telegram to address {frame.address} came within the response delay "
                    f"limit after a request to address {p.address}; taken as a wrong answer"
                )
            return self._pair(p, answer, unsure)
        if p.ok and self._looks_like_answer(p, frame):
            unsure = (
                "came after the response delay limit from the same address and looks like "
                "an answer; taken as a late answer, not a new request"
            )
            return self._pair(p, answer, unsure)
        return self._on_request(as_request)

    def _on_request(self, frame: Frame) -> list[Exchange]:
        if frame.telegram is None:
            return self._noise(frame)
        out: list[Exchange] = []
        if self._pending is not None:
            note = ""
            if frame.start - self._pending.end <= self.answer_window:
                note = "the master sent its next telegram before the response delay limit"
            out += self._unanswered(self._pending, note)
        self._last = frame
        if frame.telegram.mode.is_broadcast:
            if frame.ok:
                self._broadcast = frame
            out.append(self._build(frame, None))
        else:
            self._pending = frame
        return out

    def _on_answer(self, frame: Frame) -> list[Exchange]:
        p = self._pending
        if p is not None:
            if frame.telegram is None and frame.start - p.end <= self.answer_window + _EPS:
                return self._suspect(frame)
            return self._pair(p, frame, "")
        if frame.telegram is None:
            return self._noise(frame)
        self._last = frame
        return [self._unexpected(frame)]

    def _unexpected(self, frame: Frame, unsure: str = "") -> Exchange:
        """An answer with no request open: to a broadcast (A 3), or to nothing."""
        b = self._broadcast
        if b is not None and 0 <= frame.start - b.end <= self.late_limit:
            why = (
                f"an answer {ms(frame.start - b.end)} after a broadcast, which no slave may "
                "answer (A 3)"
            )
        else:
            why = "an answer without a request"
        return self._build(None, frame, [Issue(Problem.UNEXPECTED, "answer", why)], unsure)

    def _answers_broadcast(self, frame: Frame) -> bool:
        """On a 2-wire line: whether ``frame``, right after a broadcast and within the response
        delay limit, is a slave's answer to it by its PZD1 (seen as a status word of its
        address, never as a control word)."""
        b = self._broadcast
        return (
            b is not None
            and self._last is b
            and frame.mode is AddressMode.NORMAL
            and frame.start - b.end <= self.answer_window + _EPS
            and self._pzd1_seen(frame, self._seen_status, self._seen_control)
        )

    def _suspect(self, frame: Frame) -> list[Exchange]:
        """Bytes without a telegram within the response delay limit of the open request:
        the answer, damaged, unless a telegram that answers the request follows in time
        (a driver switching on can put a stray character on the line before the answer)."""
        self._suspects.append(frame)
        self._last = frame
        return []

    def _settle(self, frame: Frame) -> list[Exchange] | None:
        """A frame after bytes held by `_suspect`: None when it is more such bytes (held as
        well); else the held bytes become the noise before the answer ``frame`` (nothing to
        report yet) or, when ``frame`` is no answer, the damaged answer of the open request."""
        p = self._pending
        assert p is not None
        if frame.telegram is None and frame.start - p.end <= self.answer_window + _EPS:
            side = self._suspects[0]
            self._suspects.append(replace(frame, direction=side.direction, guessed=side.guessed))
            self._last = frame
            return None
        if self._answers(p, frame):
            self._tail += self._suspects
            self._suspects = []
            return []
        return self._pair_suspect(p)

    def _pair_suspect(self, request: Frame) -> list[Exchange]:
        """The first bytes held by `_suspect` are the answer to ``request``."""
        first, *rest = self._suspects
        self._suspects = []
        self._tail += rest
        return self._pair(request, first, "" if request.ok else _DAMAGED_REQUEST)

    def _answers(self, request: Frame, frame: Frame) -> bool:
        """Whether the telegram ``frame`` is the answer to the open ``request`` (after bytes
        held by `_suspect`): an answer by its port, or one from the request's address within
        the response delay limit (or later, looking like an answer)."""
        if frame.telegram is None or frame.direction is Direction.REQUEST:
            return False
        if frame.direction is Direction.RESPONSE:
            return True
        if frame.address != request.address or frame.telegram.mode.is_broadcast:
            return False
        if frame.raw == request.raw and frame.mode is not AddressMode.MIRROR:
            return False  # the master repeating its request
        if self._pzd1_seen(frame, self._seen_control, self._seen_status):
            return False  # a control word: the master's next request
        if frame.start - request.end <= self.answer_window + _EPS:
            return True
        return request.ok and self._looks_like_answer(request, frame)

    def _close(self, exchange: Exchange) -> list[Exchange]:
        """The open request is done: its exchange, then the bytes that followed it."""
        self._pending = None
        tail, self._tail = sorted(self._tail, key=lambda f: f.start), []
        return [exchange, *(self._build(frame, None) for frame in tail)]

    def _pair(self, request: Frame, answer: Frame, unsure: str) -> list[Exchange]:
        self._last = answer
        issues: list[Issue] = []
        delay, _ = self.response_delay(request, answer)  # None: no timing rule to judge
        if delay is None:
            pass
        elif delay > self.answer_window + _EPS:
            issues.append(
                Issue(
                    Problem.LATE_ANSWER,
                    "answer",
                    f"the answer began {ms(delay)} after the request, later than the response "
                    f"delay limit of {ms(self.response_limit)} (A 5.2.1.1)",
                )
            )
        elif delay < self.early_limit - _EPS:
            issues.append(
                Issue(
                    Problem.EARLY_ANSWER,
                    "answer",
                    f"the answer began {ms(delay)} after the request, sooner than the start "
                    f"pause of {ms(self.timing.start_pause)} (A 5.2.1.1)",
                )
            )
        rq, an = request.telegram, answer.telegram
        if rq is not None and an is not None:
            if an.address != rq.address:
                issues.append(
                    Issue(
                        Problem.WRONG_ADDRESS,
                        "answer",
                        f"answer from address {an.address} to a request to address {rq.address}",
                    )
                )
            elif rq.mode is AddressMode.MIRROR and answer.raw != request.raw:
                issues.append(
                    Issue(
                        Problem.MIRROR,
                        "answer",
                        "the answer to a mirror telegram is not the same bytes (A 5.3)",
                    )
                )
        return self._close(self._build(request, answer, issues, unsure))

    def _unanswered(self, request: Frame, note: str = "") -> list[Exchange]:
        issues: list[Issue] = []
        if request.ok:
            issues.append(
                Issue(
                    Problem.NO_ANSWER,
                    "exchange",
                    f"address {request.address} did not answer within "
                    f"{ms(self.response_limit)} (A 5.2.1.1)",
                )
            )
        return self._close(self._build(request, None, issues, notes=(note,) if note else ()))

    def _looks_like_answer(self, request: Frame, frame: Frame) -> bool:
        rq, tg = request.telegram, frame.telegram
        if rq is None or tg is None or frame.fault is not None:
            return False
        if tg.address != rq.address or tg.mode is not rq.mode or frame.raw == request.raw:
            return False
        if rq.mode is not AddressMode.NORMAL:
            return False
        choice = self.layouts.choice(rq.address, len(tg.data) // 2)
        if choice is None:
            return False
        req, ans = unpack(choice.layout, rq.data), unpack(choice.layout, tg.data)
        if req is None or ans is None:
            return False
        if self._pzd1_seen(frame, self._seen_status, self._seen_control):
            return True
        if self._pzd1_seen(frame, self._seen_control, self._seen_status):
            return False
        if req.pkw is not None and ans.pkw is not None and ans.pkw != req.pkw:
            return ans.pkw.is_answer_to(req.pkw)
        return False

    def _pzd1_seen(
        self, frame: Frame, seen: dict[int, set[int]], not_in: dict[int, set[int]]
    ) -> bool:
        """Whether the PZD1 of ``frame`` was seen for its address in ``seen`` (control or
        status words) and never in ``not_in``: a hint which way a telegram went."""
        tg = frame.telegram
        if tg is None or frame.fault is not None or tg.mode is not AddressMode.NORMAL:
            return False
        choice = self.layouts.choice(tg.address, len(tg.data) // 2)
        data = None if choice is None or len(tg.data) % 2 else unpack(choice.layout, tg.data)
        if data is None or not data.pzd:
            return False
        word = data.pzd[0]
        return word in seen.get(tg.address, ()) and word not in not_in.get(tg.address, ())

    # -- exchanges -------------------------------------------------------------------------

    def _build(
        self,
        request: Frame | None,
        answer: Frame | None,
        extra: Sequence[Issue] = (),
        unsure: str = "",
        notes: Sequence[str] = (),
    ) -> Exchange:
        issues: list[Issue] = []
        for frame, where in ((request, "request"), (answer, "answer")):
            if frame is not None and frame.fault is not None:
                issues.append(Issue(problem_of(frame.fault), where, frame.detail))
        issues += extra
        address = next((f.address for f in (request, answer) if f and f.address is not None), None)
        learn(self.layouts, request, answer)
        request_data, choice = decode(self.layouts, request, address, issues, "request")
        answer_address = answer.address if answer is not None else None
        answer_data, answer_choice = decode(self.layouts, answer, answer_address, issues, "answer")
        choice = choice or answer_choice
        all_notes = list(notes)
        control_before = status_before = None
        if address is not None and request is not None:
            control_before = self._control.get(address)
            if request.ok and request_data is not None and request_data.pzd:
                self._note(address, request_data.pzd[0], self._control, self._seen_control)
        if answer_address is not None and answer is not None:
            status_before = self._status.get(answer_address)
            if answer.ok and answer_data is not None and answer_data.pzd:
                self._note(answer_address, answer_data.pzd[0], self._status, self._seen_status)
        if request_data is not None and answer_data is not None:
            all_notes += job_notes(request_data, answer_data)
        delay = None
        if request is not None and answer is not None:
            delay, unknown = self.response_delay(request, answer)
            if unknown:
                all_notes.insert(0, unknown)
        exchange = Exchange(
            request,
            answer,
            address=address,
            layout=None if choice is None else choice.layout,
            layout_source=None if choice is None else choice.source,
            request_data=request_data,
            answer_data=answer_data,
            delay=delay,
            issues=tuple(issues),
            unsure=unsure,
            notes=tuple(all_notes),
            control_before=control_before,
            status_before=status_before,
            index=next(self._count),
        )
        self.summary.record(exchange, self.layouts)
        return exchange

    @staticmethod
    def _note(address: int, word: int, last: dict[int, int], seen: dict[int, set[int]]) -> None:
        last[address] = word
        values = seen.setdefault(address, set())
        if len(values) < _HISTORY:
            values.add(word)


_DAMAGED_REQUEST = (
    "the request was damaged on the line; this came within the response delay limit, so it "
    "is taken as the answer"
)
