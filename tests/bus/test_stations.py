"""Stations on the bus: who hears what, collisions, echo, limits."""

from __future__ import annotations

import pytest

from pyuss.bus import Recorder, VirtualBus
from pyuss.bus.core import sample
from pyuss.bus.faults import frame_bits
from pyuss.errors import ConfigError, TransportError
from pyuss.transport.base import LineError
from transport.helpers import flat_errors, joined, read_bytes


async def test_every_other_station_hears_a_sender_but_not_the_sender() -> None:
    bus = VirtualBus(38400)
    async with (
        bus.attach("master") as master,
        bus.attach("s1") as s1,
        bus.attach("s2") as s2,
        bus.attach("monitor", listen_only=True) as monitor,
    ):
        await master.write(b"\x02\x03\x01\x00\x00")
        assert joined(await read_bytes(s2, 5)) == b"\x02\x03\x01\x00\x00"
        await s2.write(b"\x02\x03\x02\x00\x03")
        for station in (s1, monitor):
            assert joined(await read_bytes(station, 10)) == (
                b"\x02\x03\x01\x00\x00\x02\x03\x02\x00\x03"
            )
        assert joined(await read_bytes(master, 5)) == b"\x02\x03\x02\x00\x03"
        assert await master.read(0.05) is None
        with pytest.raises(TransportError, match="listen-only"):
            await monitor.write(b"\x02")
    await bus.close()


async def test_station_with_echo_hears_itself() -> None:
    bus = VirtualBus(19200)
    async with bus.attach("master", echo=True) as master, bus.attach("slave") as slave:
        await master.write(b"\x02\x02\x00\x00")
        assert joined(await read_bytes(master, 4)) == b"\x02\x02\x00\x00"
        assert joined(await read_bytes(slave, 4)) == b"\x02\x02\x00\x00"
    await bus.close()


async def test_overlapping_senders_garble_each_other_and_count_a_collision() -> None:
    bus = VirtualBus(9600)
    recorder = Recorder().attach(bus)
    async with (
        bus.attach("a", echo=True) as a,
        bus.attach("b"),
        bus.attach("monitor", listen_only=True) as monitor,
    ):
        # Both send in the same instant: their frames lie on top of each other. The times are
        # given, so how fast this process runs does not move one against the other.
        start = monitor.clock() + 0.01
        for i, (one, two) in enumerate(zip(b"\x01\x0f", b"\x02\xf0", strict=True)):
            bus.inject("a", start + i * bus.char_time, one)
            bus.inject("b", start + i * bus.char_time, two)
        chunks = await read_bytes(monitor, 2)
        echo = await read_bytes(a, 2)
    await bus.close()
    # Dominant low: 01 & 02 = 00, but both parity bits were 1 -> parity error; 0F & F0 = 00
    # with parity bits 0 and 0 -> a clean 00 that nevertheless collided.
    assert joined(chunks) == b"\x00\x00"
    assert [e for c in chunks for e in c.errors] == [(0, LineError.PARITY)]
    assert joined(echo) == b"\x00\x00"  # the echo shows the sender what the line carried
    assert bus.stats.collisions == 1
    assert bus.stats.garbled == 2
    assert [r.sender for r in recorder.records] == ["a+b", "a+b"]
    assert all("collision" in r.notes for r in recorder.records)


async def test_collision_half_a_character_late_is_a_framing_error() -> None:
    bus = VirtualBus(9600)
    bit = 1 / 9600
    async with bus.attach("monitor", listen_only=True) as monitor:
        start = monitor.clock() + 0.01
        bus.inject("a", start, 0xFF)
        bus.inject("b", start + 5 * bit, 0x00)
        chunks = await read_bytes(monitor, 1)
        assert await monitor.read(0.05) is None  # b's character went down with a's
    await bus.close()
    assert joined(chunks) == b"\x0f"
    assert chunks[0].errors == ((0, LineError.FRAMING),)
    assert bus.stats.collisions == 1


async def test_the_tail_of_a_swallowed_character_garbles_the_next_one() -> None:
    # a sends FF FF; b's 00 starts 5 bits into a's first character. b's character goes down
    # with a's first, but its last bits are still on the line while a's second one begins.
    bus = VirtualBus(9600)
    bit = 1 / 9600
    recorder = Recorder().attach(bus)
    async with bus.attach("monitor", listen_only=True) as monitor:
        start = monitor.clock() + 0.01
        bus.inject("a", start, 0xFF)
        bus.inject("b", start + 5 * bit, 0x00)
        bus.inject("a", start + 11 * bit, 0xFF)
        chunks = await read_bytes(monitor, 2)
    await bus.close()
    # Second character: data bits 0..2 meet b's data bits 5..7 and parity (all 0), bit 3 its
    # stop bit; F8 has odd parity.
    assert joined(chunks) == b"\x0f\xf8"
    assert flat_errors(chunks) == [(0, LineError.FRAMING), (1, LineError.PARITY)]
    assert [r.sender for r in recorder.records] == ["a+b", "a+b"]
    assert bus.stats.collisions == 1 and bus.stats.garbled == 2


def test_sampling_a_lone_frame_gives_the_byte_back() -> None:
    for byte in range(256):
        assert sample([(0.0, frame_bits(byte))], 0.0, 1.0) == (byte, LineError.NONE)


async def test_a_station_queues_behind_its_own_bytes_only() -> None:
    # 300 baud: the second write comes while the first is still on the line even when the
    # test process is descheduled for tens of milliseconds on a loaded machine.
    bus = VirtualBus(300)
    recorder = Recorder().attach(bus)
    async with bus.attach("a") as a, bus.attach("b") as b:
        await a.write(b"\x02\x03")
        await a.write(b"\x04")  # behind a's own bytes: no collision
        await bus.drain()
        assert bus.stats.collisions == 0
        assert joined(await read_bytes(b, 3)) == b"\x02\x03\x04"
    await bus.close()
    assert recorder.recording().gaps("a") == pytest.approx([0.0, 0.0], abs=1e-9)


def test_station_names_and_the_number_of_senders() -> None:
    bus = VirtualBus(9600)
    bus.attach("master")
    with pytest.raises(ConfigError, match="already"):
        bus.attach("master")
    with pytest.raises(ConfigError, match="name"):
        bus.attach("a+b")
    with pytest.raises(ConfigError, match="at most 128"):
        bus.attach("n" * 129)
    # the name uss simulate gives the drives of every address is a name the bus takes
    bus.attach("simulate-" + "-".join(str(a) for a in range(32)), listen_only=True)
    for i in range(31):
        bus.attach(f"slave{i}")
    with pytest.raises(ConfigError, match="32 sending stations"):
        bus.attach("one-too-many")
    bus.attach("monitor", listen_only=True)  # monitors do not count


def test_bad_baud() -> None:
    with pytest.raises(ConfigError, match="14400 is not a USS baud rate"):
        VirtualBus(14400)


async def test_deaf_and_dead_on_request() -> None:
    bus = VirtualBus(38400)
    async with bus.attach("m") as m, bus.attach("s1") as s1, bus.attach("s2") as s2:
        bus.make_deaf("s1", 60)
        bus.make_dead("s2", 60)
        await m.write(b"\x02\x02")
        await bus.drain()
        await s1.write(b"\x11")  # a deaf station still sends
        await s2.write(b"\x22")  # a dead one does not
        assert joined(await read_bytes(m, 1)) == b"\x11"
        assert await s1.read(0.05) is None
        assert await s2.read(0.05) is None
        assert await m.read(0.05) is None
        assert bus.stats.lost == 1
    await bus.close()
