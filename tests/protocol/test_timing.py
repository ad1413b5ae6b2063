"""Timing (A 5.1.2, A 5.2.1, A 6, B 2.4) against the shared timing vectors."""

from __future__ import annotations

import math
from typing import Any

import pytest

from pyuss.errors import ConfigError
from pyuss.protocol.timing import (
    BAUD_RATES,
    MAX_RESPONSE_DELAY,
    LineTiming,
    char_time,
    check_baud,
    residual_time_flush,
    residual_time_max,
    response_delay_limit,
    start_pause,
    transmit_time,
)
from support.paths import load_vectors

TIMING = load_vectors("uss")["timing"]
MS = 1000.0


@pytest.mark.parametrize("row", TIMING, ids=[str(r["baud"]) for r in TIMING])
def test_timing_vectors(row: dict[str, Any]) -> None:
    baud = row["baud"]
    assert char_time(baud) * MS == pytest.approx(row["char_time_ms"], abs=1e-6)
    assert start_pause(baud) * MS == pytest.approx(row["start_pause_ms"], abs=1e-6)
    assert residual_time_max(baud, 10) * MS == pytest.approx(row["max_residual_ms_n10"], abs=1e-6)
    assert residual_time_max(baud, 252) * MS == pytest.approx(row["max_residual_ms_n252"], abs=1e-6)
    assert response_delay_limit(baud) * MS == pytest.approx(row["max_response_delay_ms"])
    # Table 5.1 lists the start pause rounded up to 0.01 ms.
    assert math.ceil(round(start_pause(baud) * MS * 100, 6)) / 100 == row["start_pause_table_ms"]


@pytest.mark.parametrize("row", TIMING, ids=[str(r["baud"]) for r in TIMING])
def test_line_timing_bundles_the_same_figures(row: dict[str, Any]) -> None:
    line = LineTiming(row["baud"])
    assert line.char_time == char_time(row["baud"])
    assert line.start_pause == start_pause(row["baud"])
    assert line.residual_max(10) == residual_time_max(row["baud"], 10)
    assert line.residual_flush(10) == residual_time_flush(row["baud"], 10)
    assert line.response_delay_limit == response_delay_limit(row["baud"])
    assert line.transmit(14) == transmit_time(row["baud"], 14)


def test_the_thirteen_baud_rates_of_b_2_4() -> None:
    assert BAUD_RATES == (
        300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 76800, 93750, 115200, 187500,
    )  # fmt: skip
    for baud in BAUD_RATES:
        assert check_baud(baud) == baud
    with pytest.raises(ConfigError, match="not a USS baud rate"):
        check_baud(14400)


# Every rate of B 2.4, worked out by hand (ms): character (11 bits), start pause (2 characters),
# maximum residual time before LGE is known (1.5 x 255 characters), response delay limit
# (20 ms, but at least the start pause). docs/protocol.md shows the same table.
ALL_RATES = [
    (300, 36.666667, 73.333333, 14025.0, 73.333333),
    (600, 18.333333, 36.666667, 7012.5, 36.666667),
    (1200, 9.166667, 18.333333, 3506.25, 20.0),
    (2400, 4.583333, 9.166667, 1753.125, 20.0),
    (4800, 2.291667, 4.583333, 876.5625, 20.0),
    (9600, 1.145833, 2.291667, 438.28125, 20.0),
    (19200, 0.572917, 1.145833, 219.140625, 20.0),
    (38400, 0.286458, 0.572917, 109.570313, 20.0),
    (57600, 0.190972, 0.381944, 73.046875, 20.0),
    (76800, 0.143229, 0.286458, 54.785156, 20.0),
    (93750, 0.117333, 0.234667, 44.88, 20.0),
    (115200, 0.095486, 0.190972, 36.523438, 20.0),
    (187500, 0.058667, 0.117333, 22.44, 20.0),
]


@pytest.mark.parametrize(
    ("baud", "char_ms", "pause_ms", "residual_ms", "response_ms"),
    ALL_RATES,
    ids=[str(row[0]) for row in ALL_RATES],
)
def test_timing_of_every_baud_rate(
    baud: int, char_ms: float, pause_ms: float, residual_ms: float, response_ms: float
) -> None:
    line = LineTiming(check_baud(baud))
    assert line.char_time * MS == pytest.approx(char_ms, abs=1e-6)
    assert line.start_pause * MS == pytest.approx(pause_ms, abs=1e-6)
    assert line.residual_max(252) * MS == pytest.approx(residual_ms, abs=1e-6)
    assert line.residual_flush(252) * MS == pytest.approx(residual_ms / 1.5, abs=1e-6)
    assert line.response_delay_limit * MS == pytest.approx(response_ms, abs=1e-6)
    assert line.start_pause <= line.response_delay_limit


def test_every_baud_rate_is_in_the_table() -> None:
    assert [row[0] for row in ALL_RATES] == list(BAUD_RATES)


def test_character_is_eleven_bits_and_flush_time_is_n_plus_3() -> None:
    assert char_time(11000) == pytest.approx(0.001)
    assert residual_time_flush(11000, 0) == pytest.approx(0.003)
    assert residual_time_max(11000, 0) == pytest.approx(0.0045)


def test_response_delay_never_below_start_pause() -> None:
    # At 300 baud two characters take 73.3 ms, more than the 20 ms of A 5.2.1.1.
    assert response_delay_limit(300) == pytest.approx(start_pause(300))
    assert response_delay_limit(300) > MAX_RESPONSE_DELAY
    assert response_delay_limit(9600) == MAX_RESPONSE_DELAY
    assert response_delay_limit(9600, 0.001) == start_pause(9600)
    assert response_delay_limit(9600, 0.05) == 0.05


@pytest.mark.parametrize("bad", [0, -9600, "9600", True])
def test_bad_baud_is_refused(bad: Any) -> None:
    with pytest.raises(ConfigError, match="baud"):
        char_time(bad)


@pytest.mark.parametrize("n", [-1, 253])
def test_net_byte_count_range(n: int) -> None:
    with pytest.raises(ConfigError, match=r"0\.\.252"):
        residual_time_max(9600, n)


def test_bad_response_limit_is_refused() -> None:
    with pytest.raises(ConfigError, match="response delay"):
        response_delay_limit(9600, 0)


def test_residual_extra_chars_extend_the_deadline_and_bad_values_are_refused() -> None:
    plain, nord = LineTiming(19200), LineTiming(19200, residual_extra_chars=0.5)
    assert nord.residual_max(10) - plain.residual_max(10) == pytest.approx(0.5 * 11 / 19200)
    # NORD (NORD BU 0050 1.3.5): 1.5 x (n + 4) characters from the start of STX = from its end + 1
    assert nord.residual_max(10) + nord.char_time == pytest.approx(1.5 * 14 * nord.char_time)
    for bad in (-1, float("nan"), float("inf"), True, "0.5"):
        with pytest.raises(ConfigError, match="residual_extra_chars"):
            LineTiming(19200, residual_extra_chars=bad)  # type: ignore[arg-type]
