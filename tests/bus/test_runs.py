"""How the bus hands a run of characters over: the first character when it ends, the rest
together near the end of the run, never a character before its end (docs/bus.md, "Timing
model"); to a station that holds runs (``bus://``), the first character and then the rest when
the run ends."""

from __future__ import annotations

import time

from pyuss.bus import BusClientTransport, VirtualBus
from pyuss.bus.core import HOLD_MAX, RUN_HOLD, WireChar
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
            joined_at = time.monotonic()
            late = bus.attach("late")
            await late.open()
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


async def test_a_station_made_deaf_in_the_middle_of_a_run_misses_the_rest_of_it() -> None:
    # A fault window is judged by the line's time: made deaf from the end of the fourth
    # character, the drive hears four characters, whenever the bus hands the rest over.
    bus = VirtualBus(187500)
    got: list[bytes] = []
    bus.attach("drive", sink=lambda data, _ts, _errors: got.append(data))

    def on_char(char: WireChar) -> None:
        if char.sender == "master" and bus.stats.chars == 4:
            bus.make_deaf("drive", 0.5, start=char.end)

    bus.on_char.append(on_char)
    try:
        async with bus.attach("master") as master:
            await master.write(bytes(range(1, 15)))
            await bus.drain(timeout=WAIT)
    finally:
        await bus.close()
    assert b"".join(got) == bytes([1, 2, 3, 4])


async def _held(baud: int, data: bytes, *, hold: bool = True) -> list[Delivery]:
    """What a ``bus://`` station (in another process as far as the bus knows: a TCP
    connection) got of ``data`` sent by an in-process station."""
    bus = VirtualBus(baud)
    got: list[Delivery] = []
    try:
        host, port = await bus.serve_tcp(framed=True)
        reader = BusClientTransport(host, port, baud=baud, name="reader", hold=hold)
        async with reader, bus.attach("master") as master:
            await master.write(data)
            received = 0
            while received < len(data):
                chunk = await reader.read(WAIT)
                assert chunk is not None
                got.append((chunk.data, chunk.timestamp, time.monotonic()))
                received += len(chunk.data)
    finally:
        await bus.close()
    assert b"".join(chunk for chunk, _, _ in got) == data
    return got


async def test_a_bus_station_is_handed_a_telegram_in_two_pieces() -> None:
    # A station in another process is woken up by every hand-over: it takes the first
    # character when it ends (a master sees an answer begin) and the rest when the
    # telegram ends, each piece stamped with its last character's end on the line.
    tc = 11 / 19200
    telegram = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")
    got = await _held(19200, telegram)
    assert len(got) == 2
    (head, head_end, head_at), (rest, last_end, _) = got
    # the head as soon as the loop hands it over: a character, or the few that ended by then
    assert len(head) < 5 and head_at < last_end - 5 * tc
    assert abs(last_end - head_end - len(rest) * tc) < 1e-6
    for _, timestamp, delivered in got:
        assert delivered >= timestamp
    # without holding, the bus hands the same telegram over in more pieces
    assert len(await _held(19200, telegram, hold=False)) > 2


async def test_a_held_run_is_handed_over_at_most_hold_max_characters_at_a_time() -> None:
    # A station that never stops sending keeps no listener waiting for the end of it: 600
    # characters take 35 ms at 187500 baud, and come in pieces of at most HOLD_MAX.
    got = await _held(187500, bytes(600))
    run_end = got[-1][1]
    assert got[0][2] < run_end - 200 * 11 / 187500
    assert all(len(chunk) <= HOLD_MAX for chunk, _, _ in got)
    assert len(got) >= 600 / HOLD_MAX
