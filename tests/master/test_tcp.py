"""The master over raw TCP (``tcp://``, as to an RS-485/Ethernet converter), with simulated
drives on a virtual bus in another thread: the rules of the virtual-bus tests again, with a
transport that stamps bytes when it reads them (receive tolerance) - and the sync facade used
from threads."""

from __future__ import annotations

import asyncio
import threading
from concurrent.futures import ThreadPoolExecutor

import pytest

from pyuss.bus import Fault, FaultPlan
from pyuss.errors import TransportError, UssTimeout
from pyuss.master import Master, SpontaneousMessage
from pyuss.master import sync as sync_master
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import Layout
from pyuss.slave import JobLatency
from support.buses import SimulatorThread, line_telegrams
from support.waiting import eventually

L32 = Layout(3, 2)
L42 = Layout(4, 2)


async def test_jobs_poll_list_spontaneous_mirror_and_broadcast_over_tcp() -> None:
    drives = [(1, "generic", L42), (2, "generic", L42)]
    with SimulatorThread(drives, record=True) as sim:
        async with Master(sim.paths[0], baud=sim.baud, layout=L42) as bus:
            assert bus.rx_tolerance > 0  # TCP stamps bytes when they are read
            one, two = bus.drive(1), bus.drive(2)
            bus.set_poll_list([1, 2, 1])
            messages: list[SpontaneousMessage] = []
            one.on_spontaneous(messages.append)
            assert await one.read(52) == 0x4000
            assert await two.write(18, 0x7000) == 0x7000
            assert await one.write(4, 0x4000_0000, 2) == 0x4000_0000
            sim.call(lambda s: s.engines[1].drive.update(52, 0x0222))
            await eventually(lambda: bool(messages))
            assert [(m.pnu, m.value) for m in messages] == [(52, 0x0222)]
            result = await one.mirror()
            assert result.sent[2] == 0x41
            bea = BroadcastEnableArray.from_selection(words=[2])
            assert await bus.broadcast([0, 0x1000], pkw=bea.to_pkw_words(), layout=L42) == 0
            await eventually(lambda: bus.cycle_stats().cycles >= 10)
        recorder = sim.recorder
        assert recorder is not None
        addresses = [r.telegram.address for r in line_telegrams(recorder, sim.baud, sim.station())]
    start = max(i for i in range(len(addresses) - 2) if addresses[i : i + 3] == [1, 2, 1]) - 30
    tail = addresses[max(start, 0) :]
    assert tail.count(1) >= 2 * tail.count(2) - 3


async def test_a_slave_that_stops_answering_comes_back_over_tcp() -> None:
    with SimulatorThread([(1, "generic", L32), (2, "generic", L32)]) as sim:
        async with Master(sim.paths[0], baud=sim.baud, layout=L32) as bus:
            one, two = bus.drive(1), bus.drive(2)
            await eventually(lambda: one.status is not None and two.status is not None)
            assert sim.bus is not None
            sim.call(lambda s: s.bus.make_dead("drive2", 0.5))
            await eventually(lambda: two.not_sending)
            assert await one.read(52) == 0x4000  # the others are served meanwhile
            await eventually(lambda: not two.not_sending)
            assert await two.read(52) == 0x4000


async def test_a_slow_slave_beyond_20_ms_over_tcp() -> None:
    # 45 ms: later than 20 ms plus the 20 ms receive tolerance of TCP, but inside the time
    # the master still listens (latency), so the late answer is taken off the line.
    plan = FaultPlan([Fault("delay", station="drive2", seconds=0.045)])
    with SimulatorThread([(1, "generic", L32), (2, "generic", L32)], faults=plan) as sim:
        async with Master(sim.paths[0], baud=sim.baud, layout=L32) as bus:
            one, two = bus.drive(1), bus.drive(2)
            with pytest.raises(UssTimeout):
                await two.read(52, timeout=0.6)
            assert two.not_sending
            assert await one.read(52) == 0x4000
        async with Master(sim.paths[0], baud=sim.baud, layout=L32) as bus:
            slow = bus.drive(2, response_delay=0.2)
            assert await slow.read(52) == 0x4000


async def test_lost_answers_are_repeated_and_old_answers_not_taken_over_tcp() -> None:
    # The drive needs 3 more telegrams for a new job and drops characters now and then.
    plan = FaultPlan([Fault("flip", station="drive5", probability=0.02)])
    with SimulatorThread([(5, "generic", L32)], faults=plan, latency=JobLatency(cycles=3)) as sim:
        async with Master(sim.paths[0], baud=sim.baud, layout=L32) as bus:
            drive = bus.drive(5)
            results = await asyncio.gather(*(drive.write(18, v) for v in (11, 12, 13, 14)))
            assert results == [11, 12, 13, 14]
            assert await drive.read(18) == 14
            diag = drive.diagnostics()
            assert diag.jobs.telegrams.maximum >= 4  # every job waited for its own answer


def test_sync_facade_from_several_threads_over_tcp() -> None:
    with (
        SimulatorThread([(1, "generic", L42), (2, "generic", L42)]) as sim,
        sync_master.Master(sim.paths[0], baud=sim.baud, layout=L42) as bus,
    ):
        drives = [bus.drive(1), bus.drive(2)]
        assert bus.drive(1) is drives[0]
        errors: list[BaseException] = []
        lock = threading.Lock()

        def work(k: int) -> list[int]:
            drive = drives[k % 2]
            out = []
            try:
                for i in range(3):
                    value = 100 * k + i
                    out.append(drive.write(18, value) if k >= 2 else drive.read(52))
            except BaseException as exc:  # pragma: no cover - reported below
                with lock:
                    errors.append(exc)
            return out

        with ThreadPoolExecutor(6) as pool:
            results = list(pool.map(work, range(6)))
        assert not errors
        assert results[0] == results[1] == [0x4000] * 3
        for k in range(2, 6):
            assert results[k] == [100 * k + i for i in range(3)]
        status = drives[0].on()
        assert status.control == 0x047F
        assert drives[0].status is not None
        assert bus.diagnostics().slaves[0].address == 1


async def test_fixed_cycle_time_over_tcp() -> None:
    with SimulatorThread([(1, "generic", L32), (2, "generic", L32)]) as sim:
        async with Master(sim.paths[0], baud=sim.baud, layout=L32, cycle_time=0.05) as bus:
            bus.set_poll_list([1, 2, 1])
            await eventually(lambda: bus.cycle_stats().cycles >= 6)
            stats = bus.cycle_stats()
    # A 5.1.1: a new cycle never starts before the cycle time is over.
    assert stats.achieved.minimum >= 0.05 - 1e-3
    assert stats.cycle_time == 0.05


async def test_a_lost_port_fails_every_waiter_and_later_calls() -> None:
    sim = SimulatorThread([(5, "generic", L32)])
    with sim:
        bus = Master(sim.paths[0], baud=sim.baud, layout=L32, job_timeout=30)
        await bus.start()
        drive = bus.drive(5)
        assert await drive.read(52) == 0x4000
        sim.call(lambda s: s.engines[5].drive.update(52, 1))
    # The simulator's thread ended and closed the connection: the port is gone.
    with pytest.raises(TransportError):
        for _ in range(100):
            await drive.read((52, 18)[_ % 2])
    with pytest.raises(TransportError):
        await drive.read(52)
    await bus.close()
