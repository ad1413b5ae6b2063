"""A job without an answer of its own: what is known of it (`JobTimeout.outcome`), reading the
value back to tell (``verify``), and a timeout that ends on time whatever else is on the line.

The line misbehaves through the virtual bus's fault plan (answers dropped, a drive that hears
nothing) or scripted slaves; times are the bus's own timeline (``time.monotonic`` seconds the
bus and the master share), never a stopwatch in the test."""

from __future__ import annotations

import asyncio
import time

import pytest

from pyuss.bus import Fault, FaultPlan, VirtualBus
from pyuss.master import JobOutcome, JobTimeout
from pyuss.master.jobs import Job, ParameterChannel
from pyuss.master.verify import read_request
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId, TextIndex
from support.buses import line_telegrams, scripted_bus, simulated_bus

GENERIC = get_profile("generic")
LAYOUT = Layout(3, 2)


def _job(request: Pkw, done: list[Job], timeout: float = 1.0) -> Job:
    return Job(request, request.pnu, None, timeout, done.append)


def _error(done: list[Job]) -> JobTimeout:
    assert len(done) == 1 and isinstance(done[0].error, JobTimeout)
    return done[0].error


# -- the channel alone (pure, time passed in) -----------------------------------------------


def test_a_write_that_was_sent_but_not_answered_may_have_been_applied() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.WRITE_WORD, 18, values=(7,)), done), 0.0)
    assert channel.request(0.1).id == RequestId.WRITE_WORD
    channel.expire(1.2)
    error = _error(done)
    assert error.outcome is JobOutcome.UNKNOWN
    assert error.may_have_applied and error.changes
    assert error.sent == 1 and error.elapsed == pytest.approx(1.2)
    assert error.timeout == 1.0
    assert "may have carried it out" in str(error)


def test_a_write_held_back_by_the_guard_was_not_sent_and_not_applied() -> None:
    channel = ParameterChannel(5, GENERIC)  # nothing known of the slave: guard first
    done: list[Job] = []
    channel.submit(_job(Pkw(RequestId.WRITE_WORD, 18, values=(7,)), done), 0.0)
    assert channel.request(0.5) == Pkw(RequestId.NO_JOB)
    channel.expire(1.01)
    error = _error(done)
    assert error.outcome is JobOutcome.NOT_SENT and error.sent == 0
    assert not error.may_have_applied
    assert "the drive did not get it" in str(error)


def test_a_read_without_answer_changed_nothing() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done), 0.0)
    channel.request(0.0)
    channel.expire(1.5)
    error = _error(done)
    assert error.outcome is JobOutcome.UNKNOWN and not error.changes
    assert not error.may_have_applied


def test_text_requests_change_something_only_with_the_write_bit() -> None:
    read = Pkw(RequestId.TEXT, 7, 3)
    write = Pkw(RequestId.TEXT, 7, 3 | TextIndex.WRITE, values=(0x4142,))
    for request, changes in ((read, False), (write, True)):
        error = JobTimeout("x", address=5, pnu=7, sent=1, request=request)
        assert error.changes is changes
    assert read_request(write) == read
    assert read_request(Pkw(RequestId.WRITE_ARRAY_DWORD_EEPROM, 4, 2, values=(1, 2))) == Pkw(
        RequestId.READ_ARRAY, 4, 2
    )


def test_the_time_held_back_by_the_guard_counts() -> None:
    """A job's time starts when it is due, not when the guard lets it go: a 1 s job that
    waited 0.6 s for the slave's old answer to clear has 0.4 s left."""
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done), 0.0)
    assert channel.request(0.0) == Pkw(RequestId.NO_JOB)
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.6)
    assert channel.request(0.6).id == RequestId.READ_VALUE
    assert channel.request(0.95).id == RequestId.READ_VALUE
    assert channel.request(1.05) == Pkw(RequestId.NO_JOB)  # nothing carries it after 1.0
    error = _error(done)
    assert error.elapsed == pytest.approx(1.05) and error.sent == 2


def test_a_queued_job_starts_its_time_when_the_one_before_it_ends() -> None:
    channel = ParameterChannel(5, GENERIC)
    done: list[Job] = []
    channel.answer(Pkw(ResponseId.NO_RESPONSE), 0.0)
    channel.submit(_job(Pkw(RequestId.READ_VALUE, 52), done), 0.0)
    second = _job(Pkw(RequestId.READ_VALUE, 53), done)
    channel.submit(second, 0.1)
    assert second.due is None
    channel.request(0.2)
    channel.answer(Pkw(ResponseId.VALUE_WORD, 52, values=(1,)), 0.8)
    assert second.due == 0.8 and channel.deadline == pytest.approx(1.8)


# -- over the virtual bus -------------------------------------------------------------------


async def _bus_time(bus: VirtualBus, t: float) -> None:
    """Sleep until ``t`` seconds after the bus started (the fault plan's time base)."""
    await asyncio.sleep(max(0.0, bus.epoch + t - time.monotonic()))


# The faults below act from 0.5 s to 1.3 s of bus time. The write starts at 0.5 s and has
# 0.6 s, so the window covers it whole (with 0.2 s to spare for a slow start); the read-back
# that follows runs into the end of the window and has its own 0.6 s.
WINDOW = {"at": 0.5, "duration": 0.8}
TIMEOUT = 0.6


async def test_a_write_whose_answer_is_lost_reports_an_unknown_outcome() -> None:
    plan = FaultPlan([Fault("drop", station="drive5", **WINDOW)])  # type: ignore[arg-type]
    async with simulated_bus([(5, "generic", LAYOUT)], faults=plan) as env:
        drive = env.master.drive(5, layout=LAYOUT)
        assert await drive.read(18) == 0
        await _bus_time(env.bus, WINDOW["at"])
        with pytest.raises(JobTimeout) as info:
            await drive.write(18, 0x7000, timeout=TIMEOUT)
        error = info.value
        assert error.outcome is JobOutcome.UNKNOWN and error.may_have_applied
        assert error.sent >= 1 and error.pnu == 18
        # ... and indeed the drive got it: only its answers were lost.
        assert env.engines[5].drive.value(18) == 0x7000


async def test_verify_reads_back_a_write_that_was_applied() -> None:
    plan = FaultPlan([Fault("drop", station="drive5", **WINDOW)])  # type: ignore[arg-type]
    async with simulated_bus([(5, "generic", LAYOUT)], faults=plan) as env:
        drive = env.master.drive(5, layout=LAYOUT)
        assert await drive.read(18) == 0
        await _bus_time(env.bus, WINDOW["at"])
        assert await drive.write(18, 0x7000, timeout=TIMEOUT, verify=True) == 0x7000
        assert env.master.diagnostics().slaves[0].jobs.timed_out == 1  # the answer was lost
        assert env.engines[5].drive.value(18) == 0x7000


async def test_verify_tells_a_write_the_drive_never_heard() -> None:
    plan = FaultPlan([Fault("deaf", station="drive5", **WINDOW)])  # type: ignore[arg-type]
    async with simulated_bus([(5, "generic", LAYOUT)], faults=plan) as env:
        drive = env.master.drive(5, layout=LAYOUT)
        assert await drive.read(18) == 0
        await _bus_time(env.bus, WINDOW["at"])
        with pytest.raises(JobTimeout) as info:
            await drive.write(18, 0x7000, timeout=TIMEOUT, verify=True)
        error = info.value
        assert error.outcome is JobOutcome.NOT_APPLIED and not error.may_have_applied
        assert "did not carry it out" in str(error)
        assert env.engines[5].drive.value(18) == 0
        assert await drive.read(18) == 0


async def test_a_job_ends_at_its_deadline_after_a_long_guard() -> None:
    """Slave 5 answers nothing while its old answer must clear (0.4 s), then lets the guard
    pass and swallows the job; slaves 6..8 on the same poll list are silent, so every cycle
    holds three unanswered exchanges. The job of 1 s still ends within 10 % of 1 s after it
    was due, by the bus's clock, and no telegram carries it after its deadline."""
    async with scripted_bus((5, 6, 7, 8), record=True) as env:
        slave = env.slaves[5]
        for address in (6, 7, 8):
            env.slaves[address].silent = True
        slave.silent = True

        def swallow_the_job(telegram):  # type: ignore[no-untyped-def]
            if LAYOUT.unpack(telegram.data).pkw.id == RequestId.READ_VALUE:
                slave.silent = True

        drive = env.master.drive(5)
        for address in (6, 7, 8):
            env.master.drive(address)
        submitted = env.master.transport.clock()
        task = asyncio.create_task(drive.read(52, timeout=1.0))
        await asyncio.sleep(0)  # the job is queued (its time starts) by now
        due_by = env.master.transport.clock()
        await asyncio.sleep(0.4)
        slave.on_request = swallow_the_job
        slave.silent = False  # "no job" is answered with "no response": the guard passes
        with pytest.raises(JobTimeout) as info:
            await task
        error = info.value
        assert error.outcome is JobOutcome.UNKNOWN and error.sent >= 1
        assert error.elapsed is not None and 1.0 <= error.elapsed <= 1.1
        assert env.recorder is not None
        carrying = [
            env.bus.epoch + t.start
            for t in line_telegrams(env.recorder, env.bus.baud)
            if t.telegram.address == 5
            and (pkw := LAYOUT.unpack(t.telegram.data).pkw) is not None
            and pkw.id == RequestId.READ_VALUE
        ]
        assert len(carrying) == error.sent  # the job went out after the guard ...
        assert submitted + 0.4 <= carrying[0]
        assert carrying[-1] <= due_by + 1.0  # ... and never after its deadline


async def test_a_job_ends_at_its_deadline_while_another_slave_holds_the_line() -> None:
    """The job for slave 5 is queued as the master starts an exchange with slave 6, whose
    answer may come up to 3 s later (its response delay limit): the job ends at its own
    deadline (1 s) during that exchange, not when the line is free again - and it was never
    sent, so the drive did not get it."""
    async with scripted_bus((5, 6), record=True) as env:
        drive = env.master.drive(5)
        assert await drive.read(52) == 0x4000
        other = env.master.drive(6, response_delay=3.0)
        env.slaves[6].silent = True
        jobs: list[asyncio.Task[object]] = []

        def queue_the_job(telegram):  # type: ignore[no-untyped-def]
            if not jobs:
                jobs.append(asyncio.create_task(drive.write(18, 5, timeout=1.0)))

        env.slaves[6].on_request = queue_the_job
        while not jobs:
            await asyncio.sleep(0.01)
        with pytest.raises(JobTimeout) as info:
            await jobs[0]
        assert other.diagnostics().timeouts == 0  # slave 6's exchange is still running
        error = info.value
        assert error.outcome is JobOutcome.NOT_SENT and error.sent == 0
        assert error.elapsed is not None and 1.0 <= error.elapsed <= 1.1
        assert env.slaves[5].params[18] == 0
