"""Figures the master keeps: sample statistics and the diagnostics snapshots it hands out.

`Samples` keeps a count, the extremes and the mean of everything recorded, and the most
recent ``window`` values for the median and the 99th percentile. They are put in order the
first time a percentile is asked for and kept in order from then on, so that a summary taken
with every answer costs no sort, while a master whose figures nobody reads (a gateway's,
between two looks at its diagnostics) spends nothing on the order at every answer. The
snapshots are frozen dataclasses with a ``to_dict()`` for JSON output.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import asdict, dataclass
from typing import Any

from pyuss.protocol.diagnostics import Counters

__all__ = [
    "BusDiagnostics",
    "CycleStats",
    "JobStats",
    "SampleSummary",
    "Samples",
    "SlaveCounts",
    "SlaveDiagnostics",
]


@dataclass(frozen=True, slots=True)
class SampleSummary:
    """A summary of recorded values (seconds for times); all 0 when nothing was recorded."""

    count: int = 0
    last: float = 0.0
    mean: float = 0.0
    minimum: float = 0.0
    maximum: float = 0.0
    median: float = 0.0
    p99: float = 0.0
    stdev: float = 0.0


class Samples:
    """Running statistics over all values plus a window of recent ones for percentiles (the
    values are times and counts: never NaN, which has no place in an order)."""

    __slots__ = (
        "_m2",
        "_mean",
        "_ordered",
        "_summary",
        "count",
        "last",
        "maximum",
        "minimum",
        "recent",
    )

    def __init__(self, window: int = 1000) -> None:
        self.recent: deque[float] = deque(maxlen=window)
        self._ordered: list[float] | None = None
        """The values of ``recent``, sorted; None until a percentile is first asked for."""
        self._summary: SampleSummary | None = None
        """The last summary, until the next value."""
        self.count = 0
        self.last = 0.0
        self.minimum = math.inf
        self.maximum = -math.inf
        self._mean = 0.0
        self._m2 = 0.0

    def add(self, value: float) -> None:
        self._summary = None
        self.count += 1
        self.last = value
        if value < self.minimum:
            self.minimum = value
        if value > self.maximum:
            self.maximum = value
        delta = value - self._mean
        self._mean += delta / self.count
        self._m2 += delta * (value - self._mean)
        recent, ordered = self.recent, self._ordered
        if len(recent) == recent.maxlen:
            if not recent:
                return  # a window of 0 keeps no values
            if ordered is not None:
                del ordered[bisect.bisect_left(ordered, recent[0])]
        recent.append(value)
        if ordered is not None:
            bisect.insort(ordered, value)

    def percentile(self, q: float) -> float:
        """The ``q`` quantile (0..1) of the recent values, nearest rank; 0 when empty."""
        ordered = self._ordered
        if ordered is None:
            ordered = self._ordered = sorted(self.recent)
        if not ordered:
            return 0.0
        rank = max(0, min(len(ordered) - 1, math.ceil(q * len(ordered)) - 1))
        return ordered[rank]

    def summary(self) -> SampleSummary:
        if self._summary is not None:
            return self._summary
        if not self.count:
            return SampleSummary()
        stdev = math.sqrt(self._m2 / (self.count - 1)) if self.count > 1 else 0.0
        self._summary = SampleSummary(
            count=self.count,
            last=self.last,
            mean=self._mean,
            minimum=self.minimum,
            maximum=self.maximum,
            median=self.percentile(0.5),
            p99=self.percentile(0.99),
            stdev=stdev,
        )
        return self._summary


@dataclass(frozen=True, slots=True)
class JobStats:
    """Parameter jobs of one slave (C 4.2.1.1)."""

    completed: int = 0
    refused: int = 0
    timed_out: int = 0
    guard_telegrams: int = 0
    """"No job" telegrams sent to separate two jobs whose answers could be confused."""
    spontaneous: int = 0
    """Spontaneous messages received and acknowledged (C 4.2.1.2)."""
    telegrams: SampleSummary = SampleSummary()
    """Telegrams each completed job took (1 = answered at the first try)."""
    latency: SampleSummary = SampleSummary()
    """Seconds from a job's first telegram to its answer."""


@dataclass(frozen=True, slots=True)
class SlaveCounts:
    """The counts of `SlaveDiagnostics` without the response times and jobs, whose
    summaries take longer to make: what a view of the slave built at every answer needs."""

    counters: Counters
    exchanges: int
    answers: int
    timeouts: int


@dataclass(frozen=True, slots=True)
class SlaveDiagnostics:
    """One slave as the master sees it: the counters of A 5.2.3 for its answers, the
    "does not send" state of A 5.2.1.1, response times, process data and jobs."""

    address: int
    not_sending: bool
    counters: Counters
    exchanges: int
    answers: int
    timeouts: int
    late: int
    """Answers that began after the response delay limit (discarded, counted as timeouts)."""
    wrong_address: int
    """Telegrams received while waiting for this slave that came from another address or of
    another type (A 5.2: discarded)."""
    unusable: int
    """Answers that were complete and correct on the line but do not fit the slave's layout."""
    response_time: SampleSummary
    """From the end of the request's BCC to the start of the answer's STX (A 5.2.1.1)."""
    jobs: JobStats

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["counters"]["error_status"] = int(self.counters.error_status)
        return data


@dataclass(frozen=True, slots=True)
class CycleStats:
    """Achieved poll cycles (A 5.1.1): time from the start of one cycle to the next."""

    cycles: int
    cycle_time: float | None
    """The fixed cycle time asked for, None when the master cycles as fast as it can."""
    achieved: SampleSummary
    overruns: int
    """Cycles that took longer than the fixed cycle time."""


@dataclass(frozen=True, slots=True)
class BusDiagnostics:
    """The whole line: receive counters of every telegram seen (A 5.2.3), cycles, slaves."""

    baud: int
    line: Counters
    cycles: CycleStats
    broadcasts: int
    answered_broadcasts: int
    """Telegrams received after a broadcast, which no slave may answer (A 3)."""
    stray: int
    """Telegrams received while no answer was awaited."""
    slaves: tuple[SlaveDiagnostics, ...]
    own_heard: int = 0
    """The master's own telegrams heard back (a line that echoes), not taken as answers."""

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["line"]["error_status"] = int(self.line.error_status)
        data["slaves"] = [s.to_dict() for s in self.slaves]
        return data
