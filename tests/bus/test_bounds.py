"""One station cannot grow the bus or jam its line, and idle raw connections cannot lock
``bus://`` stations out: real TCP sockets on 127.0.0.1, the bus's own queue sizes."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import socket
import time
from collections.abc import Callable

import pytest

from pyuss.bus import BusClientTransport, VirtualBus, core, serve
from pyuss.bus.core import EVICT_IDLE, MAX_QUEUE, MAX_SENDERS
from pyuss.bus.wire import read_hello
from pyuss.errors import ConfigError
from support.waiting import eventually
from transport.helpers import WAIT, joined, read_bytes

BAUD = 9600


def _most_queued(bus: VirtualBus) -> Callable[[], int]:
    """The most characters the bus has had waiting since this call, watched at every
    character it puts on the line."""
    most = 0

    def watch(_char: object) -> None:
        nonlocal most
        most = max(most, bus.queued())

    bus.on_char.append(watch)
    return lambda: most


async def _send_and_leave(port: int, size: int) -> None:
    """A raw TCP station (pyserial socket://, tcp://) that writes ``size`` bytes and leaves."""
    loop = asyncio.get_running_loop()
    with socket.create_connection(("127.0.0.1", port)) as sock:
        sock.setblocking(False)
        await loop.sock_sendall(sock, bytes(size))


@pytest.mark.parametrize("size", [64 * 1024, 1024 * 1024], ids=["64 KiB", "1 MiB"])
async def test_a_flooding_station_is_bounded_and_its_rest_dropped_when_it_leaves(
    size: int,
) -> None:
    bus = VirtualBus(BAUD)
    try:
        _, raw_port = await bus.serve_tcp("127.0.0.1", 0)
        host, port = await bus.serve_tcp("127.0.0.1", 0, framed=True)
        most = _most_queued(bus)
        stats = bus.stats
        await _send_and_leave(raw_port, size)
        await eventually(
            lambda: stats.overflow + stats.unsent + stats.chars + bus.queued() == size,
            WAIT,
            what="every byte was taken, dropped or sent",
        )
        await eventually(lambda: stats.unsent, WAIT, what="the station left")
        assert most() <= MAX_QUEUE
        assert stats.overflow >= size - MAX_QUEUE - stats.chars  # room freed as chars went out
        # at most what had begun on the wire as it left: a character or two, a few more
        # where a loaded machine's bus runs late (their start times passed all the same)
        assert bus.queued() <= 16
        # the line is free at once: two bus:// stations talk as if nothing had happened
        async with (
            BusClientTransport(host, port, baud=BAUD, name="master") as master,
            BusClientTransport(host, port, baud=BAUD, name="drive") as drive,
        ):
            await master.write(b"\x02\x06\x05\x10\x34\x00\x00\x27")
            got = joined(await read_bytes(drive, 8, timeout=WAIT))
        assert got == b"\x02\x06\x05\x10\x34\x00\x00\x27"
    finally:
        await bus.close()


async def test_a_station_that_leaves_takes_its_unsent_characters_along() -> None:
    bus = VirtualBus(BAUD)
    try:
        chatty = bus.attach("chatty")
        await chatty.open()
        began = time.monotonic()
        await chatty.write(bytes(1000))
        assert bus.queued("chatty") == 1000
        await chatty.close()
        started = (time.monotonic() - began) / bus.char_time + 1  # went on the wire meanwhile
        assert bus.queued() <= started
        assert bus.stats.unsent >= 1000 - started
    finally:
        await bus.close()


async def test_idle_raw_connections_never_lock_a_bus_master_out() -> None:
    """32 raw TCP connections take every sending place (B 1); a bus:// master that comes
    later gets the place of the raw station silent longest."""
    bus = VirtualBus(BAUD)
    idle: list[socket.socket] = []
    try:
        _, raw_port = await bus.serve_tcp("127.0.0.1", 0)
        host, port = await bus.serve_tcp("127.0.0.1", 0, framed=True)
        idle = [socket.create_connection(("127.0.0.1", raw_port)) for _ in range(MAX_SENDERS)]
        await eventually(
            lambda: len(bus.stations) == MAX_SENDERS, WAIT, what="every raw station attached"
        )
        await asyncio.sleep(EVICT_IDLE + 0.1)  # they stay silent
        async with BusClientTransport(host, port, baud=BAUD, name="master") as master:
            assert master.name == "master"
            assert "master" in bus.stations
        assert bus.stats.evicted == 1
        assert len([n for n in bus.stations if n.startswith("tcp")]) == MAX_SENDERS - 1
        idle[0].settimeout(WAIT)
        assert idle[0].recv(16) == b""  # tcp1, the first silent, was disconnected
    finally:
        for sock in idle:
            sock.close()
        await bus.close()


async def test_only_idle_evictable_stations_give_their_place() -> None:
    bus = VirtualBus(BAUD)
    evicted: list[str] = []
    for i in range(MAX_SENDERS):
        station = bus.attach(f"s{i}")
        if i >= 30:  # two anonymous ones, which may give their place

            def evict(name: str = f"s{i}") -> None:
                evicted.append(name)

            station.evict = evict
            bus.send(station.name, b"\x00")  # they speak
    with pytest.raises(ConfigError, match="32 sending stations"):
        bus.attach("new")  # they just sent: not idle
    bus.stations["s31"].last_active -= EVICT_IDLE
    bus.stations["s30"].last_active -= 2 * EVICT_IDLE
    bus.attach("new")  # the one silent longest goes first
    assert evicted == ["s30"]
    bus.attach("newer")
    assert evicted == ["s30", "s31"]
    with pytest.raises(ConfigError, match="32 sending stations"):
        bus.attach("newest")  # no evictable station left: the others are not anonymous
    assert bus.stats.evicted == 2
    await bus.close()


async def test_new_stations_do_not_push_out_a_raw_station_that_talks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Raw connections that come again and again take the places of those that have said
    nothing since they connected, first come first out; a raw master that polls keeps its
    place (one that has spoken gives it only after `EVICT_IDLE` seconds of silence, made long
    here), and when no silent one is left the newcomer is turned away."""
    monkeypatch.setattr(core, "EVICT_IDLE", 3600.0)
    bus = VirtualBus(BAUD)
    evicted: list[str] = []

    def anonymous(name: str) -> None:
        bus.attach(name).evict = lambda: evicted.append(name)

    anonymous("poller")
    bus.send("poller", b"\x02")
    for i in range(MAX_SENDERS - 1):
        anonymous(f"silent{i}")
    for i in range(3):
        anonymous(f"new{i}")  # each takes the place of the silent one that came first
    assert evicted == ["silent0", "silent1", "silent2"] and "poller" in bus.stations
    bus.send("new0", b"\x02")  # it speaks: it keeps its place too
    for name in [n for n in bus.stations if n != "poller" and n != "new0"]:
        bus.send(name, b"\x02")
    with pytest.raises(ConfigError, match="32 sending stations"):
        anonymous("one-more")
    assert "poller" in bus.stations and bus.stats.evicted == 3
    await bus.close()


async def test_an_evicted_raw_station_puts_nothing_more_on_the_line() -> None:
    """A connection closed to make room must not put late bytes on the line."""
    bus = VirtualBus(BAUD)
    try:
        _, raw_port = await bus.serve_tcp("127.0.0.1", 0)
        with socket.create_connection(("127.0.0.1", raw_port)) as sock:
            await eventually(lambda: "tcp1" in bus.stations, WAIT, what="attached")
            station = bus.stations["tcp1"]
            assert station.evict is not None
            station.evict()
            bus.detach("tcp1", station)
            with contextlib.suppress(OSError):
                for _ in range(20):
                    sock.sendall(bytes(100))
                    await asyncio.sleep(0.01)
        await asyncio.sleep(0.1)
        assert bus.stats.chars == 0
        assert bus.queued() == 0
    finally:
        await bus.close()


async def _hello(port: int, line: bytes) -> tuple[dict[str, object], bytes]:
    """Send ``line`` as a bus:// hello; the bus's answer and what follows until it closes."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        writer.write(line)
        await writer.drain()
        async with asyncio.timeout(WAIT):
            answer = json.loads(await reader.readline())
            rest = await reader.read() if not answer.get("ok") else b""
    finally:
        writer.close()
    return answer, rest


@pytest.mark.parametrize(
    ("line", "named"),
    [
        (b"[" * 3000 + b"\n", "nested"),
        (b"[" * 1500 + b"]" * 1500 + b"\n", "nested"),  # valid JSON: Python 3.13 parses it
        (b'{"name": "m", "x": [[1]]}\n', "nested"),
        (b"{" + b" " * 70000, "line end"),  # a line never ended
        (b'{"name": "m", "echo": "false"}\n', "echo"),
        (b'{"name": "m", "listen_only": "no"}\n', "listen_only"),
        (b'{"name": "m", "timed": 1, "hold": true}\n', "timed"),
        (b'{"name": 123}\n', "name"),
        (b'{"name": ["m"]}\n', "name"),
        (b'{"name": "' + b"n" * 10000 + b'"}\n', "at most"),
        (b'{"name": "a\\nb"}\n', "printable"),
        (b'{"name": ""}\n', "name"),
        (b'["name", "m"]\n', "JSON object"),
        (b'{"name": "m"', "cut off"),  # cut off: the peer left in the middle of its hello
    ],
    ids=[
        "nested",
        "nested-closed",
        "nested-in-object",
        "never-ended",
        "echo-string",
        "listen-only-string",
        "timed-number",
        "name-number",
        "name-list",
        "name-10k",
        "name-newline",
        "name-empty",
        "not-an-object",
        "cut-off",
    ],
)
async def test_a_bad_hello_is_refused_naming_what_was_wrong(line: bytes, named: str) -> None:
    """A hello is checked whole: a value of the wrong type is refused, not read as something
    the station did not ask for ("false" is no echo), and nothing is attached."""
    bus = VirtualBus(BAUD)
    try:
        _, port = await bus.serve_tcp("127.0.0.1", 0, framed=True)
        if line.endswith(b"\n"):
            answer, rest = await _hello(port, line)
        else:  # the peer sends part of a hello and closes its side
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            writer.write(line)
            writer.write_eof()
            async with asyncio.timeout(WAIT):
                answer = json.loads(await reader.readline())
            writer.close()
            rest = b""
        assert answer["ok"] is False
        assert str(answer["error"]).startswith("bad hello")
        assert named in str(answer["error"])
        assert len(str(answer["error"])) < 200
        assert rest == b""  # and the bus closed the connection
        assert bus.stations == {}
        # a good hello after it is served
        good = {"name": "m", "echo": False, "timed": True, "hold": True, "future_key": [1]}
        answer, _ = await _hello(port, json.dumps(good).encode() + b"\n")
        assert answer["ok"] is True and answer["name"] == "m"
    finally:
        await bus.close()


async def test_a_station_that_does_not_read_loses_what_comes_next_and_is_told(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A bus:// monitor that never reads: once its socket holds `MAX_BACKLOG` bytes (made small
    here) it loses what comes next, counted, and the bus says so once - while a station that
    reads gets every character."""
    monkeypatch.setattr(serve, "MAX_BACKLOG", 1024)
    bus = VirtualBus(187500)
    loop = asyncio.get_running_loop()
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
    sock.setblocking(False)
    try:
        host, port = await bus.serve_tcp("127.0.0.1", 0, framed=True)
        await loop.sock_connect(sock, (host, port))
        await loop.sock_sendall(sock, b'{"name": "deaf", "listen_only": true}\n')
        await eventually(lambda: "deaf" in bus.stations, WAIT, what="the monitor attached")
        deaf = bus.stations["deaf"]
        sent = 0
        async with bus.attach("talker") as talker, bus.attach("ear") as ear:
            while not deaf.stats.dropped_out:
                await talker.write(bytes(MAX_QUEUE))
                sent += MAX_QUEUE
                assert len(joined(await read_bytes(ear, MAX_QUEUE, timeout=WAIT))) == MAX_QUEUE
                assert sent < 100 * MAX_QUEUE, "the socket never counted as full"
        warnings = [r for r in caplog.records if "deaf" in r.getMessage()]
        assert len(warnings) == 1 and "does not read" in warnings[0].getMessage()
    finally:
        sock.close()
        await bus.close()


async def test_connections_turned_away_one_after_another_are_logged_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A full bus whose raw stations all talk turns new raw connections away; a peer that
    connects again and again gets one warning in the log, not one per connection."""
    caplog.set_level(logging.DEBUG, logger="pyuss.bus.serve")
    bus = VirtualBus(BAUD)
    loop = asyncio.get_running_loop()
    talkers: list[socket.socket] = []
    try:
        _, raw_port = await bus.serve_tcp("127.0.0.1", 0)
        for _ in range(MAX_SENDERS):
            sock = socket.create_connection(("127.0.0.1", raw_port))
            sock.sendall(b"\x00")
            talkers.append(sock)
        await eventually(
            lambda: (
                len(bus.stations) == MAX_SENDERS and all(s.spoke for s in bus.stations.values())
            ),
            WAIT,
            what="every raw station spoke",
        )
        for _ in range(20):
            with socket.create_connection(("127.0.0.1", raw_port)) as sock:
                sock.setblocking(False)
                async with asyncio.timeout(WAIT):
                    assert await loop.sock_recv(sock, 1) == b""  # turned away
        turned = [r for r in caplog.records if "turned away" in r.getMessage()]
        assert len(turned) == 20
        assert [r.levelname for r in turned].count("WARNING") == 1
    finally:
        for sock in talkers:
            sock.close()
        await bus.close()


@pytest.mark.pty
async def test_a_program_that_floods_a_pty_and_leaves_costs_the_line_one_telegram_at_most() -> None:
    # The bus holds each pty open itself, so it cannot see a program that wrote 12 kB into
    # one and left: what waits of it is bounded by one telegram of the longest, 256
    # characters (0.3 s at 9600 baud), not 4096 (4.7 s)
    import tty

    bus = VirtualBus(BAUD)
    try:
        flooded, _other = await bus.serve_pty(2)
        most = _most_queued(bus)
        fd = os.open(flooded, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            tty.setraw(fd)
            data = bytes(12 * 1024)
            while data:
                try:
                    data = data[os.write(fd, data) :]
                except BlockingIOError:
                    await asyncio.sleep(0.01)  # the bus reads the pty
        finally:
            os.close(fd)
        stats = bus.stats
        await eventually(lambda: stats.overflow + stats.chars + bus.queued() >= 12 * 1024, WAIT)
        assert most() <= serve.PTY_QUEUE
        assert stats.overflow >= 12 * 1024 - serve.PTY_QUEUE - stats.chars
    finally:
        await bus.close()


def test_brackets_inside_a_name_are_no_nesting() -> None:
    """The nesting check reads JSON strings as strings: a name may hold brackets."""
    assert read_hello(b'{"name": "[[[{x}]]] \\"[["}\n').name == '[[[{x}]]] "[['
