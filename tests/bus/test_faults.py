"""Fault injection, on raw bytes: what each station receives, with its line error flags."""

from __future__ import annotations

import itertools
import math
import time

import pytest

from pyuss.bus import Fault, FaultKind, FaultPlan, Recorder, VirtualBus, parse_fault
from pyuss.bus.faults import FaultEngine
from pyuss.errors import ConfigError
from pyuss.transport.base import Chunk, LineError
from transport.helpers import byte_ends, flat_errors, joined, read_bytes

REQUEST = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")  # C 8.1 example 2
BAUD = 38400
TC = 11 / BAUD


async def _send(plan: FaultPlan, data: bytes = REQUEST, *, seed: int = 0) -> list[Chunk]:
    """The master sends ``data`` once; what the slave receives."""
    bus = VirtualBus(BAUD, faults=plan, seed=seed)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(data)
        await bus.drain()
        chunks = await read_bytes(slave, len(data) + 1, timeout=0.2)
    await bus.close()
    return chunks


async def test_single_bit_flip_is_a_parity_error() -> None:
    chunks = await _send(FaultPlan([Fault(FaultKind.FLIP, station="master", nth=3)]))
    got = joined(chunks)
    assert len(got) == len(REQUEST)
    assert (got[2] ^ REQUEST[2]).bit_count() == 1
    assert got[:2] + got[3:] == REQUEST[:2] + REQUEST[3:]
    assert flat_errors(chunks) == [(2, LineError.PARITY)]


async def test_double_bit_flip_passes_parity_unseen() -> None:
    chunks = await _send(FaultPlan([Fault(FaultKind.FLIP, nth=5, bits=2)]))
    got = joined(chunks)
    assert (got[4] ^ REQUEST[4]).bit_count() == 2
    assert flat_errors(chunks) == []  # only the BCC can tell (A 4.5)


@pytest.mark.parametrize(
    ("kind", "flag"), [(FaultKind.PARITY, LineError.PARITY), (FaultKind.FRAMING, LineError.FRAMING)]
)
async def test_parity_and_framing_errors_keep_the_byte(kind: FaultKind, flag: LineError) -> None:
    chunks = await _send(FaultPlan([Fault(kind, nth=14)]))
    assert joined(chunks) == REQUEST
    assert flat_errors(chunks) == [(13, flag)]


async def test_dropped_character_leaves_its_time_empty() -> None:
    chunks = await _send(FaultPlan([Fault(FaultKind.DROP, nth=3)]))
    assert joined(chunks) == REQUEST[:2] + REQUEST[3:]
    steps = [
        b - a for a, b in zip(byte_ends(chunks, BAUD), byte_ends(chunks, BAUD)[1:], strict=False)
    ]
    # One character time between byte ends, two across the hole.
    assert steps == pytest.approx([TC, 2 * TC] + [TC] * 10, abs=1e-9)


async def test_inserted_character_follows_the_selected_one() -> None:
    chunks = await _send(FaultPlan([Fault(FaultKind.INSERT, nth=2, byte=0xAA)]))
    assert joined(chunks) == REQUEST[:2] + b"\xaa" + REQUEST[2:]
    assert flat_errors(chunks) == []


async def test_stretched_gap_inside_a_telegram() -> None:
    chunks = await _send(FaultPlan([Fault(FaultKind.STRETCH, nth=4, gap=2.5)]))
    assert joined(chunks) == REQUEST
    ends = byte_ends(chunks, BAUD)
    steps = [b - a for a, b in itertools.pairwise(ends)]
    # An idle gap of 2.5 character times before the 4th byte, none elsewhere.
    assert steps == pytest.approx([TC, TC, 3.5 * TC] + [TC] * 10, abs=1e-9)
    # The receiver gets the bytes after the gap in a new chunk.
    assert any(c.data.startswith(REQUEST[3:4]) for c in chunks)


async def test_deaf_station_hears_nothing_in_its_window() -> None:
    plan = FaultPlan([Fault(FaultKind.DEAF, station="slave", at=0, duration=3600)])
    assert await _send(plan) == []


async def test_dead_station_neither_hears_nor_sends() -> None:
    plan = FaultPlan([Fault(FaultKind.DEAD, station="slave", duration=3600)])
    bus = VirtualBus(BAUD, faults=plan)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(REQUEST)
        await bus.drain()
        await slave.write(b"\x02\x02\x00\x00")
        await bus.drain()
        assert await slave.read(0.05) is None
        assert await master.read(0.05) is None
    await bus.close()
    assert bus.stats.lost == 4


async def test_window_in_the_future_does_not_apply_yet() -> None:
    plan = FaultPlan([Fault(FaultKind.DEAF, station="slave", at=3600)])
    assert joined(await _send(plan)) == REQUEST


def test_deaf_and_dead_windows_start_and_end() -> None:
    plan = FaultPlan(
        [
            Fault(FaultKind.DEAF, station="s1", at=2.0, duration=1.5),
            Fault(FaultKind.DEAD, station="s2", at=1.0, duration=0.5),
        ]
    )
    engine = FaultEngine(plan, seed=0)
    for t, s1_deaf, s2_deaf in [
        (0.0, False, False),
        (1.0, False, True),
        (1.49, False, True),
        (1.5, False, False),
        (2.0, True, False),
        (3.49, True, False),
        (3.5, False, False),
    ]:
        assert (engine.deaf("s1", t), engine.deaf("s2", t)) == (s1_deaf, s2_deaf), t
        assert not engine.dead("s1", t)  # deaf stations still send
        assert engine.dead("s2", t) == s2_deaf
        assert not engine.deaf("other", t)


async def test_extra_delay_before_a_stations_answer() -> None:
    plan = FaultPlan([Fault(FaultKind.DELAY, station="slave", seconds=0.03)])
    bus = VirtualBus(BAUD, faults=plan)
    recorder = Recorder().attach(bus)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(REQUEST)  # the master is not delayed
        await read_bytes(slave, len(REQUEST))
        before = time.monotonic()
        await slave.write(b"\x02\x02\x00\x00")
        after = time.monotonic()
        answer = await read_bytes(master, 4)
    await bus.close()
    assert joined(answer) == b"\x02\x02\x00\x00"
    first = next(r for r in recorder.records if r.sender == "slave")
    assert before + 0.03 <= first.start + bus.epoch <= after + 0.03
    assert recorder.records[0].start + bus.epoch < before
    assert bus.stats.faults["delay"] == 1


async def _record(seed: int) -> list[tuple[int, LineError, tuple[str, ...]]]:
    plan = FaultPlan(
        [
            Fault(FaultKind.FLIP, probability=0.1),
            Fault(FaultKind.DROP, probability=0.05),
            Fault(FaultKind.INSERT, probability=0.05),
        ]
    )
    bus = VirtualBus(187500, faults=plan, seed=seed)
    recorder = Recorder().attach(bus)
    async with bus.attach("master") as master:
        await master.write(bytes(range(200)))
        await bus.drain()
    await bus.close()
    return [(r.byte, r.flags, r.notes) for r in recorder.records]


async def test_same_seed_same_faults_other_seed_other_faults() -> None:
    first = await _record(7)
    assert first == await _record(7)
    assert first != await _record(8)
    assert any(notes for _, _, notes in first)


async def test_count_limits_how_often_a_rule_hits() -> None:
    plan = FaultPlan([Fault(FaultKind.PARITY, count=2)])
    chunks = await _send(plan)
    assert flat_errors(chunks) == [(0, LineError.PARITY), (1, LineError.PARITY)]


def test_fault_text_form() -> None:
    fault = parse_fault("flip:station=master,p=0.25,nth=3,count=1,at=1.5,for=2,bits=2")
    assert fault == Fault(
        FaultKind.FLIP,
        station="master",
        probability=0.25,
        nth=3,
        count=1,
        at=1.5,
        duration=2.0,
        bits=2,
    )
    assert parse_fault("insert:byte=0x55").byte == 0x55
    assert parse_fault("drop").duration == math.inf
    assert parse_fault("delay:station=s1,seconds=0.01").seconds == 0.01


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("melt", "fault kind 'melt'"),
        ("flip:p=2", "probability"),
        ("flip:p=x", "p='x'"),
        ("flip:colour=red", "'colour=red'"),
        ("flip:bits=9", "1..8"),
        ("deaf", "needs station"),
        ("delay:station=s1", "seconds"),
        ("flip:nth=0", "nth"),
        ("insert:byte=300", "0..255"),
        ("flip:at=nan", "finite at"),
        ("flip:at=inf", "finite at"),
        ("flip:for=nan", "for > 0"),
        ("stretch:gap=inf", "gap must be finite"),
        ("stretch:gap=nan", "gap must be finite"),
        ("delay:station=s1,seconds=inf", "seconds finite"),
        ("delay:station=s1,seconds=nan", "seconds finite"),
    ],
)
def test_bad_fault_text_names_the_problem(text: str, words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        parse_fault(text)
