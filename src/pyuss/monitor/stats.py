"""Summary statistics of a monitored line: A 5.2.3 counters, error rates, response times.

`Summary` keeps, for the whole line and for each slave address, a
`pyuss.protocol.Diagnostics` (the 16 diagnostic parameters of A 5.2.3, as a receiver on the
line would count them) and the monitor's own counts:

- every frame counts once: a good telegram as received without fault, a damaged one under its
  receive fault (A 5.2.2); a frame whose address is unknown (bytes without a telegram)
  counts for the line only;
- a request not answered in time (no answer, or a late one) counts as a timeout (A 5.2.3
  counter 16, status bit 7: "Master: Antwortverzugszeit abgelaufen");
- requests, answers, answers missing, late, from the wrong address, unexpected answers,
  refused parameter jobs (response ID 7, C Table 4.3);
- response times (A 5.2.1.1, end of request to start of answer): count, minimum, mean,
  maximum and the 95th percentile of the last `RECENT` answers.

The error rate of an address is the share of its frames that were discarded; the no-answer
rate the share of its requests that got no answer in time.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from pyuss.monitor.infer import LayoutBook
from pyuss.monitor.model import Exchange, Problem
from pyuss.protocol.diagnostics import Diagnostics
from pyuss.protocol.pkw import ResponseId

__all__ = ["RECENT", "AddressStats", "Delays", "Summary"]

RECENT = 1000
"""How many recent response times the percentile is taken over."""


@dataclass(slots=True)
class Delays:
    """Response times in seconds."""

    count: int = 0
    total: float = 0.0
    low: float = math.inf
    high: float = -math.inf
    recent: deque[float] = field(default_factory=lambda: deque(maxlen=RECENT))

    def add(self, delay: float) -> None:
        self.count += 1
        self.total += delay
        self.low = min(self.low, delay)
        self.high = max(self.high, delay)
        self.recent.append(delay)

    @property
    def mean(self) -> float | None:
        return self.total / self.count if self.count else None

    def percentile(self, q: float) -> float | None:
        """The ``q`` quantile (0..1) of the recent response times, nearest rank."""
        if not self.recent:
            return None
        ordered = sorted(self.recent)
        rank = max(1, math.ceil(q * len(ordered)))
        return ordered[rank - 1]

    def as_dict(self) -> dict[str, Any]:
        """Milliseconds, rounded to microseconds; None where there is nothing yet."""

        def ms(value: float | None) -> float | None:
            return None if value is None or not math.isfinite(value) else round(value * 1e3, 3)

        return {
            "count": self.count,
            "min_ms": ms(self.low),
            "mean_ms": ms(self.mean),
            "p95_ms": ms(self.percentile(0.95)),
            "max_ms": ms(self.high),
        }


@dataclass(slots=True)
class AddressStats:
    """What was seen of one address (or of the whole line when ``address`` is None)."""

    address: int | None
    diagnostics: Diagnostics = field(default_factory=Diagnostics)
    requests: int = 0
    answers: int = 0
    no_answer: int = 0
    late: int = 0
    wrong_address: int = 0
    unexpected: int = 0
    refused: int = 0
    delays: Delays = field(default_factory=Delays)
    layout: str = ""

    @property
    def frames(self) -> int:
        return self.diagnostics.good + self.diagnostics.discarded

    @property
    def error_rate(self) -> float:
        """Discarded frames / all frames (0 when none)."""
        return self.diagnostics.discarded / self.frames if self.frames else 0.0

    @property
    def no_answer_rate(self) -> float:
        """Requests not answered in time / requests that expected an answer."""
        expected = self.answers + self.no_answer
        return (self.no_answer + self.late) / expected if expected else 0.0

    def as_dict(self, now: float) -> dict[str, Any]:
        counters = self.diagnostics.snapshot(now)
        return {
            "address": self.address,
            "layout": self.layout,
            "requests": self.requests,
            "answers": self.answers,
            "no_answer": self.no_answer,
            "late": self.late,
            "wrong_address": self.wrong_address,
            "unexpected": self.unexpected,
            "refused": self.refused,
            "error_rate": round(self.error_rate, 6),
            "no_answer_rate": round(self.no_answer_rate, 6),
            "error_status": int(counters.error_status),
            "counters": counters.counts(),
            "response_time": self.delays.as_dict(),
        }


class Summary:
    """Counters of a monitored line, updated for every exchange (see the module text)."""

    def __init__(self) -> None:
        self.line = AddressStats(None)
        self.addresses: dict[int, AddressStats] = {}
        self.exchanges = 0
        self.first: float | None = None
        self.last: float | None = None

    def _of(self, address: int | None) -> AddressStats | None:
        if address is None:
            return None
        stats = self.addresses.get(address)
        if stats is None:
            stats = self.addresses[address] = AddressStats(address)
        return stats

    def record(self, exchange: Exchange, layouts: LayoutBook | None = None) -> None:
        """Count ``exchange`` (``layouts``: the monitor's, which tell the current layouts)."""
        self.exchanges += 1
        for frame in exchange.frames:
            if self.first is None or frame.start < self.first:
                self.first = frame.start
            if self.last is None or frame.end > self.last:
                self.last = frame.end
            address = frame.address if frame.address is not None else exchange.address
            if frame.telegram is not None and frame.telegram.mode.is_broadcast:
                address = None
            for stats in (self.line, self._of(address)):
                if stats is None:
                    continue
                if frame.fault is None:
                    stats.diagnostics.record_received(frame.end)
                else:
                    stats.diagnostics.record_fault(frame.fault, frame.end)
        where = self._of(exchange.address)
        problems = set(exchange.problems)
        for stats in (self.line, where):
            if stats is None:
                continue
            if exchange.request is not None and exchange.request.telegram is not None:
                stats.requests += 1
            if exchange.answer is not None:
                stats.answers += 1
            if exchange.delay is not None and Problem.WRONG_ADDRESS not in problems:
                stats.delays.add(exchange.delay)
            timeout = problems & {Problem.NO_ANSWER, Problem.LATE_ANSWER}
            if timeout:
                stats.diagnostics.record_timeout(exchange.time)
            stats.no_answer += Problem.NO_ANSWER in problems
            stats.late += Problem.LATE_ANSWER in problems
            stats.wrong_address += Problem.WRONG_ADDRESS in problems
            stats.unexpected += Problem.UNEXPECTED in problems
            data = exchange.answer_data
            if data is not None and data.pkw is not None and data.pkw.id == ResponseId.REFUSED:
                stats.refused += 1
        if layouts is not None and where is not None and exchange.address is not None:
            choice = layouts.choice(exchange.address)
            if choice is not None:
                where.layout = f"{choice.layout} {choice.source.value}"

    def rows(self, now: float) -> list[dict[str, Any]]:
        """One dict per address (in address order), then the line; see `AddressStats`."""
        out = [self.addresses[a].as_dict(now) for a in sorted(self.addresses)]
        out.append(self.line.as_dict(now))
        return out
