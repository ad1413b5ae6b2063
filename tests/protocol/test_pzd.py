"""Process data (C 5): control and status word bits, scaling 4000h = 100 %."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.protocol.pzd import (
    CONTROL_BITS,
    STATUS_BITS,
    ControlWord,
    StatusWord,
    describe_bits,
    join_dword,
    percent_to_raw16,
    percent_to_raw32,
    raw16_to_percent,
    raw32_to_percent,
    split_dword,
)


def test_control_bits_of_tables_5_2_to_5_4() -> None:
    assert ControlWord.ON == 1 << 0
    assert ControlWord.NO_OFF2 == ControlWord.NO_COAST_STOP == 1 << 1
    assert ControlWord.NO_OFF3 == ControlWord.NO_QUICK_STOP == 1 << 2
    assert ControlWord.ENABLE_OPERATION == 1 << 3
    assert ControlWord.ENABLE_RAMP_GENERATOR == 1 << 4
    assert ControlWord.START_RAMP_GENERATOR == 1 << 5
    assert ControlWord.ENABLE_SETPOINT == 1 << 6
    assert ControlWord.ACKNOWLEDGE_FAULT == 1 << 7
    assert ControlWord.JOG1 == 1 << 8
    assert ControlWord.JOG2 == 1 << 9
    assert ControlWord.CONTROL_BY_PLC == 1 << 10
    assert ControlWord(0x047E) == ControlWord(0x047F) & ~ControlWord.ON


def test_status_bits_of_tables_5_5_and_5_6() -> None:
    names = [
        "READY_TO_SWITCH_ON",
        "READY",
        "OPERATION_ENABLED",
        "FAULT",
        "NO_OFF2",
        "NO_OFF3",
        "SWITCH_ON_INHIBITED",
        "WARNING",
        "IN_TOLERANCE",
        "CONTROL_REQUESTED",
        "TARGET_REACHED",
    ]
    for bit, name in enumerate(names):
        assert StatusWord[name] == 1 << bit


def test_describe_spells_out_active_low_bits() -> None:
    rows = describe_bits(0x047E, CONTROL_BITS)
    assert rows[0] == (0, False, "OFF1: ramp down and switch off")
    assert rows[1] == (1, True, "no OFF2")
    assert rows[10] == (10, True, "control by PLC (process data valid)")
    assert rows[11] == (11, False, "device-specific")
    rows = describe_bits(0x0000, STATUS_BITS)
    assert rows[4] == (4, False, "OFF2 pending")
    assert len(rows) == 16


@pytest.mark.parametrize(
    ("percent", "raw"),
    [(100.0, 0x4000), (50.0, 0x2000), (0.0, 0), (-100.0, 0xC000), (-200.0, 0x8000)],
)
def test_16_bit_scaling(percent: float, raw: int) -> None:
    assert percent_to_raw16(percent) == raw
    assert raw16_to_percent(raw) == percent


def test_32_bit_scaling() -> None:
    assert percent_to_raw32(100.0) == 0x4000_0000
    assert percent_to_raw32(-50.0) == 0xE000_0000
    assert raw32_to_percent(0x2000_0000) == 50.0
    assert split_dword(percent_to_raw32(100.0)) == (0x4000, 0)
    assert join_dword(0x4000, 0) == 0x4000_0000


@pytest.mark.parametrize("bad", [200.0, -200.01, float("nan"), "50"])
def test_out_of_range_percent_is_refused(bad: object) -> None:
    with pytest.raises(ConfigError):
        percent_to_raw16(bad)  # type: ignore[arg-type]


def test_raw_value_range_is_checked() -> None:
    with pytest.raises(ConfigError, match="16-bit"):
        raw16_to_percent(0x10000)
    with pytest.raises(ConfigError):
        split_dword(-1)
    with pytest.raises(ConfigError):
        join_dword(0x10000, 0)


@given(st.integers(0, 0xFFFF))
@settings(max_examples=100)
def test_raw16_round_trip(raw: int) -> None:
    assert percent_to_raw16(raw16_to_percent(raw)) == raw


@given(st.integers(0, 0xFFFF_FFFF))
@settings(max_examples=100)
def test_raw32_round_trip(raw: int) -> None:
    assert percent_to_raw32(raw32_to_percent(raw)) == raw
    assert join_dword(*split_dword(raw)) == raw
