"""Timed sends: a station hands over a telegram with the moment it is to start, in-process
(`Station.write_at`) or over ``bus://`` (send frames), and the bus starts it then - never
before it received it, never before the station's own characters have left the line."""

from __future__ import annotations

import asyncio
import json
import time

import pytest

from pyuss.bus import BusClientTransport, VirtualBus, WireChar
from pyuss.bus.timed import is_station, timed_writer
from pyuss.bus.wire import MAX_AHEAD, SendDecoder, encode_send
from pyuss.errors import ProtocolError
from pyuss.transport import PtyPort

BAUD = 19200
TC = 11 / BAUD
DATA = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")


def test_send_frames_decode_as_encoded_in_any_pieces() -> None:
    stream = encode_send(12.5, DATA) + encode_send(0.0, b"\x01")
    for cut in range(len(stream) + 1):
        decoder = SendDecoder()
        out = decoder.feed(stream[:cut]) + decoder.feed(stream[cut:])
        assert out == [(12.5, DATA), (0.0, b"\x01")]
    with pytest.raises(ProtocolError, match="not a number"):
        SendDecoder().feed(encode_send(float("nan"), DATA))


async def _first_chars(bus: VirtualBus, sender: str, n: int) -> list[WireChar]:
    seen: list[WireChar] = []
    bus.on_char.append(seen.append)
    for _ in range(500):
        mine = [c for c in seen if c.sender == sender]
        if len(mine) >= n:
            return mine
        await asyncio.sleep(0.01)
    raise AssertionError("the characters did not come")


async def test_an_in_process_station_starts_at_the_moment_given() -> None:
    bus = VirtualBus(BAUD)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        assert timed_writer(master) is not None and is_station(master)
        start = time.monotonic() + 0.05
        chars = asyncio.ensure_future(_first_chars(bus, "master", len(DATA)))
        await master.write_at(DATA, start)
        got = await chars
        assert got[0].start == start
        assert got[-1].end == pytest.approx(start + len(DATA) * TC)
        # behind its own characters: a second timed send asking for less starts after them
        chars = asyncio.ensure_future(_first_chars(bus, "slave", 2 * len(DATA)))
        later = time.monotonic() + 0.02
        await slave.write_at(DATA, later)
        await slave.write_at(DATA, later)
        got = await chars
        assert got[len(DATA)].start == pytest.approx(later + len(DATA) * TC)
        # a moment already past: at once, when the bus has it
        before = time.monotonic()
        chars = asyncio.ensure_future(_first_chars(bus, "master", len(DATA)))
        await master.write_at(DATA, before - 1.0)
        got = await chars
        assert got[0].start >= before
    await bus.close()


async def test_a_bus_client_sends_timed_over_the_wire() -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    async with BusClientTransport(host, port, baud=BAUD, name="m") as master:
        assert master.timed and is_station(master)
        start = time.monotonic() + 0.05
        chars = asyncio.ensure_future(_first_chars(bus, "m", len(DATA)))
        await master.write_at(DATA, start)
        got = await chars
        assert got[0].start == start
        assert bytes(c.byte for c in got) == DATA
    await bus.close()


async def test_a_send_frame_too_far_ahead_ends_the_station() -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    reader, writer = await asyncio.open_connection(host, port)
    writer.write(json.dumps({"name": "far", "timed": True}).encode() + b"\n")
    answer = json.loads(await reader.readline())
    assert answer["ok"] and answer["timed"] is True
    writer.write(encode_send(time.monotonic() + MAX_AHEAD + 5, DATA))
    async with asyncio.timeout(5):
        assert await reader.read() == b""  # the bus closed the connection
    assert "far" not in bus.stations
    assert bus.stats.chars == 0
    writer.close()
    await bus.close()


async def test_a_station_that_does_not_ask_sends_raw_bytes() -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    reader, writer = await asyncio.open_connection(host, port)
    writer.write(json.dumps({"name": "old"}).encode() + b"\n")
    answer = json.loads(await reader.readline())
    assert answer["ok"] and answer["timed"] is False
    chars = asyncio.ensure_future(_first_chars(bus, "old", len(DATA)))
    writer.write(DATA)  # raw, as before
    assert bytes(c.byte for c in await chars) == DATA
    writer.close()
    await bus.close()


def test_other_transports_are_no_stations() -> None:
    pty = PtyPort(baud=BAUD)
    assert not is_station(pty) and timed_writer(pty) is None


async def test_a_send_frame_without_characters_holds_nothing_back() -> None:
    """A send frame with no characters (from a station that did not ask for ``hold_answer``:
    there it is no answer hold) puts nothing on the line and does not move the station's
    next telegram to the moment it named: nothing was sent that the telegram must wait for."""
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    reader, writer = await asyncio.open_connection(host, port)
    writer.write(json.dumps({"name": "m", "timed": True, "hold": True}).encode() + b"\n")
    answer = json.loads(await reader.readline())
    assert answer["ok"] and answer["hold_answer"] is False
    ahead = time.monotonic() + MAX_AHEAD - 0.01
    chars = asyncio.ensure_future(_first_chars(bus, "m", len(DATA)))
    writer.write(encode_send(ahead, b"") + encode_send(0.0, DATA))
    got = await chars
    assert bytes(c.byte for c in got) == DATA
    assert got[0].start < ahead  # at once, not when the empty frame said
    async with bus.attach("local") as local:  # the same in-process
        ahead = time.monotonic() + MAX_AHEAD
        chars = asyncio.ensure_future(_first_chars(bus, "local", len(DATA)))
        await local.write_at(b"", ahead)
        await local.write(DATA)
        assert (await chars)[0].start < ahead
    assert bus.stats.chars == 2 * len(DATA)
    writer.close()
    await bus.close()
