"""How the bus hands a run of characters over: the first character when it ends, the rest
together near the end of the run, never a character before its end (docs/bus.md, "Timing
model")."""

from __future__ import annotations

import time

from pyuss.bus import VirtualBus
from pyuss.bus.core import RUN_HOLD
from pyuss.loop import run
from pyuss.transport.base import LineError
from transport.helpers import WAIT

Delivery = tuple[bytes, float, float]
"""What a station got: the characters, their chunk timestamp, when it got them."""


async def _deliveries(baud: int, data: bytes) -> list[Delivery]:
    bus = VirtualBus(baud)
    got: list[Delivery] = []

    def sink(chunk: bytes, timestamp: float, _errors: tuple[tuple[int, LineError], ...]) -> None:
        got.append((chunk, timestamp, time.monotonic()))

    bus.attach("drive", sink=sink)
    try:
        async with bus.attach("master") as master:
            await master.write(data)
            await bus.drain(timeout=WAIT)
    finally:
        await bus.close()
    assert b"".join(chunk for chunk, _, _ in got) == data
    return got


def test_a_telegram_is_handed_over_in_a_few_pieces_not_one_per_character() -> None:
    # 14 characters at 187500 baud: 0.8 ms on the wire. On the event loop every uss command
    # runs (microsecond timers), the receiving station is woken up at most three times (its
    # first character, all but the last few, the rest), not 7 to 14 times: that is what a
    # busy simulator saves on every telegram.
    telegram = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")
    got = run(_deliveries(187500, telegram))
    assert len(got) <= 3


async def test_a_station_sees_a_long_run_begin_before_it_ends() -> None:
    # 100 characters at 9600 baud take 115 ms: the first one is handed over long before the
    # last has ended, and pieces keep coming during the run (a master waiting for an answer
    # sees it start; a monitor shows it as it comes).
    tc = 11 / 9600
    got = await _deliveries(9600, bytes(range(100)))
    run_end = got[-1][1]
    assert got[0][2] < run_end - 50 * tc
    assert len(got) >= 100 * tc / (RUN_HOLD + 2 * tc)


async def test_no_character_is_handed_over_before_it_has_ended() -> None:
    for baud in (9600, 187500):
        for chunk, timestamp, delivered in await _deliveries(baud, bytes(range(40))):
            assert delivered >= timestamp, (baud, chunk)


async def test_a_station_that_attaches_hears_nothing_that_ended_before() -> None:
    # Characters held to be handed over with their run reach only stations that were on the
    # line while they were on it: a station that attaches later starts with a quiet line.
    bus = VirtualBus(187500)
    try:
        early = bus.attach("early")
        await early.open()
        async with bus.attach("master") as master:
            await master.write(bytes(200))  # 11.7 ms
            while bus.queued() > 150:
                await master.read(0.001)
            late = bus.attach("late")
            await late.open()
            joined_at = time.monotonic()
            await bus.drain(timeout=WAIT)
        heard_early = b""
        while (chunk := await early.read(0.05)) is not None:
            heard_early += chunk.data
        stamps = []
        while (chunk := await late.read(0.05)) is not None:
            stamps.append(chunk.timestamp - (len(chunk.data) - 1) * bus.char_time)
        assert heard_early == bytes(200)
        assert stamps and all(first_end > joined_at for first_end in stamps)
    finally:
        await bus.close()
