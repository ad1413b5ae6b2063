"""Each fault the bus injects, and what the receiver of the protocol core reports for it
(A 5.2.2: parity, framing, LGE, BCC, residual time, no answer)."""

from __future__ import annotations

import pytest

from pyuss.bus import Fault, FaultKind, FaultPlan, VirtualBus
from pyuss.protocol.diagnostics import FaultKind as ReceiveKind
from pyuss.protocol.receiver import Event, Received, Receiver
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.transport.base import Chunk
from transport.helpers import read_bytes

BAUD = 38400
TC = 11 / BAUD
# C 8.1 example 2: PKW 3 words, PZD 2 words to slave 5 (14 bytes, LGE 12, n = 10).
REQUEST = Telegram(5, AddressMode.NORMAL, bytes.fromhex("1034 0000 0000 047E 0000"))
RESPONSE = Telegram(5, AddressMode.NORMAL, bytes.fromhex("1034 0000 4000 0231 0000"))


def _events(chunks: list[Chunk]) -> list[Event]:
    receiver = Receiver(BAUD)
    events: list[Event] = []
    for chunk in chunks:
        events += receiver.feed(chunk.data, chunk.timestamp, chunk.errors)
    if chunks:
        events += receiver.poll(chunks[-1].timestamp + 1.0)
    return events


async def _slave_hears(*faults: Fault, seed: int = 0) -> list[Event]:
    bus = VirtualBus(BAUD, faults=FaultPlan(faults), seed=seed)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(REQUEST.encode())
        await bus.drain()
        chunks = await read_bytes(slave, 15, timeout=0.2)
    await bus.close()
    return _events(chunks)


def _kinds(events: list[Event]) -> list[ReceiveKind | str]:
    return ["ok" if isinstance(e, Received) else e.kind for e in events]


async def test_clean_line_gives_the_telegram() -> None:
    events = await _slave_hears()
    assert _kinds(events) == ["ok"]
    assert isinstance(events[0], Received) and events[0].telegram == REQUEST


async def test_single_bit_flip_is_reported_as_parity_error() -> None:
    assert _kinds(await _slave_hears(Fault(FaultKind.FLIP, nth=6))) == [ReceiveKind.PARITY]


async def test_double_bit_flip_in_net_data_is_reported_as_bcc_error() -> None:
    assert _kinds(await _slave_hears(Fault(FaultKind.FLIP, nth=6, bits=2))) == [ReceiveKind.BCC]


async def test_parity_fault_is_reported_as_parity_error() -> None:
    assert _kinds(await _slave_hears(Fault(FaultKind.PARITY, nth=14))) == [ReceiveKind.PARITY]


async def test_framing_fault_is_reported_as_framing_error() -> None:
    assert _kinds(await _slave_hears(Fault(FaultKind.FRAMING, nth=3))) == [ReceiveKind.FRAMING]


async def test_dropped_character_leaves_the_telegram_short_residual_time() -> None:
    events = await _slave_hears(Fault(FaultKind.DROP, nth=8))
    assert _kinds(events) == [ReceiveKind.RESIDUAL_TIME]
    assert len(events[0].raw) == 13


async def test_inserted_character_breaks_the_bcc_and_leaves_a_byte_over() -> None:
    events = await _slave_hears(Fault(FaultKind.INSERT, nth=6, byte=0x11))
    assert _kinds(events) == [ReceiveKind.BCC, ReceiveKind.NO_STX]
    assert len(events[0].raw) == 14 and len(events[1].raw) == 1


async def test_inserted_character_in_lge_is_a_bad_length() -> None:
    # 0xFF after STX is taken as LGE: out of 2..254 (A 4.2).
    events = await _slave_hears(Fault(FaultKind.INSERT, nth=1, byte=0xFF))
    assert _kinds(events) == [ReceiveKind.BAD_LGE]


async def test_gap_of_a_start_pause_inside_a_telegram_cuts_it() -> None:
    # 3 character times of silence after byte 7: the receiver takes it as a start pause
    # (A 5.1.2), so the first part is incomplete and the rest starts without STX.
    events = await _slave_hears(Fault(FaultKind.STRETCH, nth=8, gap=3))
    assert _kinds(events) == [ReceiveKind.RESIDUAL_TIME, ReceiveKind.NO_STX]
    assert [len(e.raw) for e in events] == [7, 7]


async def test_short_gaps_within_the_residual_time_are_fine() -> None:
    # A 6.3: the gaps may add up to half the flush residual time, (n + 3) / 2 = 6.5 here.
    events = await _slave_hears(Fault(FaultKind.STRETCH, gap=1.5, count=4))
    assert _kinds(events) == ["ok"]


async def test_gaps_beyond_the_residual_time_are_reported() -> None:
    # Gaps of 1.9 character times before characters 1..5: 4 inside the telegram, 7.6 > 6.5.
    events = await _slave_hears(Fault(FaultKind.STRETCH, gap=1.9, count=5))
    assert _kinds(events) == [ReceiveKind.RESIDUAL_TIME]


async def test_collision_is_reported_as_line_errors() -> None:
    bus = VirtualBus(BAUD)
    async with bus.attach("slave") as slave:
        # Both telegrams put on the line at explicit times, the second a third of a character
        # behind the first, so the overlap does not depend on how fast the test process runs.
        tc = 11 / BAUD
        start = slave.clock() + 0.01
        for i, byte in enumerate(REQUEST.encode()):
            bus.inject("master", start + i * tc, byte)
        for i, byte in enumerate(RESPONSE.encode()):
            bus.inject("other", start + (i + 1 / 3) * tc, byte)
        await bus.drain()
        chunks = await read_bytes(slave, 14, timeout=0.5)
    await bus.close()
    kinds = _kinds(_events(chunks))
    assert bus.stats.collisions == 1
    assert kinds and all(k in (ReceiveKind.PARITY, ReceiveKind.FRAMING) for k in kinds)


@pytest.mark.parametrize(("kind", "master_gets"), [(FaultKind.DEAF, ["ok"]), (FaultKind.DEAD, [])])
async def test_deaf_or_dead_slave(kind: FaultKind, master_gets: list[str]) -> None:
    # Deaf: the slave's receiver gets nothing, yet what it sends reaches the master. Dead:
    # nothing either way, so the master has nothing to receive: its "station x does not
    # send" (A 5.2.1.1).
    bus = VirtualBus(BAUD, faults=FaultPlan([Fault(kind, station="slave")]))
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(REQUEST.encode())
        await bus.drain()
        heard = await read_bytes(slave, 14, timeout=0.2)
        await slave.write(RESPONSE.encode())
        await bus.drain()
        answer = await read_bytes(master, 14, timeout=0.2)
    await bus.close()
    assert _events(heard) == []
    assert _kinds(_events(answer)) == master_gets


async def test_delayed_answer_shows_in_the_response_delay() -> None:
    delay = 0.025  # beyond the 20 ms of A 5.2.1.1
    bus = VirtualBus(
        BAUD, faults=FaultPlan([Fault(FaultKind.DELAY, station="slave", seconds=delay)])
    )
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(REQUEST.encode())
        request = _events(await read_bytes(slave, 14))
        await slave.write(RESPONSE.encode())
        answer = _events(await read_bytes(master, 14))
    await bus.close()
    assert isinstance(request[0], Received) and isinstance(answer[0], Received)
    assert answer[0].telegram == RESPONSE
    response_delay = answer[0].start - request[0].end
    assert response_delay >= delay
