"""The same exchanges over every way of reaching the virtual bus: in-process stations, ptys
with pyserial on both ends, raw TCP on 127.0.0.1 (pyuss ``tcp://`` and pyserial
``socket://``), and ``bus://`` (framed TCP)."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import AsyncIterator
from dataclasses import dataclass

import pytest

from pyuss.bus import BusClientTransport, Fault, FaultKind, FaultPlan, VirtualBus
from pyuss.protocol.receiver import Event, Received, Receiver
from pyuss.protocol.telegram import Telegram
from pyuss.transport import SerialTransport, TcpTransport, Transport, open_transport
from pyuss.transport.base import Chunk, LineError
from support.paths import load_vectors
from transport.helpers import WAIT, byte_ends, flat_errors, joined, read_bytes

BAUD = 19200
MEDIA = ["inproc", pytest.param("pty", marks=pytest.mark.pty), "tcp", "socket", "bus"]


@dataclass
class Line:
    medium: str
    bus: VirtualBus
    master: Transport
    slave: Transport
    monitor: Transport


async def _wait_stations(bus: VirtualBus, n: int) -> None:
    for _ in range(int(WAIT / 0.01)):
        if len(bus.stations) >= n:
            return
        await asyncio.sleep(0.01)
    raise AssertionError(f"only {len(bus.stations)} stations attached")


async def _open_line(medium: str, bus: VirtualBus) -> tuple[Transport, Transport, Transport]:
    if medium == "inproc":
        return (
            bus.attach("master"),
            bus.attach("slave"),
            bus.attach("monitor", listen_only=True),
        )
    if medium == "pty":
        paths = await bus.serve_pty(3)
        return tuple(SerialTransport(p, baud=BAUD) for p in paths)  # type: ignore[return-value]
    if medium == "tcp":
        host, port = await bus.serve_tcp("127.0.0.1", 0)
        return tuple(TcpTransport(host, port, baud=BAUD) for _ in range(3))  # type: ignore[return-value]
    if medium == "socket":
        host, port = await bus.serve_tcp("127.0.0.1", 0)
        urls = [f"socket://{host}:{port}"] * 3
        return tuple(open_transport(url, baud=BAUD) for url in urls)  # type: ignore[return-value]
    host, port = await bus.serve_tcp("127.0.0.1", 0, framed=True)
    return (
        open_transport(f"bus://{host}:{port}?name=master", baud=BAUD),
        BusClientTransport(host, port, baud=BAUD, name="slave"),
        BusClientTransport(host, port, baud=BAUD, name="monitor", listen_only=True),
    )


@pytest.fixture(params=MEDIA)
async def line(request: pytest.FixtureRequest) -> AsyncIterator[Line]:
    medium: str = request.param
    bus = VirtualBus(BAUD, faults=getattr(request, "faults", None))
    master, slave, monitor = await _open_line(medium, bus)
    for transport in (master, slave, monitor):
        await transport.open()
    await _wait_stations(bus, 3)
    yield Line(medium, bus, master, slave, monitor)
    for transport in (master, slave, monitor):
        await transport.close()
    await bus.close()


def _vector_pairs() -> list[tuple[bytes, bytes]]:
    telegrams = load_vectors("uss")["telegrams"]
    pairs = []
    for request, response in itertools.pairwise(telegrams):
        if request["direction"] == "master->slave" and response["direction"] == "slave->master":
            pairs.append((bytes.fromhex(request["hex"]), bytes.fromhex(response["hex"])))
    return pairs


async def test_request_and_response(line: Line) -> None:
    pairs = _vector_pairs()
    assert pairs
    seen = b""
    for request, response in pairs:
        await line.master.write(request)
        assert joined(await read_bytes(line.slave, len(request))) == request
        await line.slave.write(response)
        assert joined(await read_bytes(line.master, len(response))) == response
        seen += request + response
    assert joined(await read_bytes(line.monitor, len(seen))) == seen
    assert await line.master.read(0.05) is None
    assert line.bus.stats.collisions == 0


async def test_longest_telegram_both_ways(line: Line) -> None:
    # LGE 254: 256 bytes on the wire (A 4.2).
    big = bytes([0x02, 0xFE]) + bytes(range(254))
    await line.master.write(big)
    assert joined(await read_bytes(line.slave, 256)) == big
    await line.slave.write(big[::-1])
    assert joined(await read_bytes(line.master, 256)) == big[::-1]


async def test_timestamps_never_go_back(line: Line) -> None:
    await line.master.write(bytes(40))
    chunks = await read_bytes(line.slave, 40)
    stamps = [c.timestamp for c in chunks]
    assert stamps == sorted(stamps)
    assert all(s <= line.slave.clock() for s in stamps)
    if line.medium in ("inproc", "bus"):
        # Ideal times reach the station: 40 characters back to back.
        ends = byte_ends(chunks, BAUD)
        assert ends[-1] - ends[0] == pytest.approx(39 * 11 / BAUD, abs=1e-9)


async def test_simultaneous_senders_collide(line: Line) -> None:
    # 250 characters each: 143 ms at 19200 baud, so the two overlap on the line even when one
    # reaches the bus tens of milliseconds after the other (threads, sockets, a loaded machine).
    ones, twos = bytes([0x01] * 250), bytes([0x02] * 250)
    await asyncio.gather(line.master.write(ones), line.slave.write(twos))
    await line.bus.drain(WAIT)
    seen = await read_bytes(line.monitor, 500, timeout=0.3)
    assert line.bus.stats.collisions >= 1
    assert line.bus.stats.garbled >= 1
    # Nobody received both telegrams intact.
    assert joined(seen) not in (ones + twos, twos + ones)


@pytest.mark.parametrize("medium", [pytest.param("pty", marks=pytest.mark.pty), "bus"])
async def test_two_wire_echo_is_checked_and_removed_by_the_station(medium: str) -> None:
    bus = VirtualBus(BAUD)
    if medium == "pty":
        (path,) = await bus.serve_pty(1, echo=True)
        master: Transport = SerialTransport(path, baud=BAUD, echo=True)
    else:
        host, port = await bus.serve_tcp(framed=True)
        master = BusClientTransport(host, port, baud=BAUD, name="master", echo=True)
    slave = bus.attach("slave")
    async with master, slave:
        await _wait_stations(bus, 2)
        await master.write(b"\x02\x02\x00\x00")
        assert joined(await read_bytes(slave, 4)) == b"\x02\x02\x00\x00"
        await slave.write(b"\x02\x02\x01\x01")
        assert joined(await read_bytes(master, 4)) == b"\x02\x02\x01\x01"
        assert master.stats.echo_bytes == 4  # type: ignore[attr-defined]
    await bus.close()


async def test_echo_for_named_raw_tcp_stations_only() -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(echo={"tcp1"})
    async with TcpTransport(host, port, baud=BAUD) as one:
        await _wait_stations(bus, 1)
        async with TcpTransport(host, port, baud=BAUD) as two:
            await _wait_stations(bus, 2)
            assert bus.stations["tcp1"].hears_own and not bus.stations["tcp2"].hears_own
            await one.write(b"\x02\x02\x00\x00")
            assert joined(await read_bytes(two, 4)) == b"\x02\x02\x00\x00"
            assert joined(await read_bytes(one, 4)) == b"\x02\x02\x00\x00"
            await two.write(b"\x02\x02\x01\x01")
            assert joined(await read_bytes(one, 4)) == b"\x02\x02\x01\x01"
            await one.write(b"\x02\x02\x02\x02")
            assert joined(await read_bytes(two, 4)) == b"\x02\x02\x02\x02"
    await bus.close()


async def test_bus_client_sees_the_line_errors_of_the_bus() -> None:
    bus = VirtualBus(BAUD, faults=FaultPlan([Fault(FaultKind.PARITY, station="master", nth=2)]))
    host, port = await bus.serve_tcp(framed=True)
    async with (
        BusClientTransport(host, port, baud=BAUD, name="master") as master,
        BusClientTransport(host, port, baud=BAUD, listen_only=True) as monitor,
    ):
        await master.write(b"\x02\x02\x00\x00")
        chunks = await read_bytes(monitor, 4)
    await bus.close()
    assert joined(chunks) == b"\x02\x02\x00\x00"
    assert flat_errors(chunks) == [(1, LineError.PARITY)]


async def test_bus_refuses_a_taken_name_and_a_wrong_baud() -> None:
    from pyuss.errors import TransportError

    bus = VirtualBus(BAUD)
    bus.attach("master")
    host, port = await bus.serve_tcp(framed=True)
    with pytest.raises(TransportError, match="already on the bus"):
        await BusClientTransport(host, port, baud=BAUD, name="master").open()
    with pytest.raises(TransportError, match=f"runs at {BAUD} baud, not 9600"):
        await BusClientTransport(host, port, baud=9600).open()
    await bus.close()


async def _receive(line: Line, transport: Transport, receiver: Receiver) -> list[Event]:
    """Feed what ``transport`` reads to ``receiver`` until it reports something. Ptys and raw
    TCP carry no character timing, so there what arrives is fed as one burst."""
    timed = line.medium in ("inproc", "bus")
    events: list[Event] = []
    held: list[Chunk] = []
    while not events:
        chunk = await transport.read(0.05 if held else WAIT)
        if chunk is None:
            if not held:
                break
            data = b"".join(c.data for c in held)
            events += receiver.feed(data, held[-1].timestamp, flat_errors(held))
            held.clear()
            events += receiver.poll(transport.clock() + 1.0)
        elif timed:
            events += receiver.feed(chunk.data, chunk.timestamp, chunk.errors)
            if not events and receiver.next_poll() is not None:
                events += receiver.poll(chunk.timestamp)
        else:
            held.append(chunk)
    return events


async def test_telegrams_through_the_protocol_core(line: Line) -> None:
    at_slave, at_master = Receiver(BAUD), Receiver(BAUD)
    for request, response in _vector_pairs():
        sent = Telegram.decode(request)
        await line.master.write(sent.encode())
        events = await _receive(line, line.slave, at_slave)
        assert len(events) == 1 and isinstance(events[0], Received), events
        assert events[0].telegram == sent
        await asyncio.sleep(0.002)  # processing time, longer than the start pause
        answer = Telegram.decode(response)
        await line.slave.write(answer.encode())
        events = await _receive(line, line.master, at_master)
        assert len(events) == 1 and isinstance(events[0], Received), events
        assert events[0].telegram == answer
