"""Property tests of the bus's two byte formats: the frames ``bus://`` stations receive
(`pyuss.bus.wire`) and the JSON lines of a recording (`pyuss.bus.recorder`)."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.bus.recorder import Record
from pyuss.bus.wire import ERROR, HEADER, FrameDecoder, encode_frame
from pyuss.errors import ProtocolError
from pyuss.transport.base import LineError

FLAGS = st.builds(
    LineError, st.integers(1, int(LineError.PARITY | LineError.FRAMING | LineError.OVERRUN))
)


@st.composite
def deliveries(draw: st.DrawFn) -> tuple[bytes, float, tuple[tuple[int, LineError], ...]]:
    data = draw(st.binary(min_size=1, max_size=300))
    positions = draw(st.lists(st.integers(0, len(data) - 1), unique=True, max_size=8))
    errors = tuple((pos, draw(FLAGS)) for pos in sorted(positions))
    timestamp = draw(st.floats(0, 1e7, allow_nan=False))
    return data, timestamp, errors


@settings(max_examples=200, deadline=None)
@given(st.lists(deliveries(), max_size=6), st.data())
def test_frames_decode_to_the_deliveries_across_any_split(
    items: list[tuple[bytes, float, tuple[tuple[int, LineError], ...]]], data: st.DataObject
) -> None:
    stream = b"".join(encode_frame(ts, payload, errors) for payload, ts, errors in items)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=6)))
    decoder = FrameDecoder()
    out = []
    last = 0
    for cut in [*cuts, len(stream)]:
        out += decoder.feed(stream[last:cut])
        last = cut
    assert out == items


def test_a_frame_flagging_a_character_it_does_not_carry_is_refused() -> None:
    frame = HEADER.pack(1.0, 2, 1) + b"\x02\x03" + ERROR.pack(2, int(LineError.PARITY))
    with pytest.raises(ProtocolError, match="position 2 beyond 2 bytes"):
        FrameDecoder().feed(frame)


def test_a_delivery_too_long_for_one_frame_is_refused() -> None:
    with pytest.raises(ValueError, match="too long"):
        encode_frame(0.0, bytes(65536), ())


TIMES = st.floats(0, 1e6, allow_nan=False).map(lambda t: round(t, 9))


@settings(max_examples=300, deadline=None)
@given(
    t=TIMES,
    start=TIMES,
    sender=st.text(min_size=1, max_size=12),
    byte=st.integers(0, 255),
    flags=st.sampled_from([LineError.NONE]) | FLAGS,
    notes=st.lists(st.sampled_from(["flip", "insert", "stretch", "collision"]), max_size=3),
)
def test_recording_lines_read_back_as_written(
    t: float, start: float, sender: str, byte: int, flags: LineError, notes: list[str]
) -> None:
    start, t = min(start, t), max(start, t)  # a character ends after it starts
    record = Record(t, start, sender, byte, flags, tuple(notes))
    line = record.to_json()
    assert "\n" not in line
    assert Record.from_json(json.loads(line)) == record
