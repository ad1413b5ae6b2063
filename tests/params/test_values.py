"""Conversions of `pyuss.params.values`: words <-> typed values <-> text, with properties that
hold for every value of every type (hypothesis), and the refusals a user meets."""

from __future__ import annotations

import math
import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyuss.drive.database import Access
from pyuss.drive.datatypes import DataType, round_float
from pyuss.errors import ConfigError
from pyuss.params import ParamInfo, ValueRefused, decode, encode, format_value, parse
from pyuss.params.values import float_text

INTEGERS = [
    DataType.INT8,
    DataType.INT16,
    DataType.INT32,
    DataType.UINT8,
    DataType.UINT16,
    DataType.UINT32,
]


def info(dtype: DataType, **fields: object) -> ParamInfo:
    return ParamInfo(1, "Test", dtype, **fields)  # type: ignore[arg-type]


@st.composite
def integer_values(draw: st.DrawFn) -> tuple[DataType, int]:
    dtype = draw(st.sampled_from(INTEGERS))
    low, high = dtype.type_range
    return dtype, draw(st.integers(int(low), int(high)))


singles = st.floats(width=32, allow_nan=False, allow_infinity=False)


@given(integer_values())
def test_every_integer_goes_to_words_and_back(case: tuple[DataType, int]) -> None:
    dtype, value = case
    param = info(dtype)
    words = encode(param, value)
    assert len(words) == (2 if dtype.byte_size == 4 else 1)
    assert all(0 <= w <= 0xFFFF for w in words)
    assert decode(param, words) == value


@given(singles)
def test_every_single_precision_float_goes_to_words_and_back(value: float) -> None:
    param = info(DataType.FLOAT)
    words = encode(param, value)
    assert words == struct.unpack(">HH", struct.pack(">f", value))
    assert decode(param, words) == value


@given(integer_values(), st.integers(0, 4))
def test_a_scaled_value_is_raw_times_scaling_and_goes_back_to_the_same_words(
    case: tuple[DataType, int], places: int
) -> None:
    dtype, raw = case
    param = info(dtype, scaling=10.0**-places, unit="s")
    words = encode(param, raw) if places == 0 else encode(info(dtype), raw)
    value = decode(param, words)
    assert value == pytest.approx(raw * 10.0**-places, rel=1e-12, abs=1e-12)
    assert encode(param, value) == words


@given(integer_values(), st.integers(1, 4))
def test_formatted_scaled_values_parse_back_to_the_same_words(
    case: tuple[DataType, int], places: int
) -> None:
    dtype, raw = case
    param = info(dtype, scaling=10.0**-places, unit="s")
    words = encode(info(dtype), raw)
    text = format_value(param, decode(param, words))
    assert text.endswith(" s") and len(text.split()[0].partition(".")[2]) == places
    assert encode(param, parse(param, text)) == words


@given(integer_values())
def test_formatted_integers_parse_back(case: tuple[DataType, int]) -> None:
    dtype, value = case
    param = info(dtype, unit="ms")
    assert parse(param, format_value(param, value)) == value
    assert parse(param, hex(value) if value >= 0 else str(value)) == value


@given(singles)
def test_formatted_floats_parse_back_to_the_same_single(value: float) -> None:
    param = info(DataType.FLOAT, unit="Hz")
    text = format_value(param, value)
    assert text.endswith(" Hz")
    if "e" not in text:
        assert len(text.split()[0].partition(".")[2]) >= 2
    assert parse(param, text) == value


@given(singles)
def test_the_shortest_text_of_a_float_reads_back_as_the_same_single(value: float) -> None:
    text = float_text(value)
    assert round_float(float(text)) == value
    mantissa = text.lstrip("-").partition("e")[0].replace(".", "").strip("0")
    assert len(mantissa) <= 9  # never more digits than a single precision number has


@given(st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=16))
def test_visible_strings_go_to_words_and_back(text: str) -> None:
    param = info(DataType.VISIBLE_STRING, length=16)
    words = encode(param, text)
    assert len(words) == 8
    assert decode(param, words) == text.rstrip()
    typed = text.strip()
    if len(typed) >= 2 and typed[0] == typed[-1] and typed[0] in "\"'":
        typed = typed[1:-1]  # a quoted text is taken without its quotes
    assert parse(param, text) == typed


@given(st.binary(max_size=6))
def test_octet_strings_go_to_words_and_back(data: bytes) -> None:
    param = info(DataType.OCTET_STRING, length=6)
    words = encode(param, data)
    assert decode(param, words) == data.ljust(6, b"\0")
    assert parse(param, data.hex(" ")) == data


@given(st.integers(-(2**40), 2**40), st.sampled_from(INTEGERS))
def test_a_value_outside_the_type_is_refused_and_nothing_is_encoded(
    value: int, dtype: DataType
) -> None:
    low, high = dtype.type_range
    param = info(dtype)
    if low <= value <= high:
        assert decode(param, encode(param, value)) == value
    else:
        with pytest.raises(ValueRefused, match=f"does not fit {dtype.label}"):
            encode(param, value)


@given(st.floats(allow_nan=False))
def test_limits_hold_for_every_value(value: float) -> None:
    param = info(DataType.FLOAT, minimum=0.0, maximum=650.0, unit="s")
    single = round_float(value) if abs(value) < 3e38 else value
    if math.isfinite(single) and 0.0 <= single <= 650.0:
        assert decode(param, encode(param, value)) == single
    else:
        with pytest.raises(ValueRefused):
            encode(param, value)


RAMP = info(DataType.FLOAT, unit="s", minimum=0.0, maximum=650.0)
NORD_RAMP = ParamInfo(102, "Ramp-up time", DataType.UINT16, unit="s", scaling=0.01, maximum=32000)
BAUD = ParamInfo(
    2010,
    "USS baudrate",
    DataType.UINT16,
    array=2,
    minimum=3,
    maximum=13,
    texts={6: "9600 BAUD", 7: "19200 BAUD"},
)


def test_what_a_user_types_is_read_by_the_parameters_type() -> None:
    assert [parse(RAMP, t) for t in ("10", "10.0", "10 s", "10s", "500 ms", "0.5 min")] == [
        10.0,
        10.0,
        10.0,
        10.0,
        0.5,
        30.0,
    ]
    assert parse(NORD_RAMP, "2.05") == 2.05 and encode(NORD_RAMP, 2.05) == (205,)
    assert parse(BAUD, "19200 baud") == 7 and parse(BAUD, "7") == 7
    assert parse(info(DataType.UINT16), "0x7000") == 0x7000
    assert parse(info(DataType.INT16), "-5") == -5


@pytest.mark.parametrize(
    ("param", "text", "message"),
    [
        (RAMP, "700", r"P1: 700.00 s is outside 0.00..650.00 s"),
        (RAMP, "fast", "'fast' is not a number"),
        (RAMP, "0x10", "raw bit pattern"),
        (RAMP, "10 Hz", "unit 'Hz' does not fit: its unit is 's'"),
        (NORD_RAMP, "2.005", "not a multiple of the resolution 0.01 s"),
        (NORD_RAMP, "400", r"400.00 s is outside 0.00..320.00 s"),
        (BAUD, "2", "is outside 3..13"),
        (BAUD, "115200 BAUD", "is not a number nor one of 9600 BAUD, 19200 BAUD"),
        (info(DataType.INT16), "2.5", "takes a whole number"),
        (info(DataType.UINT16), "\u0661\u0660", "is not a number"),  # 10 in Arabic-Indic digits
        (RAMP, "\uff15 s", "is not a number"),  # a full-width 5
        (info(DataType.V2), "0x4000", "bit field"),
        (info(DataType.VISIBLE_STRING, length=4), "too long", "at most 4"),
        (info(DataType.UINT16, allowed=(0, 3, 4, 127)), "5", "is not one of 0, 3, 4, 127"),
        (info(DataType.UINT16, reset_only=True), "5", "may only be reset to 0"),
    ],
)
def test_wrong_values_are_refused_with_one_clear_line(
    param: ParamInfo, text: str, message: str
) -> None:
    with pytest.raises(ValueRefused, match=message) as caught:
        parse(param, text)
    assert isinstance(caught.value, ConfigError)  # bad input: exit 2 in the commands
    assert "\n" not in str(caught.value)


def test_values_show_as_a_drive_engineer_reads_them() -> None:
    assert format_value(RAMP, 10.0) == "10.00 s"
    assert format_value(RAMP, 0.001) == "0.001 s"
    assert format_value(NORD_RAMP, 2.0) == "2.00 s"
    assert format_value(BAUD, 6) == "6 [9600 BAUD]"
    assert format_value(BAUD, [6, 7]) == "[6 [9600 BAUD], 7 [19200 BAUD]]"
    assert format_value(info(DataType.V2), 0x4000) == "4000h"
    assert format_value(info(DataType.VISIBLE_STRING, length=8), "ABC     ") == '"ABC"'
    assert format_value(None, 0x4000) == "16384 (4000h)"
    assert format_value(None, 0x12345678) == "305419896 (12345678h)"
    assert float_text(0.009999999776482582) == "0.01"


def test_access_is_part_of_the_record() -> None:
    assert not info(DataType.UINT16, access=Access.RO).writable
    assert info(DataType.UINT16, access=Access.PROTECTED).writable
