"""Capture files: pcapng and JSON lines written atomically, read back, replayed identically."""

from __future__ import annotations

import asyncio
import json
import struct
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.traffic import REQ_52, Wire, answer, request
from pyuss.bus import Recorder, VirtualBus
from pyuss.errors import ConfigError
from pyuss.monitor import (
    CaptureFlag,
    CaptureRecord,
    Direction,
    Exchange,
    Frame,
    LayoutBook,
    LayoutChoice,
    LayoutSource,
    Monitor,
    Problem,
    open_writer,
    read_capture,
    replay,
)
from pyuss.monitor.capture import PSEUDO_HEADER
from pyuss.monitor.pcapng import LINKTYPE_USER0
from pyuss.protocol import FaultKind, Layout, Pkw
from pyuss.protocol.layout import PKW_VARIABLE
from pyuss.protocol.timing import char_time

BAUD = 19200
TC = char_time(BAUD)


def _traffic(four_wire: bool = False) -> tuple[list[Exchange], Monitor]:
    """A line with every kind of exchange: good, damaged, unanswered, noise, late, guessed."""
    monitor = Monitor(BAUD, four_wire=four_wire, layouts=LayoutBook(None, {5: Layout(3, 2)}))
    wire = Wire(monitor)
    port = 1 if four_wire else 0
    wire.send(REQ_52, 0.01)
    wire.send(answer(5, Pkw(1, 52, values=(3,))), 0.004, port)
    wire.send(request(5, Pkw(1, 53)), 0.01)
    bad = bytearray(answer(5, Pkw(1, 53, values=(4,))))
    bad[-1] ^= 0xFF
    wire.send(bytes(bad), 0.003, port)
    wire.send(request(5, Pkw(1, 54)), 0.01)  # no answer
    wire.send(b"\xff\xfe", 0.08)  # noise
    wire.send(request(6, Pkw(2, 1, values=(9,))), 0.01)
    wire.send(answer(6, Pkw(1, 1, values=(9,))), 0.030, port)  # late
    wire.send(request(6, Pkw(1, 2)), 0.01)
    wire.send(answer(6, Pkw(1, 2, values=(1,))), 0.004, port)
    wire.send(request(6, Pkw(1, 3)), 0.01)
    wire.send(b"\x00", 0.002, port)  # a stray character: noise, reported after the exchange
    wire.send(answer(6, Pkw(1, 3, values=(1,))), 0.002, port)
    return wire.finish(), monitor


def _shape(exchanges: list[Exchange]) -> list[tuple[object, ...]]:
    return [
        (
            ex.kind,
            ex.address,
            ex.problems,
            ex.layout,
            ex.layout_source,
            bool(ex.unsure),
            None if ex.delay is None else round(ex.delay, 5),
            tuple((f.raw, f.direction, f.fault, f.port) for f in ex.frames),
        )
        for ex in exchanges
    ]


@pytest.mark.parametrize("suffix", [".pcapng", ".jsonl"])
@pytest.mark.parametrize("four_wire", [False, True])
def test_round_trip_and_replay(tmp_path: Path, suffix: str, four_wire: bool) -> None:
    exchanges, monitor = _traffic(four_wire)
    assert {ex.kind for ex in exchanges} == {"exchange", "request", "noise"}
    path = tmp_path / f"line{suffix}"
    writer = open_writer(path, baud=BAUD, four_wire=four_wire, epoch=1.7e9, gap=monitor.gap)
    for ex in exchanges:
        writer.write(ex)
    writer.close()
    capture = read_capture(path)
    assert capture.baud == BAUD and capture.four_wire == four_wire
    assert capture.gap == pytest.approx(monitor.gap)
    assert capture.tolerance == 0.0  # exact timestamps: the file does not mention it
    # One packet per frame, in time order (the noise was reported after its exchange).
    assert [ex.kind for ex in exchanges[-2:]] == ["exchange", "noise"]
    frames = sorted((f for ex in exchanges for f in ex.frames), key=lambda f: f.start)
    assert len(capture.records) == len(frames)
    for record, frame in zip(capture.records, frames, strict=True):
        got = record.frame
        assert got.raw == frame.raw
        # Unix time: a pcapng capture counts from its first packet (`Capture.epoch`)
        assert got.start + capture.epoch == pytest.approx(frame.start + 1.7e9, abs=1e-6)
        assert got.end + capture.epoch == pytest.approx(frame.end + 1.7e9, abs=2e-6)
        assert (got.direction, got.guessed, got.fault, got.port) == (
            frame.direction,
            frame.guessed,
            frame.fault,
            frame.port,
        )
        assert got.detail == frame.detail
    replayed = list(replay(capture, Monitor(capture.baud, gap=capture.gap)))
    assert _shape(replayed) == _shape(exchanges)
    # Frames out of order in a file (pcapng allows it; merged captures have it) replay the same.
    shuffled = replace(capture, records=capture.records[::-1])
    assert _shape(list(replay(shuffled, Monitor(capture.baud, gap=capture.gap)))) == _shape(
        exchanges
    )


@pytest.mark.parametrize("suffix", [".pcapng", ".jsonl"])
def test_a_capture_keeps_the_tolerance_of_its_port_for_the_replay(
    tmp_path: Path, suffix: str
) -> None:
    # A capture made on a port that stamps bytes when read judged timing with a tolerance;
    # its replay judges it the same way (an answer 30 ms after its request is in time then).
    exchanges, monitor = _traffic()
    path = tmp_path / f"line{suffix}"
    writer = open_writer(path, baud=BAUD, gap=monitor.gap, tolerance=0.02)
    for ex in exchanges:
        writer.write(ex)
    writer.close()
    capture = read_capture(path)
    assert capture.tolerance == pytest.approx(0.02)
    again = Monitor(capture.baud, gap=capture.gap, tolerance=capture.tolerance)
    assert again.resolution == pytest.approx(monitor.resolution + 0.02)
    replayed = list(replay(capture, again))
    frames = [tuple(f.raw for f in ex.frames) for ex in exchanges]
    assert [tuple(f.raw for f in ex.frames) for ex in replayed] == frames
    late = [i for i, ex in enumerate(exchanges) if Problem.LATE_ANSWER in ex.problems]
    assert late and [exchanges[i].delay for i in late] == [pytest.approx(0.03)]
    assert all(Problem.LATE_ANSWER not in replayed[i].problems for i in late)


def test_replay_judges_a_given_fixed_length_like_the_live_monitor(tmp_path: Path) -> None:
    # A capture made without layouts, replayed with a layout the telegrams do not have: the
    # wrong LGE is a receive fault (A 5.2), as a live monitor with that layout reports it.
    exchanges, monitor = _traffic()
    path = tmp_path / "line.jsonl"
    writer = open_writer(path, baud=BAUD, gap=monitor.gap)
    for ex in exchanges:
        writer.write(ex)
    writer.close()
    given = LayoutBook(None, {6: Layout(4, 2)})
    replayed = list(replay(read_capture(path), Monitor(BAUD, layouts=given)))
    bad = [ex for ex in replayed if ex.address == 6 and ex.kind == "exchange"]
    assert bad and all(ex.problems[:2] == (Problem.BAD_LGE, Problem.BAD_LGE) for ex in bad), [
        ex.problems for ex in bad
    ]
    assert "address 6 uses the fixed length LGE 14" in bad[0].issues[0].text
    live = Monitor(BAUD, layouts=LayoutBook(None, {5: Layout(3, 2), 6: Layout(4, 2)}))
    wire = Wire(live)
    wire.send(request(6, Pkw(1, 2)), 0.01)
    (ex,) = wire.finish()
    assert ex.issues[0].text == bad[0].issues[0].text
    assert monitor.summary.line.diagnostics.bad_lge == 0


def test_pcapng_blocks(tmp_path: Path) -> None:
    exchanges, monitor = _traffic()
    path = tmp_path / "line.pcapng"
    writer = open_writer(path, baud=BAUD, gap=monitor.gap, linktype=150)
    for ex in exchanges:
        writer.write(ex)
    writer.close()
    data = path.read_bytes()
    blocks = []
    offset = 0
    while offset < len(data):
        kind, length = struct.unpack_from("<II", data, offset)
        assert length % 4 == 0
        assert struct.unpack_from("<I", data, offset + length - 4)[0] == length
        blocks.append((kind, data[offset + 8 : offset + length - 4]))
        offset += length
    assert blocks[0][0] == 0x0A0D0D0A
    assert struct.unpack_from("<IHHq", blocks[0][1]) == (0x1A2B3C4D, 1, 0, -1)
    assert blocks[1][0] == 1 and struct.unpack_from("<H", blocks[1][1])[0] == 150
    assert b"USS 2-wire line, 19200 baud" in blocks[1][1]
    assert struct.pack("<HH", 9, 1) + b"\x09" in blocks[1][1]  # if_tsresol: nanoseconds
    packets = [body for kind, body in blocks if kind == 6]
    assert len(packets) == sum(len(ex.frames) for ex in exchanges)
    first = packets[0]
    _, high, low, captured, original = struct.unpack_from("<IIIII", first)
    assert captured == original == PSEUDO_HEADER.size + len(REQ_52)
    assert ((high << 32) | low) == round(exchanges[0].time * 1e9)
    assert first[20 + PSEUDO_HEADER.size : 20 + captured] == REQ_52
    version, size, direction = first[20], first[21], first[22]
    assert (version, size, direction) == (1, 20, Direction.REQUEST)
    # epb_flags: outbound for the master's request
    assert struct.pack("<HHI", 2, 4, 2) in first


def _be_block(kind: int, body: bytes) -> bytes:
    length = 12 + len(body)
    return struct.pack(">II", kind, length) + body + struct.pack(">I", length)


def test_big_endian_pcapng_and_unknown_blocks(tmp_path: Path) -> None:
    header = CaptureRecord(
        Frame(REQ_52, 0.0, 14 * TC, Direction.REQUEST), CaptureFlag.LAYOUT_GIVEN
    ).pseudo_header()
    packet = header + REQ_52
    pad = b"\x00" * (-len(packet) % 4)
    speed = struct.pack(">HH", 8, 8) + struct.pack(">Q", BAUD) + struct.pack(">HH", 0, 0)
    data = (
        _be_block(0x0A0D0D0A, struct.pack(">IHHq", 0x1A2B3C4D, 1, 0, -1))
        + _be_block(1, struct.pack(">HHI", LINKTYPE_USER0, 0, 0) + speed)
        + _be_block(0x0BAD, b"\x00" * 8)
        + _be_block(
            6, struct.pack(">IIIII", 0, 0, 5_000_000, len(packet), len(packet)) + packet + pad
        )
    )
    path = tmp_path / "be.pcapng"
    path.write_bytes(data)
    capture = read_capture(path)
    assert capture.baud == BAUD
    (record,) = capture.records
    assert record.frame.raw == REQ_52
    # default resolution: microseconds; times count from the first packet
    assert record.frame.start == 0.0 and capture.epoch == pytest.approx(5.0)
    assert record.frame.telegram is not None and record.frame.telegram.address == 5


def test_bad_files_give_one_clear_error(tmp_path: Path) -> None:
    exchanges, monitor = _traffic()
    good = tmp_path / "good.pcapng"
    writer = open_writer(good, baud=BAUD, gap=monitor.gap)
    writer.write(exchanges[0])
    writer.close()
    data = good.read_bytes()
    idb = struct.unpack_from("<I", data, 4)[0]
    epb = idb + struct.unpack_from("<I", data, idb + 4)[0]
    wrong_version = bytearray(data)
    wrong_version[epb + 28] = 7
    header = (
        json.dumps({"format": "pyuss-monitor-capture", "version": 1, "baud": BAUD}).encode() + b"\n"
    )
    far_off = bytearray(data)
    far_off[epb + 12 : epb + 16] = b"\xff\xff\xff\xff"  # 2^64 microseconds: no time of day
    cases = {
        "empty.pcapng": (b"", "not a capture"),
        "noise.pcapng": (b"\x00\x01\x02\x03" * 8, "not a capture"),
        "cut.pcapng": (data[:-6], "truncated: a block of"),
        "header.pcapng": (data[: epb + 6], "truncated: the file ends inside a block header"),
        "classic.pcap": (
            struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, LINKTYPE_USER0),
            "a classic pcap file, not pcapng",
        ),
        "version.pcapng": (bytes(wrong_version), "packet 1"),
        "text.jsonl": (b'{"format": "other"}\n', "not a capture"),
        "line.jsonl": (
            json.dumps({"format": "pyuss-monitor-capture", "version": 1, "baud": BAUD}).encode()
            + b'\n{"hex": "zz"}\n',
            ":2: bad frame",
        ),
        "nan.jsonl": (header + b'{"hex": "02", "start": NaN, "end": 1}\n', "finite"),
        "inf.jsonl": (header + b'{"hex": "02", "start": 1, "end": Infinity}\n', "finite"),
        "order.jsonl": (header + b'{"hex": "02", "start": 2, "end": 1}\n', "end 1.0 is before"),
        "far.jsonl": (header + b'{"hex": "02", "start": 1, "end": 1e300}\n', "out of range"),
        "far.pcapng": (bytes(far_off), "packet 1: timestamp 1.8"),
        "gap.jsonl": (header.replace(b"}", b', "gap_ms": -1}'), "gap_ms -1"),
        "tolerance.jsonl": (header.replace(b"}", b', "tolerance_ms": NaN}'), "tolerance_ms"),
        "baud.jsonl": (
            json.dumps({"format": "pyuss-monitor-capture", "version": 1, "baud": 1234}).encode(),
            "not a USS baud rate",
        ),
    }
    for name, (content, words) in cases.items():
        path = tmp_path / name
        path.write_bytes(content)
        with pytest.raises(ConfigError, match=words) as info:
            read_capture(path)
        assert name in str(info.value)
    with pytest.raises(ConfigError, match="cannot read capture"):
        read_capture(tmp_path / "missing.pcapng")
    other = bytearray(data)
    other[idb + 8 : idb + 10] = struct.pack("<H", 1)  # Ethernet instead of a user link type
    (tmp_path / "eth.pcapng").write_bytes(bytes(other))
    with pytest.raises(ConfigError, match="no USS interface"):
        read_capture(tmp_path / "eth.pcapng")


def test_writing_is_atomic(tmp_path: Path) -> None:
    exchanges, _ = _traffic()
    path = tmp_path / "line.pcapng"
    path.write_bytes(b"old")
    writer = open_writer(path, baud=BAUD)
    writer.write(exchanges[0])
    assert path.read_bytes() == b"old"  # nothing half-written under the name
    writer.discard()
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["line.pcapng"]
    writer = open_writer(path, baud=BAUD)
    writer.write(exchanges[0])
    writer.close()
    writer.close()  # idempotent
    assert read_capture(path).records[0].frame.raw == REQ_52
    assert sorted(p.name for p in tmp_path.iterdir()) == ["line.pcapng"]
    with pytest.raises(ConfigError, match="cannot write a capture"):
        open_writer(tmp_path / "no" / "dir.pcapng", baud=BAUD)
    with pytest.raises(ConfigError, match=r"\*.pcapng"):
        open_writer(tmp_path / "line.txt", baud=BAUD)
    with pytest.raises(ConfigError, match="user link type"):
        open_writer(tmp_path / "x.pcapng", baud=BAUD, linktype=1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["line.pcapng"]


async def test_bus_recordings_are_read_and_framed(tmp_path: Path) -> None:
    bus = VirtualBus(BAUD)
    path = tmp_path / "wire.jsonl"
    recorder = Recorder(path).attach(bus)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(REQ_52)
        await bus.drain()
        await slave.read(1.0)
        await asyncio.sleep(0.003)  # the start pause before the answer (A 5.2.1.1)
        await slave.write(answer(5, Pkw(1, 52, values=(1,))))
        await bus.drain()
    await bus.close()
    recorder.close()
    capture = read_capture(path)
    assert capture.kind == "bus recording" and capture.baud == BAUD
    (ex,) = replay(capture, Monitor(BAUD, layouts=LayoutBook(Layout(3, 2))))
    assert ex.kind == "exchange" and ex.issues == ()


_FRAMES = st.builds(
    lambda raw, start, length, direction, fault, flags, layout, delay: CaptureRecord(
        Frame(raw, start, start + length, direction, fault=fault),
        CaptureFlag(flags),
        layout,
        delay,
    ),
    st.binary(min_size=0, max_size=256),
    st.floats(0, 2e9, allow_nan=False),
    st.floats(0, 4000, allow_nan=False),
    st.sampled_from(Direction),
    st.none() | st.sampled_from(FaultKind),
    st.integers(0, 0x0FFF),
    st.none()
    | st.builds(
        LayoutChoice,
        st.builds(Layout, st.sampled_from([0, 3, 4, PKW_VARIABLE]), st.integers(0, 16)),
        st.sampled_from([LayoutSource.INFERRED]),
    ),
    st.none() | st.floats(-100, 100, allow_nan=False),
)


@settings(max_examples=80, deadline=None)
@given(_FRAMES)
def test_pseudo_header_round_trip(record: CaptureRecord) -> None:
    flags = record.flags & ~(CaptureFlag.LAYOUT_GIVEN | CaptureFlag.LAYOUT_GUESSED)
    record = CaptureRecord(record.frame, flags, record.layout, record.delay)
    packet = record.pseudo_header() + record.frame.raw
    back = CaptureRecord.from_packet(packet, record.frame.start, "test")
    assert back.frame.raw == record.frame.raw
    assert back.frame.direction == record.frame.direction
    assert back.frame.fault == record.frame.fault
    assert back.flags == record.flags
    assert back.layout == record.layout
    duration = record.frame.end - record.frame.start
    assert back.frame.end - back.frame.start == pytest.approx(duration, abs=1e-6)
    if record.delay is None:
        assert back.delay is None
    else:
        assert back.delay == pytest.approx(record.delay, abs=1e-6)
