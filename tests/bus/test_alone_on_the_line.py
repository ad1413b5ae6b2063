"""A character alone on the line is read from its own levels without sampling (a fast path of
the bus): it must read exactly as the sampling UART reads it."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.bus.line import read_levels, sample


@settings(deadline=None)
@given(st.integers(0, 0x7FF))
def test_a_lone_frame_reads_as_sampled(frame: int) -> None:
    bit = 11 / 187500 / 11
    assert read_levels(frame) == sample([(1.0, frame)], 1.0, bit)
