"""How the bus hands a run of characters over: the first character when it ends, the rest
together near the end of the run, never a character before its end (docs/bus.md, "Timing
model"); to a station that holds runs (``bus://``), the first character and then the rest when
the run ends."""

from __future__ import annotations

import time

import pytest

from pyuss.bus import BusClientTransport, VirtualBus
from pyuss.bus.core import HOLD_MAX, WireChar
from pyuss.loop import run
from pyuss.master import Master
from pyuss.master.testing import simulated_drives
from pyuss.protocol.layout import Layout
from pyuss.transport.base import LineError, Transport
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
    # (a piece every RUN_HOLD on an idle machine; fewer where the process is woken late)
    assert len(got) >= 3


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
            await master.write(bytes(2000))  # 117 ms: a loaded machine joins in time
            while bus.queued() > 1800:
                await master.read(0.001)
            joined_at = time.monotonic()
            late = bus.attach("late")
            left = bus.queued()
            await late.open()
            await bus.drain(timeout=WAIT)
        heard_early = b""
        while (chunk := await early.read(0.05)) is not None:
            heard_early += chunk.data
        stamps, heard_late = [], 0
        while (chunk := await late.read(0.05)) is not None:
            stamps.append(chunk.timestamp - (len(chunk.data) - 1) * bus.char_time)
            heard_late += len(chunk.data)
        assert heard_early == bytes(2000)
        assert all(first_end > joined_at for first_end in stamps)
        assert heard_late <= left
        assert stamps or left < 10  # joined before the end of the run: heard the rest of it
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
            got = await _take(reader, data)
    finally:
        await bus.close()
    return got


async def _take(station: Transport, data: bytes) -> list[Delivery]:
    """The deliveries that bring ``station`` the characters ``data``."""
    got: list[Delivery] = []
    while sum(len(chunk) for chunk, _, _ in got) < len(data):
        chunk = await station.read(WAIT)
        assert chunk is not None
        got.append((chunk.data, chunk.timestamp, time.monotonic()))
    assert b"".join(chunk for chunk, _, _ in got) == data
    return got


async def test_a_holding_station_takes_a_runs_first_piece_at_once_and_the_rest_at_its_end() -> None:
    # The rule, as the bus hands characters over (sans scheduling): the first piece of a run
    # at once, the rest kept until the run ends and then given as one piece, stamped with
    # its last character's end; a piece after a gap starts a new run.
    tc = 11 / 19200
    bus = VirtualBus(19200)
    station = bus.attach("station", hold=True)
    async with station:
        station.hand(b"\x02", 0.0, tc, (), False)
        first = await station.read(WAIT)
        assert first is not None and (first.data, first.timestamp) == (b"\x02", tc)
        station.hand(b"\x0c\x05", tc, 3 * tc, (), False)
        station.hand(b"\x10\x34", 3 * tc, 5 * tc, (), False)
        station.hand(b"\x00", 5 * tc, 6 * tc, (), True)
        rest = await station.read(WAIT)
        assert rest is not None and (rest.data, rest.timestamp) == (b"\x0c\x05\x10\x34\x00", 6 * tc)
        station.hand(b"\x02", 10 * tc, 11 * tc, (), False)  # after a gap: a new run's head
        head = await station.read(WAIT)
        assert head is not None and (head.data, head.timestamp) == (b"\x02", 11 * tc)
    await bus.close()


async def test_a_bus_station_is_handed_a_telegram_in_two_pieces() -> None:
    # A station in another process is woken up by every hand-over: it takes the first
    # character when it ends (a master sees an answer begin) and the rest when the
    # telegram ends, each piece stamped with its last character's end on the line. (A loop
    # held up long enough hands the head over with more characters, or the telegram whole.)
    tc = 11 / 19200
    telegram = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")
    got = await _held(19200, telegram)
    assert 1 <= len(got) <= 2
    last_end = got[-1][1]
    if len(got) == 2:
        (_, head_end, _), (rest, _, _) = got
        assert abs(last_end - head_end - len(rest) * tc) < 1e-6
    for _, timestamp, delivered in got:
        assert delivered >= timestamp


async def test_a_held_run_is_handed_over_at_most_hold_max_characters_at_a_time() -> None:
    # A station that never stops sending keeps no listener waiting for the end of it: 600
    # characters take 35 ms at 187500 baud, and come in pieces of at most HOLD_MAX.
    got = await _held(187500, bytes(600))
    assert all(len(chunk) <= HOLD_MAX for chunk, _, _ in got)
    assert len(got) >= 600 / HOLD_MAX
    # each piece is stamped with its last character's end: the first long before the run's
    assert got[0][1] < got[-1][1] - 200 * 11 / 187500


async def _answer_to(baud: int, answer: bytes, hold_for: float) -> tuple[list[Delivery], float]:
    """What a ``bus://`` master got of ``answer``, sent by an in-process drive once the
    master's request was on the line, when the master asked for its answer by ``hold_for``
    seconds after it sent the request; and that moment."""
    bus = VirtualBus(baud)
    got: list[Delivery] = []
    try:
        host, port = await bus.serve_tcp(framed=True)
        master = BusClientTransport(host, port, baud=baud, name="master")
        async with master, bus.attach("drive") as drive:
            assert master.hold_answer
            hold_until = time.monotonic() + hold_for
            await master.write_at(b"\x02\x02\x00\x00", 0.0, hold_until)
            await _take(drive, b"\x02\x02\x00\x00")
            await drive.write(answer)
            got = await _take(master, answer)
    finally:
        await bus.close()
    return got, hold_until


async def test_a_master_is_handed_an_answer_that_ends_in_time_in_one_piece() -> None:
    # The answer ends long before the moment its first character was due at the latest:
    # the master's process is woken once for it, with every character's end time kept.
    answer = bytes(range(40))  # 23 ms
    got, _ = await _answer_to(19200, answer, 1.0)
    assert len(got) == 1
    _data, timestamp, delivered = got[0]
    assert delivered >= timestamp


async def test_an_answer_still_running_when_its_hold_ends_is_handed_its_first_part_then() -> None:
    # 100 characters at 19200 baud take 57 ms; the master takes the answer only if its
    # first character is in 15 ms after the request was sent: what there is of it comes
    # then, the rest when it ends.
    tc = 11 / 19200
    answer = bytes(range(100))
    got, hold_until = await _answer_to(19200, answer, 0.015)
    assert len(got) == 2
    (_first, first_end, first_at), (rest, rest_end, rest_at) = got
    assert hold_until - 0.001 <= first_at < rest_end
    assert rest_at >= rest_end
    assert rest_end - first_end == pytest.approx(len(rest) * tc)


async def test_a_master_late_for_its_start_pause_is_still_handed_each_answer_whole() -> None:
    # At 187500 baud the start pause is 117 us: a master that took longer over the last
    # answer sends its request at once, past the pause, and must still say by when it takes
    # the answer, or every answer wakes its process twice (its first character, the rest).
    baud = 187500
    bus = VirtualBus(baud)
    layout = Layout(4, 2)
    try:
        host, port = await bus.serve_tcp(framed=True)
        async with simulated_drives(bus, [(3, "generic", layout)]):
            station = BusClientTransport(host, port, baud=baud, name="master")
            async with Master(station, layout=layout) as master:
                drive = master.drive(3)
                await drive.read(52)
                answers, chunks = drive.counts().answers, station.stats.chunks_in
                for _ in range(50):
                    await drive.next_update()
                answers = drive.counts().answers - answers
                chunks = station.stats.chunks_in - chunks
    finally:
        await bus.close()
    assert answers >= 50
    assert chunks <= answers + 1, f"{chunks} hand-overs for {answers} answers"


async def test_a_late_hand_over_to_a_holding_station_still_comes_in_pieces_of_hold_max() -> None:
    # On a loaded machine the bus's timer may come so late that more than HOLD_MAX characters
    # ended meanwhile: a holding station still takes them at most HOLD_MAX at a time, each
    # piece stamped with the end of its own last character, the flags where they belong.
    bus = VirtualBus(187500)
    got: list[tuple[bytes, float, tuple[tuple[int, LineError], ...]]] = []
    station = bus.attach("reader", hold=True, sink=lambda *delivery: got.append(delivery))
    try:
        tc = bus.char_time
        data = bytes(range(256)) * 2 + bytes(88)  # 600 characters
        start = time.monotonic() - 600 * tc
        errors = ((300, LineError.PARITY),)
        station.hand(b"\x02", start - tc, start, (), False)  # the run's first character
        station.hand(data, start, start + 600 * tc, errors, True)
    finally:
        await bus.close()
    assert got[0][0] == b"\x02"
    pieces = got[1:]
    assert b"".join(piece for piece, _, _ in pieces) == data
    assert all(len(piece) <= HOLD_MAX for piece, _, _ in pieces)
    assert len(pieces) == 3
    end = start
    for piece, timestamp, _ in pieces:
        end += len(piece) * tc
        assert timestamp == pytest.approx(end, abs=1e-9)
    assert pieces[1][2] == ((300 - HOLD_MAX, LineError.PARITY),)
