"""The scheduler on the virtual bus: poll list, cycle time, timing, silent and slow slaves,
broadcast, mirror (A 2, A 3, A 5.1, A 5.2, A 5.3)."""

from __future__ import annotations

import asyncio
import dataclasses
import itertools
import json
import math

import pytest

from master.scripted import ScriptedSlave
from pyuss.bus import Fault, FaultPlan, VirtualBus
from pyuss.errors import ConfigError, UssTimeout
from pyuss.master import ACYCLIC, Master, MirrorMismatch, NotSending
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.diagnostics import Counters
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import AddressMode
from pyuss.protocol.timing import char_time, start_pause
from support.buses import line_telegrams, scripted_bus
from support.waiting import eventually


async def test_poll_list_with_repeated_entries_is_followed_in_order() -> None:
    async with scripted_bus((1, 2, 3), record=True) as env:
        env.master.set_poll_list([1, 2, 1, 3])
        await eventually(lambda: len(env.slaves[3].log.requests) >= 6)
    assert env.recorder is not None
    addresses = [r.telegram.address for r in line_telegrams(env.recorder, env.bus.baud)]
    # Cut off the start (the drives were added one by one) and look at whole cycles.
    first = next(i for i in range(len(addresses) - 4) if addresses[i : i + 4] == [1, 2, 1, 3])
    body = addresses[first:]
    whole = len(body) // 4 * 4
    assert whole >= 16
    assert body[:whole] == [1, 2, 1, 3] * (whole // 4)
    assert env.master.poll_list == (1, 2, 1, 3)


async def test_point_to_point_is_a_one_entry_poll_list() -> None:
    async with scripted_bus((7,), record=True) as env:
        env.master.drive(7)
        await eventually(lambda: len(env.slaves[7].log.requests) >= 5)
    assert env.recorder is not None
    assert {r.telegram.address for r in line_telegrams(env.recorder, env.bus.baud)} == {7}


async def test_start_pause_before_every_telegram_and_answers_inside_the_limit() -> None:
    async with scripted_bus((1, 2), baud=19200, record=True) as env:
        env.master.drive(1)
        env.master.drive(2)
        await eventually(lambda: len(env.slaves[2].log.requests) >= 10)
    assert env.recorder is not None
    # Every telegram of the master starts at least 2 character times after the last
    # character on the line, whoever sent it (A 5.1.2).
    records = env.recorder.records
    pause = start_pause(env.bus.baud)
    for prev, cur in itertools.pairwise(records):
        if cur.sender == "master" and prev.sender != "master" and cur.byte == 0x02:
            assert cur.start - prev.t >= pause - 1e-9


async def test_fixed_cycle_time_is_kept() -> None:
    cycle = 0.04
    async with scripted_bus((1, 2), record=True, cycle_time=cycle) as env:
        env.master.set_poll_list([1, 2])
        await eventually(lambda: env.master.cycle_stats().cycles >= 8)
        stats = env.master.cycle_stats()
    assert env.recorder is not None
    starts = [
        r.start for r in line_telegrams(env.recorder, env.bus.baud) if r.telegram.address == 1
    ]
    gaps = [b - a for a, b in itertools.pairwise(starts[1:])]
    # A 5.1.1: after the last slave the master waits until the cycle time is over.
    assert gaps and min(gaps) >= cycle - 1e-3
    assert stats.cycle_time == cycle
    assert stats.achieved.count >= 7
    assert stats.achieved.minimum >= cycle - 1e-3


async def test_a_slave_that_stops_answering_and_comes_back() -> None:
    async with scripted_bus((1, 2)) as env:
        one, two = env.master.drive(1), env.master.drive(2)
        await eventually(lambda: one.status is not None and two.status is not None)
        env.bus.make_dead("slave2", 0.4)
        await eventually(lambda: two.not_sending)
        answered = env.slaves[1].log.answered
        await eventually(lambda: env.slaves[1].log.answered >= answered + 5)
        assert two.not_sending  # set until a good telegram comes from it
        assert 2 in env.master.poll_list
        await eventually(lambda: not two.not_sending)
        assert await two.read(52) == 0x4000
        diag = two.diagnostics()
        snapshot = json.loads(json.dumps(env.master.diagnostics().to_dict()))
    assert diag.timeouts >= 1
    assert [s["address"] for s in snapshot["slaves"]] == [1, 2]
    assert snapshot["slaves"][1]["counters"]["timeout"] >= 1
    assert snapshot["slaves"][1]["counters"]["error_status"] & 0x80
    assert snapshot["slaves"][1]["jobs"]["completed"] == 1
    assert snapshot["cycles"]["cycles"] >= 1 and "stdev" in snapshot["cycles"]["achieved"]
    assert diag.counters.timeout == diag.timeouts
    assert diag.counters.error_status & 0x80  # A 5.2.3 bit 7: response delay exceeded
    assert not one.not_sending


async def test_a_slow_slave_beyond_20_ms_is_not_sending_unless_its_limit_says_so() -> None:
    async with scripted_bus((1, 2)) as env:
        env.slaves[2].delay = 0.035
        fast, slow = env.master.drive(1), env.master.drive(2)
        with pytest.raises(UssTimeout):
            await slow.read(52, timeout=0.5)
        assert slow.not_sending
        assert slow.diagnostics().late >= 1
        assert await fast.read(52) == 0x4000  # the other slave is served meanwhile
    async with scripted_bus((2,)) as env:
        env.slaves[2].delay = 0.035
        slow = env.master.drive(2, response_delay=0.06)
        assert await slow.read(52) == 0x4000
        assert not slow.not_sending
        assert slow.diagnostics().response_time.minimum >= 0.035 - 1e-3


async def test_answers_with_the_wrong_address_are_discarded() -> None:
    async with scripted_bus((5,)) as env:
        env.slaves[5].address_out = 6
        drive = env.master.drive(5)
        with pytest.raises(UssTimeout):
            await drive.read(52, timeout=0.3)
        diag = drive.diagnostics()
    assert diag.wrong_address >= 1
    assert diag.answers == 0
    assert drive.not_sending


async def test_a_slaves_counts_are_those_of_its_diagnostics() -> None:
    # `Drive.counts` (what the drive model reads at every answer) tells the same counters,
    # exchanges, answers and timeouts as the full diagnostics, answered or silent.
    async with scripted_bus((5,)) as env:
        drive = env.master.drive(5)
        silent = env.master.drive(7)
        await drive.read(52)
        await eventually(lambda: silent.not_sending)
        for handle in (drive, silent):
            # no await in between: the master does not run (the rates per minute aside,
            # which a second's turn between the two may change)
            counts, diag = handle.counts(), handle.diagnostics()
            assert _totals(counts.counters) == _totals(diag.counters)
            assert (counts.exchanges, counts.answers, counts.timeouts) == (
                diag.exchanges,
                diag.answers,
                diag.timeouts,
            )
        assert drive.counts().answers >= 1 and silent.counts().timeouts >= 1


def _totals(counters: Counters) -> Counters:
    return dataclasses.replace(counters, good_per_minute=0, discarded_per_minute=0)


async def test_garbled_answers_are_faults_and_the_job_is_repeated() -> None:
    # Flip bits in two answers of the slave: the receiver discards them (parity/BCC).
    plan = FaultPlan([Fault("flip", station="slave5", nth=n) for n in (40, 61)])
    async with scripted_bus((5,), faults=plan) as env:
        drive = env.master.drive(5)
        for _ in range(4):
            assert await drive.read(52) == 0x4000
        diag = drive.diagnostics()
    assert diag.counters.discarded >= 1
    assert diag.counters.parity + diag.counters.bcc >= 1
    assert diag.jobs.completed == 4


async def test_broadcast_is_not_answered_and_reaches_every_slave() -> None:
    async with scripted_bus((1, 2), layout=Layout(4, 2)) as env:
        env.master.drive(1)
        env.master.drive(2)
        bea = BroadcastEnableArray.from_selection(words=[2])
        answered = await env.master.broadcast([0, 0x2000], pkw=bea.to_pkw_words())
        assert answered == 0
        assert all(len(s.broadcasts) == 1 for s in env.slaves.values())
        telegram = env.slaves[1].broadcasts[0]
        assert telegram.mode is AddressMode.BROADCAST
        assert telegram.data[:8] == bytes.fromhex("0005000000000000")
        # A slave that answers a broadcast breaks A 3: the master counts it.
        env.slaves[2].answer_broadcast = True
        assert await env.master.broadcast([0, 0x2000], pkw=bea.to_pkw_words()) == 1
        assert env.master.diagnostics().answered_broadcasts == 1


async def test_mirror_telegram_comes_back_unchanged() -> None:
    async with scripted_bus((7,), record=True) as env:
        drive = env.master.drive(7)
        result = await drive.mirror()
        assert result.address == 7
        assert result.sent[2] == 0x47  # ADR bit 6: mirror (A 4.3)
        assert len(result.sent) == 14  # the slave's fixed length, so it accepts it
        with pytest.raises(NotSending):
            await env.master.mirror(9)


async def test_mirror_mismatch_is_reported() -> None:
    async with scripted_bus((7,)) as env:
        env.master.drive(7)
        original = env.slaves[7]._handle

        def corrupt(telegram):  # type: ignore[no-untyped-def]
            answer = original(telegram)
            if telegram.mode is AddressMode.MIRROR and answer is not None:
                data = bytearray(answer.data)
                data[-1] ^= 0x01
                return type(answer)(answer.address, answer.mode, bytes(data))
            return answer

        env.slaves[7]._handle = corrupt  # type: ignore[method-assign]
        with pytest.raises(MirrorMismatch, match="came back changed"):
            await env.master.mirror(7)


async def test_acyclic_mode_sends_only_on_demand() -> None:
    async with scripted_bus((3,), mode=ACYCLIC) as env:
        drive = env.master.drive(3)
        await asyncio.sleep(0.1)
        assert env.slaves[3].log.requests == []
        assert await drive.read(52) == 0x4000
        count = len(env.slaves[3].log.requests)
        await asyncio.sleep(0.1)
        assert len(env.slaves[3].log.requests) == count
        status = await env.master.exchange(3)
        assert status.word == 0x0231
        assert len(env.slaves[3].log.requests) == count + 1


async def test_master_validates_its_arguments() -> None:
    bus = VirtualBus(9600)
    with pytest.raises(ConfigError, match="baud 19200"):
        Master(bus.attach("a"), baud=19200)
    with pytest.raises(ConfigError, match="cycle time"):
        Master(bus.attach("b"), cycle_time=0)
    for n, endless in enumerate((1e300, math.inf, 61)):  # no drive would hear a telegram so long
        with pytest.raises(ConfigError, match="at most 60"):
            Master(bus.attach(f"b{n}"), cycle_time=endless)
    master = Master(bus.attach("c"))
    with pytest.raises(ConfigError, match="address"):
        master.drive(32)
    drive = master.drive(4, layout="3,2")
    assert master.drive(4) is drive
    with pytest.raises(ConfigError, match="layout"):
        master.drive(4, layout=Layout(4, 2))
    with pytest.raises(Exception, match="not started"):
        await drive.read(1)


async def test_the_master_keeps_at_least_the_spec_start_pause_with_a_coarse_tolerance() -> None:
    bus = VirtualBus(9600)
    slave = await ScriptedSlave(bus, 1, Layout(3, 2)).start()
    master = Master(bus.attach("master"), layout=Layout(3, 2), rx_tolerance=0.02)
    async with master:
        assert master.core.receiver.gap == pytest.approx(0.02)
        assert await master.drive(1).read(52) == 0x4000
    await slave.stop()
    await bus.close()
    assert char_time(9600) * 2 < 0.02


async def test_acyclic_process_data_are_repeated_until_answered() -> None:
    async with scripted_bus((3,), mode=ACYCLIC) as env:
        drive = env.master.drive(3)
        env.slaves[3].silent = True
        sending = asyncio.create_task(drive.control_word(0x047E, timeout=5))
        await eventually(lambda: len(env.slaves[3].log.requests) >= 2)
        env.slaves[3].silent = False
        status = await sending
        assert status.control == 0x047E
        count = len(env.slaves[3].log.requests)
        await asyncio.sleep(0.1)
        assert len(env.slaves[3].log.requests) == count  # nothing more to send


async def test_does_not_send_is_cleared_only_by_a_good_telegram() -> None:
    # Slave 2 is silent first, then its first three answers are garbled on the line (a
    # parity error in one character each, counted from its first character sent).
    plan = FaultPlan([Fault("parity", station="slave2", nth=n) for n in (3, 17, 31)])
    async with scripted_bus((1, 2), faults=plan) as env:
        env.slaves[2].silent = True
        one, two = env.master.drive(1), env.master.drive(2)
        await eventually(lambda: two.not_sending)
        seen: list[bool] = []  # the mark as each further request reaches slave 2
        env.slaves[2].on_request = lambda _: seen.append(two.not_sending)
        env.slaves[2].silent = False
        await eventually(lambda: not two.not_sending)
        await eventually(lambda: len(seen) >= 6)
        diag = two.diagnostics()
    # set through the three garbled answers, cleared by the fourth, good one (A 5.2.1.1)
    assert seen[:5] == [True, True, True, True, False]
    assert diag.counters.parity >= 3 and diag.answers >= 1
    assert not one.not_sending


async def test_a_pause_without_a_poll_list_is_not_counted_as_a_cycle() -> None:
    async with scripted_bus((1,), cycle_time=0.02) as env:
        drive = env.master.drive(1, poll=False)
        seen: list[tuple[int, int]] = []  # (cycles done, cycle times measured) at each answer

        def count(_: object) -> None:
            stats = env.master.cycle_stats()
            seen.append((stats.cycles, stats.achieved.count))

        drive.on_update(count)
        env.master.set_poll_list([1])
        await eventually(lambda: len(seen) >= 3)
        # one answer per cycle, inside it: every cycle but the first has its time measured
        assert all(done == measured for done, measured in seen)
        env.master.set_poll_list([])
        await asyncio.sleep(0.1)
        env.master.set_poll_list([1])
        before = len(seen)
        await eventually(lambda: len(seen) >= before + 3)
    # the time without a poll list was not taken for one long cycle (A 5.1.1)
    assert all(done == measured + 1 for done, measured in seen[before:])


async def test_a_task_cancelled_as_its_update_arrives_is_cancelled() -> None:
    # A task following the drive (next_update in a loop, as `uss run` does) is cancelled in
    # the very step in which its update arrives: the cancellation must win, or the task goes
    # on calling into the master after its owner stopped it.
    async with scripted_bus() as setup:
        drive = setup.master.drive(5)
        follower = asyncio.create_task(drive.next_update(timeout=5))
        await asyncio.sleep(0)  # the follower waits for its update
        drive.on_update(lambda status: follower.cancel())  # runs as the update is delivered
        with pytest.raises(asyncio.CancelledError):
            await follower
