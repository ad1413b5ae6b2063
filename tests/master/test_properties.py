"""Properties: the parameter channel against a model slave that lags behind (C 4.2.1.1), and the
description decoder against the drive simulator's descriptions of every profile (C 6)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.drive import SimulatedDrive
from pyuss.drive.database import DescriptionStyle
from pyuss.master.description import decode_description
from pyuss.master.jobs import Job, ParameterChannel
from pyuss.master.stats import Samples
from pyuss.profiles import PROFILES, get_profile
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId

GENERIC = get_profile("generic")


class ModelSlave:
    """C 4.2.1.1 as a slave may do it: a changed job is a new job, answered after ``lag`` more
    telegrams; until then the previous answer is repeated with the current value."""

    def __init__(self, lag: int) -> None:
        self.lag = lag
        self.values = {52: 100, 18: 200}
        self.job: Pkw | None = None
        self.answer = Pkw(ResponseId.NO_RESPONSE)
        self.waited = 0

    def handle(self, request: Pkw) -> Pkw:
        job = Pkw(request.id, request.pnu, request.index, False, request.values)
        if job != self.job:
            if self.waited < self.lag:
                self.waited += 1
                return self._current()
            self.job, self.waited = job, 0
            if job.id == RequestId.WRITE_WORD:
                self.values[job.pnu] = job.values[0]
            if job.id == RequestId.NO_JOB:
                self.answer = Pkw(ResponseId.NO_RESPONSE)
            else:
                self.answer = Pkw(ResponseId.VALUE_WORD, job.pnu)
        return self._current()

    def _current(self) -> Pkw:
        if self.answer.id == ResponseId.VALUE_WORD:
            return Pkw(
                ResponseId.VALUE_WORD, self.answer.pnu, values=(self.values[self.answer.pnu],)
            )
        return self.answer


jobs_strategy = st.lists(
    st.tuples(st.sampled_from(["read", "write"]), st.sampled_from([52, 18]), st.integers(0, 999)),
    min_size=1,
    max_size=8,
)


@settings(max_examples=150, deadline=None)
@given(jobs=jobs_strategy, lag=st.integers(0, 4), lost=st.sets(st.integers(0, 200), max_size=20))
def test_every_job_gets_the_answer_of_its_own_execution(
    jobs: list[tuple[str, int, int]], lag: int, lost: set[int]
) -> None:
    slave = ModelSlave(lag)
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    for kind, pnu, value in jobs:
        request = (
            Pkw(RequestId.WRITE_WORD, pnu, values=(value,))
            if kind == "write"
            else Pkw(RequestId.READ_VALUE, pnu)
        )
        channel.submit(Job(request, pnu, None, 1e9, done.append))
    step = 0
    while len(done) < len(jobs):
        assert step < 1000, "jobs do not finish"
        answer = slave.handle(channel.request(float(step)))
        if step not in lost:  # the answer may be lost on the line: the job is repeated
            channel.answer(answer, float(step))
        step += 1
    state = {52: 100, 18: 200}
    for (kind, pnu, value), job in zip(jobs, done, strict=True):
        if kind == "write":
            state[pnu] = value
        assert job.error is None and job.answer is not None
        assert job.answer.word() == state[pnu]
    assert slave.values == state


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_descriptions_of_every_parameter_decode(name: str) -> None:
    profile = get_profile(name)
    drive = SimulatedDrive.from_profile(name)
    db = profile.database()
    style = db.profile.description
    for param in db:
        pnu = param.pnu
        words = drive.description_words(pnu)
        description = decode_description(pnu, words, style)
        assert description.pnu == pnu
        if style is DescriptionStyle.PROFIBUS:
            assert description.name == param.name[:16].rstrip()
            assert description.data_type == param.dtype.label
            assert description.read_only == (not param.writable)
            assert description.is_array == param.is_array
        else:
            assert description.data_type is not None
        if (
            param.dtype.is_integer
            and param.minimum is not None
            and style is DescriptionStyle.PROFIBUS
        ):
            assert description.low == param.minimum


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(min_value=0, max_value=1, allow_nan=False), max_size=60),
    st.integers(min_value=0, max_value=8),
)
def test_sample_percentiles_are_those_of_the_recent_window(
    values: list[float], window: int
) -> None:
    """The median and p99 a drive's diagnostics report are the nearest-rank quantiles of the
    last ``window`` values, however many came before and fell out of it."""
    samples = Samples(window)
    for n, value in enumerate(values, start=1):
        samples.add(value)
        recent = sorted(values[max(0, n - window) : n])
        summary = samples.summary()
        rank = [max(0, math.ceil(q * len(recent)) - 1) for q in (0.5, 0.99)]
        assert summary.median == (recent[rank[0]] if recent else 0.0)
        assert summary.p99 == (recent[rank[1]] if recent else 0.0)
        assert summary.count == n and summary.last == value
        assert samples.summary() is summary
    assert samples.percentile(0.5) == (samples.summary().median if values else 0.0)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(min_value=0, max_value=1, allow_nan=False), max_size=60),
    st.lists(st.floats(min_value=0, max_value=1, allow_nan=False), max_size=20),
    st.integers(min_value=0, max_value=8),
)
def test_sample_percentiles_asked_late_are_those_of_the_recent_window(
    before: list[float], after: list[float], window: int
) -> None:
    """A summary asked for only after many values (the gateway's master, whose figures are
    read now and then) has the quantiles of the last ``window`` values, and so has every
    summary after it."""
    samples = Samples(window)
    for value in before:
        samples.add(value)
    values = list(before)
    for value in [None, *after]:
        if value is not None:
            samples.add(value)
            values.append(value)
        recent = sorted(values[max(0, len(values) - window) :]) if window else []
        summary = samples.summary()
        rank = [max(0, math.ceil(q * len(recent)) - 1) for q in (0.5, 0.99)]
        assert summary.median == (recent[rank[0]] if recent else 0.0)
        assert summary.p99 == (recent[rank[1]] if recent else 0.0)
        assert summary.count == len(values)
