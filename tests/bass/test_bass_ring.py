"""Simulated drives on a closed RS-232 loop (Baumueller manual 1.4.2) with the IDs of Baumueller
manual 1.5."""

from __future__ import annotations

import asyncio
import os
import time

import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.bass.codec import BassAnswer, BassRequest, decode_answer
from pyuss.bass.errors import BassErrorNumber, BassRefusal, BassTelegramError, BassTimeout
from pyuss.bass.master import BassMaster
from pyuss.bass.ring import (
    ID_COMM_SOURCE,
    ID_SV_BAUD,
    ID_SV_STATE,
    BassRing,
    BassStation,
    DictOperatingData,
    Element,
    OperatingData,
    demo_elements,
)
from pyuss.errors import ConfigError
from pyuss.transport import PtyPort, TcpServerTransport, open_transport

E = BassErrorNumber
WAIT = 5.0  # generous: real ptys and sockets on a loaded machine


def ring_of_three() -> BassRing:
    return BassRing.with_addresses([5, 0x12, 200], elements=demo_elements())


def test_echo_then_answer_exactly_as_the_document_describes() -> None:
    ring = ring_of_three()
    request = BassRequest.read(0x12, ID_SV_STATE).encode()
    back = ring.inject(request)
    answer = BassAnswer.value(0x12, ID_SV_STATE, 0x121).encode()
    assert back == request + answer


def test_every_station_passes_on_what_is_not_addressed_to_it() -> None:
    ring = ring_of_three()
    for station in ring.stations:
        unrelated = BassRequest.read(99, 1).encode() + b"noise\r\n"
        assert station.receive(unrelated) == unrelated
    request = BassRequest.read(77, ID_SV_STATE).encode()
    assert ring.inject(request) == request  # nobody has address 77: echo, no answer
    assert [s.answered for s in ring.stations] == [0, 0, 0]


def test_an_upstream_answer_passes_downstream_stations_unchanged() -> None:
    ring = ring_of_three()
    request = BassRequest.read(5, ID_SV_STATE).encode()
    first = ring.stations[0].receive(request)
    assert first.startswith(request) and len(first) > len(request)
    assert ring.stations[1].receive(first) == first
    assert ring.stations[2].receive(first) == first


def test_byte_by_byte_the_ring_gives_the_same_stream() -> None:
    ring = ring_of_three()
    request = BassRequest.write(200, 2, 7500).encode()
    out = b"".join(ring.inject(bytes([b])) for b in request)
    assert out == request + BassAnswer.value(200, 2, 7500).encode()


def test_each_answer_follows_its_own_request_in_one_burst() -> None:
    ring = ring_of_three()
    write, read = BassRequest.write(5, 2, 7500).encode(), BassRequest.read(200, 2).encode()
    assert ring.inject(write + read) == (
        write + BassAnswer.value(5, 2, 7500).encode() + read + BassAnswer.value(200, 2, 0).encode()
    )


def test_a_damaged_request_is_passed_on_damaged_and_not_answered() -> None:
    ring = ring_of_three()
    damaged = bytearray(BassRequest.write(5, 2, 100).encode())
    damaged[-4] ^= 0x01
    assert ring.inject(bytes(damaged)) == bytes(damaged)
    assert ring.station(5).data.read(2) == 0


async def test_master_reads_three_drives_on_the_ring() -> None:
    ring = ring_of_three()
    async with ring.port() as port:
        master = BassMaster(port, timeout=0.5, retries=0)
        for station in ring.stations:
            state = await master.read(station.address, ID_SV_STATE)
            assert state & 0x000F == 1  # RUN
            assert (state >> 4) & 0xFF == station.address
            assert state >> 12 == 0
            assert await master.read(station.address, ID_SV_BAUD) == 9600
        await master.write(0x12, 2, 7500)
        assert await master.read(0x12, 2) == 7500
        assert await master.read(5, 2) == 0
        await master.write(200, 2, -2500)
        assert await master.read(200, 2, signed=True) == -2500
        with pytest.raises(BassTimeout, match="echo but no answer"):
            await master.read(6, ID_SV_STATE)


async def test_write_authority_through_id_126_bit_0() -> None:
    ring = ring_of_three()
    drive = ring.station(5).data
    assert isinstance(drive, DictOperatingData)
    async with ring.port() as port:
        master = BassMaster(port, timeout=0.5, retries=0)
        await master.write(5, 2, 1000)
        drive.set_write_authority(False)
        assert not drive.write_authorized()
        state = await master.read(5, ID_SV_STATE)
        assert state & 0xF == 0  # STOP
        with pytest.raises(BassRefusal) as info:
            await master.write(5, 2, 2000)
        assert info.value.code is E.WRITE_PROTECTED
        with pytest.raises(BassRefusal) as info:
            await master.write(5, ID_COMM_SOURCE, 1)
        assert info.value.code is E.WRITE_PROTECTED
        assert await master.read(5, 2) == 1000  # reads still allowed, value kept
        assert await master.read(0x12, 2) == 0
        await master.write(0x12, 2, 3)  # the other drives keep their own authority
        drive.set_write_authority(True)
        await master.write(5, 2, 2000)
        assert drive.value(2) == 2000
        # only bit 0 counts
        await master.write(5, ID_COMM_SOURCE, 0x0003)
        assert await master.read(5, ID_SV_STATE) & 0xF == 1
        # the PC may give up the authority itself; then it is locked out
        await master.write(5, ID_COMM_SOURCE, 0xFFFE)
        assert await master.read(5, ID_SV_STATE) & 0xF == 0
        with pytest.raises(BassRefusal):
            await master.write(5, 2, 3000)


async def test_station_error_numbers() -> None:
    elements = demo_elements() | {
        7: Element(1, allowed=frozenset({1, 2, 4})),
        8: Element(0x12345678, digits=8),
    }
    ring = BassRing.with_addresses([1], elements=elements)
    async with ring.port() as port:
        master = BassMaster(port, timeout=0.5, retries=0)

        async def refused(request: BassRequest) -> int:
            with pytest.raises(BassRefusal) as info:
                await master.exchange(request)
            return info.value.number

        assert await refused(BassRequest.read(1, 999)) == E.ELEMENT_NOT_AVAILABLE
        assert await refused(BassRequest(1, 0x3E, 2, "1D4")) == E.DATA_TOO_SHORT
        assert await refused(BassRequest(1, 0x3E, 2, "01D4C")) == E.DATA_TOO_LONG
        assert await refused(BassRequest(1, 0x3C, 2, "0001")) == E.DATA_TOO_LONG
        assert await refused(BassRequest.write(1, 51, 1)) == E.DATA_NOT_CHANGEABLE
        assert await refused(BassRequest.write(1, ID_SV_STATE, 1)) == E.DATA_NOT_CHANGEABLE
        assert await refused(BassRequest.write(1, ID_SV_BAUD, 19200)) == E.DATA_NOT_CHANGEABLE
        assert await refused(BassRequest.write(1, 2, -10001)) == E.BELOW_MINIMUM
        assert await refused(BassRequest.write(1, 2, 10001)) == E.ABOVE_MAXIMUM
        assert await refused(BassRequest.write(1, 7, 3)) == E.DATA_NOT_VALID
        assert await refused(BassRequest(1, 0x0040, 2)) == E.ACCESS_NOT_VALID
        assert await refused(BassRequest.write(1, 8, 5, digits=4)) == E.DATA_TOO_SHORT
        await master.write(1, 7, 4)
        await master.write(1, 2, 10000)
        await master.write(1, 8, 5, digits=8)
        assert await master.read(1, 8) == 5
        exchange = await master.exchange(BassRequest.read(1, 8))
        assert exchange.answer.data == "00000005"


def test_write_answer_carries_the_stored_value() -> None:
    station = BassStation(DictOperatingData(3, demo_elements()))
    answer = decode_answer(station.receive(BassRequest.write(3, 2, -1).encode())[19:])
    assert answer.data == "FFFF" and not answer.is_error


def test_change_listener_sees_bass_writes() -> None:
    drive = DictOperatingData(9, demo_elements())
    seen: list[tuple[int, int, int]] = []
    stop = drive.on_change(lambda ident, old, new: seen.append((ident, old, new)))
    station = BassStation(drive)
    station.receive(BassRequest.write(9, 2, 7500).encode())
    station.receive(BassRequest.write(9, 2, 7500).encode())  # same value: no change
    station.receive(BassRequest.write(9, 2, -1).encode())
    station.receive(BassRequest.write(9, 51, 1).encode())  # refused: no change
    stop()
    station.receive(BassRequest.write(9, 2, 5).encode())
    assert seen == [(2, 0, 7500), (2, 7500, -1)]


def test_operating_data_is_a_protocol_others_can_implement() -> None:
    class Fixed:
        dip_address = 4

        def digits(self, ident: int) -> int:
            if ident != 1:
                raise BassRefusal(E.ELEMENT_NOT_AVAILABLE, ident=ident)
            return 4

        def read(self, ident: int) -> int:
            return 0xBEEF

        def write(self, ident: int, value: int) -> None:
            raise BassRefusal(E.ACCESS_NOT_VALID, ident=ident)

        def write_authorized(self) -> bool:
            return True

    assert isinstance(Fixed(), OperatingData)
    assert isinstance(DictOperatingData(1), OperatingData)
    ring = BassRing([Fixed(), DictOperatingData(1)])
    out = ring.inject(BassRequest.read(4, 1).encode())
    assert out.endswith(BassAnswer.value(4, 1, 0xBEEF).encode())
    out = ring.inject(BassRequest.write(4, 1, 1).encode())
    assert out.endswith(BassAnswer.refusal(4, 1, 9).encode())


def test_ring_limits() -> None:
    BassRing.with_addresses(range(16))
    with pytest.raises(ConfigError, match="1 to 16"):
        BassRing.with_addresses(range(17))
    with pytest.raises(ConfigError, match="1 to 16"):
        BassRing.with_addresses([])
    with pytest.raises(ConfigError, match="two drives"):
        BassRing.with_addresses([3, 4, 3])
    with pytest.raises(ConfigError):
        DictOperatingData(256)
    with pytest.raises(ConfigError):
        DictOperatingData(1, {ID_SV_STATE: Element()})
    with pytest.raises(ConfigError):
        Element(digits=6)
    with pytest.raises(ConfigError):
        Element(-1)
    with pytest.raises(ConfigError):
        ring_of_three().station(6)


async def test_sixteen_drives_each_answer_at_its_dip_address() -> None:
    addresses = [0, 1, 2, 4, 8, 16, 32, 64, 128, 255, 3, 5, 6, 7, 9, 10]
    ring = BassRing.with_addresses(addresses)
    async with ring.port() as port:
        master = BassMaster(port, timeout=0.5, retries=0)
        for address in addresses:
            assert (await master.read(address, ID_SV_STATE) >> 4) & 0xFF == address


async def test_master_over_tcp_to_a_ring_served_on_localhost() -> None:
    ring = ring_of_three()
    async with TcpServerTransport("127.0.0.1", 0) as server:
        serving = asyncio.create_task(ring.serve(server))
        assert isinstance(server, TcpServerTransport)
        client = open_transport(f"tcp://127.0.0.1:{server.port}", parity="N")
        async with client:
            master = BassMaster(client, timeout=WAIT, retries=0)
            assert await master.read(200, ID_SV_STATE) == 0x0C81
            await master.write(0x12, 2, 7500)
            assert await master.read(0x12, 2) == 7500
            with pytest.raises(BassRefusal):
                await master.write(0x12, ID_SV_BAUD, 1)
    await asyncio.wait_for(serving, WAIT)  # closing the transport ends the service


@pytest.mark.pty
async def test_ring_behind_a_pty_with_pyserial() -> None:
    ring = ring_of_three()
    async with PtyPort() as pty:
        assert isinstance(pty, PtyPort)
        serving = asyncio.create_task(ring.serve(pty))

        def talk() -> bytes:
            with serial.Serial(pty.device_path, 9600, timeout=WAIT) as port:
                port.write(BassRequest.write(5, 2, 7500).encode() + BassRequest.read(5, 2).encode())
                return b"".join(port.read_until(b"\n") for _ in range(4))

        data = await asyncio.to_thread(talk)
    await asyncio.wait_for(serving, WAIT)
    lines = [line + b"\r\n" for line in data.split(b"\r\n")[:4]]
    assert lines[0] == BassRequest.write(5, 2, 7500).encode()
    assert decode_answer(lines[1]).to_int() == 7500
    assert lines[2] == BassRequest.read(5, 2).encode()
    assert decode_answer(lines[3]).to_int() == 7500


def test_malformed_answer_data_is_caught_by_the_master_codec() -> None:
    answer = BassAnswer(3, 0, 2, "")
    with pytest.raises(BassTelegramError):
        answer.to_int()


@given(st.integers(-0x8000, 0x7FFF))
@settings(max_examples=100)
def test_signed_element_round_trip_and_limits(value: int) -> None:
    """Two's complement on the wire; the element's own limits give errors 6 and 7."""
    drive = DictOperatingData(1, {2: Element(0, signed=True, minimum=-0x7000, maximum=0x7000)})
    station = BassStation(drive)
    line = BassRequest.write(1, 2, value, digits=4).encode()
    answer = decode_answer(station.receive(line)[len(line) :])
    if value < -0x7000:
        assert answer.error_number == E.BELOW_MINIMUM
    elif value > 0x7000:
        assert answer.error_number == E.ABOVE_MAXIMUM
    else:
        assert answer.to_int(signed=True) == value
        assert drive.value(2) == value


@pytest.mark.pty
async def test_a_pc_that_stops_reading_does_not_stop_the_ring() -> None:
    """The PC sends without reading until the pty's buffer is full and the ring's output is
    lost; then it empties its input and asks something else: the ring is still serving."""
    import termios
    import tty

    ring = ring_of_three()
    async with PtyPort(write_timeout=0.1) as pty:
        assert isinstance(pty, PtyPort)
        serving = asyncio.create_task(ring.serve(pty))
        batch = BassRequest.read(5, ID_SV_STATE).encode() * 500
        ask = BassRequest.read(0x12, ID_SV_BAUD).encode()

        def flood_then_ask() -> bytes:
            fd = os.open(pty.device_path, os.O_RDWR | os.O_NOCTTY)
            try:
                tty.setraw(fd)
                while pty.stats.dropped_out == 0:  # a batch at a time, never reading
                    os.write(fd, batch)
                    time.sleep(0.2)
                termios.tcflush(fd, termios.TCIFLUSH)
            finally:
                os.close(fd)
            with serial.Serial(pty.device_path, 9600, timeout=WAIT) as port:
                port.write(ask)
                seen = b""
                while not (ask in seen and seen.split(ask)[-1].endswith(b"\n")):
                    more = port.read(max(1, port.in_waiting))  # what the flood left, then ours
                    assert more, "the ring went quiet"
                    seen += more
                return seen.split(ask)[-1]

        answer = await asyncio.to_thread(flood_then_ask)
        assert not serving.done()
    await asyncio.wait_for(serving, WAIT)
    assert answer == BassAnswer.value(0x12, ID_SV_BAUD, 9600).encode()
