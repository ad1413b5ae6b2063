"""Data types and their PKW words (C 6): widths, byte order, sign, IEEE floats, strings."""

from __future__ import annotations

import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.drive.datatypes import TYPE_NAMES, DataType, decode, encode
from pyuss.drive.faults import ParameterFault
from pyuss.protocol.pkw import ErrorNumber

INTEGER_TYPES = [t for t in DataType if t.is_integer]


@pytest.mark.parametrize("dtype", INTEGER_TYPES)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_integers_round_trip_through_words(dtype: DataType, data: st.DataObject) -> None:
    low, high = dtype.type_range
    value = data.draw(st.integers(int(low), int(high)))
    words = encode(dtype, value)
    assert len(words) == dtype.word_count()
    assert all(0 <= w <= 0xFFFF for w in words)
    assert decode(dtype, words) == value


@settings(max_examples=60, deadline=None)
@given(st.floats(width=32, allow_nan=False, allow_infinity=False))
def test_floats_travel_as_ieee_bits_high_word_first(value: float) -> None:
    words = encode(DataType.FLOAT, value)
    assert words == struct.unpack(">HH", struct.pack(">f", value))
    assert decode(DataType.FLOAT, words) == value


def test_known_word_patterns() -> None:
    assert encode(DataType.INT16, -1) == (0xFFFF,)
    assert encode(DataType.INT32, 0x4000_0000) == (0x4000, 0x0000)  # C 8 example 5
    assert encode(DataType.UINT32, 0x1234_5678) == (0x1234, 0x5678)  # high word first
    assert encode(DataType.INT32, -2) == (0xFFFF, 0xFFFE)
    assert encode(DataType.FLOAT, 1.0) == (0x3F80, 0x0000)
    assert decode(DataType.INT8, [0xFF80]) == -128


@pytest.mark.parametrize(
    ("dtype", "word"),
    [(DataType.INT8, 0x0080), (DataType.UINT8, 0x0100), (DataType.INT8, 0xFF7F)],
)
def test_word_outside_an_8_bit_type_is_refused_with_error_2(dtype: DataType, word: int) -> None:
    with pytest.raises(ParameterFault) as info:
        decode(dtype, [word])
    assert info.value.number == ErrorNumber.LIMIT_EXCEEDED


@pytest.mark.parametrize(
    ("dtype", "words"),
    [(DataType.UINT16, [1, 2]), (DataType.INT32, [1]), (DataType.FLOAT, [0x3F80])],
)
def test_wrong_word_count_is_error_5(dtype: DataType, words: list[int]) -> None:
    with pytest.raises(ParameterFault) as info:
        decode(dtype, words)
    assert info.value.number == ErrorNumber.WRONG_TYPE


@pytest.mark.parametrize("bits", [(0x7FC0, 0x0000), (0x7F80, 0x0000), (0xFF80, 0x0000)])
def test_nan_and_infinity_are_refused(bits: tuple[int, int]) -> None:
    with pytest.raises(ParameterFault) as info:
        decode(DataType.FLOAT, bits)
    assert info.value.number == ErrorNumber.LIMIT_EXCEEDED


def test_text_goes_first_character_first_blank_padded() -> None:
    # C 8 example 7 / uss.json read_text_response: "300 BAUD" in 16 characters
    words = encode(DataType.VISIBLE_STRING, "300 BAUD", 16)
    assert [f"{w:04X}" for w in words] == [
        "3330",
        "3020",
        "4241",
        "5544",
        "2020",
        "2020",
        "2020",
        "2020",
    ]
    assert decode(DataType.VISIBLE_STRING, words, 16) == "300 BAUD        "


def test_octets_keep_storage_order_and_pad_odd_lengths() -> None:
    assert encode(DataType.OCTET_STRING, b"\x01\x02\x03", 3) == (0x0102, 0x0300)
    assert decode(DataType.OCTET_STRING, [0x0102, 0x0300], 3) == b"\x01\x02\x03"


def test_text_with_invisible_characters_is_refused() -> None:
    with pytest.raises(ParameterFault):
        decode(DataType.VISIBLE_STRING, [0x4107], 2)


@settings(max_examples=40, deadline=None)
@given(st.binary(min_size=1, max_size=12))
def test_octets_round_trip(data: bytes) -> None:
    words = encode(DataType.OCTET_STRING, data, len(data))
    assert len(words) == math.ceil(len(data) / 2)
    assert decode(DataType.OCTET_STRING, words, len(data)) == data


def test_siemens_short_type_names_are_accepted() -> None:
    assert TYPE_NAMES["O2"] is DataType.UINT16  # "Typ: O2" (C 3.1), unsigned 16 (C 8 ex. 7)
    assert TYPE_NAMES["I4"] is DataType.INT32
    assert DataType.UINT16.value == 6  # PROFIBUS type code in PBE element 1
