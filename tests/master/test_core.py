"""The master's core without I/O (`pyuss.master.core`): driven here by a loop of the test's own
with a simulated clock and the simulated drives' slave engines, thousands of random job mixes
and line faults; and the core reads no clock and does no I/O."""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import DriveRefusal
from pyuss.master.core import (
    ACYCLIC,
    CYCLIC,
    Exchange,
    Idle,
    MasterCore,
    Mode,
    Outcome,
    Result,
    Slave,
    Special,
)
from pyuss.master.errors import JobOutcome, JobTimeout
from pyuss.master.jobs import Job
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, RequestId
from pyuss.protocol.telegram import AddressMode
from pyuss.slave.engine import JobLatency, SlaveEngine
from pyuss.transport.base import Chunk

CORE = Path(__file__).resolve().parents[2] / "src" / "pyuss" / "master" / "core.py"
GENERIC = get_profile("generic")
PNU = 18
"""A plain writable word of the generic profile's drive (C 8.1 example 6)."""
BAUD = 19200


def test_the_core_imports_no_io_and_no_clock() -> None:
    tree = ast.parse(CORE.read_text(encoding="utf-8"))
    roots = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            roots.add(node.module.split(".")[0])
    impure = {"asyncio", "socket", "serial", "time", "os", "threading", "select", "selectors"}
    assert not roots & impure
    loaded = subprocess.run(
        [sys.executable, "-c", "import sys, pyuss.master.core; print(sorted(sys.modules))"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    for module in ("asyncio", "socket", "serial", "selectors"):
        assert f"'{module}'" not in loaded, f"importing the core loads {module}"


def test_the_asyncio_master_and_the_sync_facade_are_thin_loops_over_the_core() -> None:
    master = CORE.parent
    for name in ("scheduler.py", "loop.py", "sync.py"):
        lines = (master / name).read_text(encoding="utf-8").count("\n")
        assert lines < 400, f"master/{name} has {lines} lines"


@dataclass
class Fault:
    """What the line does to one exchange."""

    lost_request: bool = False
    lost_answer: bool = False
    garbled: bool = False
    late: bool = False


@dataclass
class Bench:
    """A loop of the test's own around a `MasterCore`: a simulated clock, one slave engine per
    address, every telegram and its answer as exact chunks, faults as drawn."""

    core: MasterCore
    engines: dict[int, SlaveEngine]
    faults: list[Fault]
    now: float = 0.0
    sent: list[tuple[float, bytes]] = field(default_factory=list)

    def run(self, until: float, done: Callable[[], bool] = lambda: False) -> None:
        core = self.core
        while self.now < until and not done():
            action = core.next_action(self.now)
            if isinstance(action, Idle):
                wake = until if action.until is None else action.until
                self.now = max(self.now, min(wake, until))
                core.expire_jobs(self.now)
                if action.until is None:
                    return
                continue
            if isinstance(action, Special):
                raise AssertionError("no special telegram was asked for")
            self.turn(action)

    def turn(self, slave: Slave) -> None:
        core = self.core
        self.now = max(self.now, core.send_due(slave.profile.start_pause_chars))
        core.sending(self.now)
        version, control = slave.version, slave.control
        frame = slave.request(self.now)
        start = self.now
        end = start + core.timing.transmit(len(frame))
        core.sent(frame, start, end - start, end)
        self.sent.append((start, frame))
        self.now = end
        fault = self.faults.pop(0) if self.faults else Fault()
        engine = self.engines[slave.address]
        answer = None if fault.lost_request else engine.handle_bytes(frame, end)
        arrivals: list[Chunk] = []
        if answer is not None and not fault.lost_answer:
            if fault.garbled:
                answer = answer[:-1] + bytes([answer[-1] ^ 0x5A])
            begin = end + (slave.response_delay + 0.05 if fault.late else 0.002)
            arrivals.append(Chunk(answer, begin + core.timing.transmit(len(answer))))
        exchange = Exchange(
            core, slave.address, {AddressMode.NORMAL}, slave.response_delay, slave, start, end
        )
        while True:
            while arrivals and arrivals[0].timestamp <= self.now:
                exchange.feed(arrivals.pop(0))
            verdict = exchange.step(self.now)
            if isinstance(verdict, Result):
                break
            if verdict is None:
                if arrivals:  # what is due is handed over first
                    self.now = max(self.now, arrivals[0].timestamp)
                    continue
                verdict = exchange.give_up(self.now)
                break
            wake = self.now + verdict
            if arrivals:
                wake = min(wake, arrivals[0].timestamp)
            self.now = max(wake, self.now + 1e-6)
        if fault.late or fault.garbled or fault.lost_answer or fault.lost_request:
            assert verdict.outcome is not Outcome.ANSWER
        core.end_turn(slave, verdict, version, control, self.now)


def make_bench(
    addresses: list[int], faults: list[Fault], mode: Mode = CYCLIC, cycles: int = 0
) -> Bench:
    core = MasterCore(BAUD, profile=GENERIC, layout="4,2", mode=mode, job_timeout=0.5)
    core.exact = True
    engines = {}
    for address in addresses:
        core.add_slave(address)
        drive = SimulatedDrive(GENERIC.database())
        # a drive that takes ``cycles`` telegrams for a job repeats its old answer meanwhile
        latency = JobLatency(cycles=cycles)
        engines[address] = SlaveEngine(
            address, drive, GENERIC, layout=Layout(4, 2), latency=latency
        )
    return Bench(core, engines, list(faults))


def submit(bench: Bench, slave: Slave, request: Pkw, done: list[Job]) -> Job:
    job = Job(request, request.pnu, None, bench.core.job_timeout, done.append)
    bench.core.check_job(slave)
    bench.core.submit(slave, job, bench.now)
    return job


faults = st.builds(
    Fault,
    lost_request=st.booleans(),
    lost_answer=st.booleans(),
    garbled=st.booleans(),
    late=st.booleans(),
)
clean_or_faulty = st.one_of(st.just(Fault()), st.just(Fault()), faults)
jobs = st.lists(
    st.tuples(st.sampled_from([3, 7, 12]), st.one_of(st.none(), st.integers(0, 0xFFFF))),
    min_size=1,
    max_size=12,
)


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    mix=jobs,
    line=st.lists(clean_or_faulty, max_size=80),
    mode=st.sampled_from([CYCLIC, ACYCLIC]),
    cycles=st.integers(0, 3),
)
def test_every_job_ends_once_and_no_old_answer_is_taken_for_a_new_one(
    mix: list[tuple[int, int | None]], line: list[Fault], mode: Mode, cycles: int
) -> None:
    bench = make_bench([3, 7, 12], line, mode, cycles)
    core = bench.core
    done: list[Job] = []
    order: list[tuple[int, Job, int | None]] = []
    for address, value in mix:
        slave = core.slaves[address]
        if value is None:
            request = Pkw(RequestId.READ_VALUE, PNU)
        else:
            request = Pkw(RequestId.WRITE_WORD, PNU, values=(value,))
        order.append((address, submit(bench, slave, request, done), value))
    bench.run(until=30.0, done=lambda: len(done) == len(order))
    assert sorted(map(id, done)) == sorted(id(job) for _, job, _ in order), "each ends once"
    if all(fault == Fault() for fault in line):
        assert all(job.error is None for job in done), "on a clean line every job is answered"
    # Per drive, in the order submitted: a read gives what the drive holds, which is the
    # last write carried out - one that answered, or possibly one whose answer was lost.
    possible = {address: {0} for address in core.slaves}
    for address, job, value in order:
        if job.error is not None:
            assert isinstance(job.error, JobTimeout | DriveRefusal)
            if value is not None and not (
                isinstance(job.error, JobTimeout) and job.error.outcome is JobOutcome.NOT_SENT
            ):
                possible[address].add(value)  # may have been carried out
            continue
        assert job.answer is not None
        got = job.answer.values[-1] & 0xFFFF  # a word in PWE2 of 4 PKW words
        if value is None:
            assert got in possible[address], f"read P{PNU} of {address}: {got} is an old answer"
            possible[address] = {got}
        else:
            assert got == value, "a write's answer gives the value written"
            possible[address] = {value}
    for address, engine in bench.engines.items():
        value = engine.drive.value(PNU)
        assert isinstance(value, int) and value & 0xFFFF in possible[address]
    # no telegram carried a job after its deadline, and none lasted past it and one exchange
    for _, job, _ in order:
        if job.deadline is not None and isinstance(job.error, JobTimeout):
            assert job.error.elapsed <= core.job_timeout + 0.2


@settings(max_examples=200, deadline=None)
@given(
    words=st.lists(st.integers(0, 0xFFFF), min_size=1, max_size=10),
    line=st.lists(clean_or_faulty, max_size=40),
)
def test_every_telegram_carries_the_newest_process_data(
    words: list[int], line: list[Fault]
) -> None:
    bench = make_bench([5], line)
    core = bench.core
    slave = core.slaves[5]
    for word in words:
        version = core.set_process_data(slave, control=word, setpoints={2: word ^ 0xFFFF})
        bench.sent.clear()
        bench.run(until=bench.now + 0.2)
        for _, frame in bench.sent:  # STX LGE ADR, PKW 8 bytes, then the control word
            assert int.from_bytes(frame[11:13], "big") == word
            assert int.from_bytes(frame[13:15], "big") == word ^ 0xFFFF
        if slave.answered_version >= version:
            assert slave.status is not None and slave.status.control == word


def test_a_fixed_cycle_waits_for_the_rest_of_the_cycle_and_counts_overruns() -> None:
    core = MasterCore(BAUD, profile=GENERIC, layout="4,2", cycle_time=0.05)
    core.add_slave(5)
    first = core.next_action(0.0)
    assert isinstance(first, Slave)
    idle = core.next_action(0.01)  # the entry is done at 10 ms: the cycle runs to 50 ms
    assert idle == Idle(0.05)
    assert isinstance(core.next_action(0.05), Slave)
    assert isinstance(core.next_action(0.2), Slave)  # that cycle took 150 ms: an overrun
    stats = core.cycle_stats()
    assert stats.overruns == 1 and stats.cycles == 2


def test_specials_go_before_the_next_entry_of_the_poll_list() -> None:
    core = MasterCore(BAUD, profile=GENERIC, layout="4,2")
    core.add_slave(5)
    core.add_slave(6)
    assert core.next_action(0.0) is core.slaves[5]

    class Pending:
        def done(self) -> bool:
            return False

        def set_result(self, result: object) -> None: ...
        def set_exception(self, exception: BaseException) -> None: ...

    core.add_special("mirror", core.mirror_frame(6, None), 6, Pending())
    assert isinstance(core.next_action(0.01), Special)
    assert core.next_action(0.02) is core.slaves[6]


def test_a_slave_that_stops_answering_is_marked_and_comes_back() -> None:
    bench = make_bench([5], [Fault(lost_answer=True)] * 3)
    slave = bench.core.slaves[5]
    missed: list[int] = []
    slave.miss_callbacks.append(missed.append)
    bench.run(until=0.2)
    assert missed[:3] == [1, 2, 3]
    assert slave.missed == 0 and not slave.not_sending and slave.timeouts == 3
