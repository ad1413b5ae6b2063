"""The ramp-function generator: exact linear motion, independent of the step size."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.drive.ramp import advance, duration, rate_of

levels = st.floats(-2.0, 2.0, allow_nan=False)
rates = st.floats(0.05, 20.0)


def test_ramp_time_is_from_zero_to_100_percent() -> None:
    assert advance(0.0, 1.0, 2.5, rate_of(10.0), rate_of(5.0)) == pytest.approx(0.25)
    assert advance(1.0, 0.0, 2.5, rate_of(10.0), rate_of(5.0)) == pytest.approx(0.5)
    assert duration(0.0, 0.5, rate_of(10.0), rate_of(5.0)) == pytest.approx(5.0)


def test_zero_ramp_time_jumps() -> None:
    assert rate_of(0.0) == math.inf
    assert advance(0.2, -0.7, 0.0, math.inf, math.inf) == -0.7
    assert duration(0.2, -0.7, math.inf, math.inf) == 0.0


def test_crossing_zero_ramps_down_then_up() -> None:
    # +50 % to -50 %: down at 1/4 per s (2 s), then up at 1/2 per s (1 s)
    assert duration(0.5, -0.5, 0.5, 0.25) == pytest.approx(3.0)
    assert advance(0.5, -0.5, 2.0, 0.5, 0.25) == pytest.approx(0.0)
    assert advance(0.5, -0.5, 2.5, 0.5, 0.25) == pytest.approx(-0.25)


@settings(max_examples=80, deadline=None)
@given(levels, levels, rates, rates, st.floats(0.0, 5.0), st.integers(1, 20))
def test_result_does_not_depend_on_the_step_size(
    start: float, target: float, up: float, down: float, dt: float, pieces: int
) -> None:
    whole = advance(start, target, dt, up, down)
    stepped = start
    for _ in range(pieces):
        stepped = advance(stepped, target, dt / pieces, up, down)
    assert stepped == pytest.approx(whole, abs=1e-9)


@settings(max_examples=80, deadline=None)
@given(levels, levels, rates, rates)
def test_duration_is_when_the_target_is_reached(
    start: float, target: float, up: float, down: float
) -> None:
    need = duration(start, target, up, down)
    assert advance(start, target, need, up, down) == pytest.approx(target, abs=1e-9)
    if need > 1e-6:
        assert advance(start, target, need * 0.99, up, down) != target
