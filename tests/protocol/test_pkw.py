"""Parameter channel (C 4): IDs, request/response pairing, error numbers, IND, PWE payloads."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError, TelegramError
from pyuss.protocol.pkw import (
    INDEX_ALL,
    ErrorNumber,
    Pkw,
    RequestId,
    ResponseId,
    TextIndex,
    bytes_to_words,
    error_meaning,
    expected_responses,
    make_index,
    positive_responses,
    pwe_dword,
    pwe_dwords,
    pwe_float,
    pwe_text,
    pwe_word,
    pwe_words,
    words_to_bytes,
    words_to_text,
)

R = ResponseId

# C Table 4.3, request -> positive responses, written out from the USS specification.
TABLE_4_3 = {
    0: {0},
    1: {1, 2},
    2: {1},
    3: {2},
    4: {3},
    5: {3},
    6: {4, 5},
    7: {4},
    8: {5},
    9: {6},
    10: set(),
    11: {5},
    12: {4},
    13: {2},
    14: {1},
    15: {15},
}


def test_all_sixteen_ids_have_names() -> None:
    assert [int(r) for r in RequestId] == list(range(16))
    assert [int(r) for r in ResponseId] == list(range(16))
    assert RequestId.READ_VALUE.german == "PWE anfordern"
    assert RequestId.TEXT.text == "read or write text"
    assert ResponseId.REFUSED.german.startswith("Auftrag nicht ausführbar")
    assert ResponseId.NO_AUTHORITY.text == "no parameter change rights"
    for member in (*RequestId, *ResponseId):
        assert member.german and member.text


@pytest.mark.parametrize("request_id", list(RequestId))
def test_positive_responses_follow_table_4_3(request_id: RequestId) -> None:
    assert {int(r) for r in positive_responses(request_id)} == TABLE_4_3[request_id]


def test_expected_responses_add_the_negative_ones() -> None:
    assert expected_responses(RequestId.NO_JOB) == {R.NO_RESPONSE}
    assert expected_responses(RequestId.READ_VALUE) == {R.VALUE_WORD, R.VALUE_DWORD, R.REFUSED}
    assert expected_responses(RequestId.WRITE_WORD) == {R.VALUE_WORD, R.REFUSED, R.NO_AUTHORITY}
    assert expected_responses(RequestId.RESERVED_10) == {R.REFUSED}
    assert R.NO_AUTHORITY in expected_responses(RequestId.TEXT)
    for request_id in RequestId:
        assert not any(r.is_spontaneous for r in expected_responses(request_id))


def test_indexed_and_change_flags() -> None:
    indexed = {r for r in RequestId if r.is_indexed}
    assert {int(r) for r in indexed} == {4, 5, 6, 7, 8, 11, 12, 15}
    assert {int(r) for r in ResponseId if r.is_indexed} == {3, 4, 5, 11, 12, 15}
    assert {int(r) for r in RequestId if r.is_change} == {2, 3, 5, 7, 8, 11, 12, 13, 14, 15}
    assert {int(r) for r in ResponseId if r.is_spontaneous} == {9, 10, 11, 12}
    assert {int(r) for r in ResponseId if r.is_negative} == {7, 8}


def test_error_numbers() -> None:
    assert [int(e) for e in ErrorNumber] == list(range(8))
    assert error_meaning(0) == "illegal parameter number"
    assert error_meaning(2) == "lower or upper limit exceeded"
    assert error_meaning(7) == "description element cannot be changed"
    assert "PROFIBUS" in error_meaning(17)
    assert error_meaning(101) == "device-specific error 101"
    assert error_meaning(101, {101: "undetermined fault"}) == "undetermined fault"
    assert error_meaning(0, {0: "other"}) == "illegal parameter number"


def test_pke_layout_and_toggle() -> None:
    pkw = Pkw(9, 52, spm_toggle=True, values=(0x0123,))
    assert pkw.pke == 0x9834
    assert Pkw.from_words(pkw.words()) == pkw
    assert Pkw.from_words([0x73E7, 0, 0]).pnu == 999


@pytest.mark.parametrize(
    ("kwargs", "text"),
    [
        ({"id": 16}, "ID"),
        ({"id": 1, "pnu": 2048}, "PNU"),
        ({"id": 1, "index": 0x10000}, "IND"),
        ({"id": 1, "values": (0x10000,)}, "PWE word"),
        ({"id": 1, "values": (-1,)}, "PWE word"),
    ],
)
def test_pkw_validation(kwargs: dict[str, object], text: str) -> None:
    with pytest.raises(ConfigError, match=text):
        Pkw(**kwargs)  # type: ignore[arg-type]


def test_from_words_needs_pke_and_ind() -> None:
    with pytest.raises(TelegramError, match="PKE and IND"):
        Pkw.from_words([0x1000])


def test_index_bits() -> None:
    ind = make_index(3, text=TextIndex.WRITE | TextIndex.VALUE_TEXTS, device=5)
    assert ind == 0x1703
    pkw = Pkw(RequestId.TEXT, 7, ind)
    assert pkw.subindex == 3
    assert pkw.text_bits == TextIndex.WRITE | TextIndex.VALUE_TEXTS
    assert pkw.device_bits == 5
    assert make_index(INDEX_ALL) == 0x00FF
    for bad in ({"subindex": 256}, {"text": 0x400}, {"device": 64}):
        with pytest.raises(ConfigError, match="IND"):
            make_index(**bad)  # type: ignore[arg-type]


def test_is_answer_to_checks_id_pnu_and_index_where_it_matters() -> None:
    read = Pkw(RequestId.READ_VALUE, 52)
    assert Pkw(R.VALUE_WORD, 52, values=(1,)).is_answer_to(read)
    assert Pkw(R.VALUE_DWORD, 52, values=(1, 2)).is_answer_to(read)
    assert not Pkw(R.VALUE_WORD, 53, values=(1,)).is_answer_to(read)
    assert not Pkw(R.ARRAY_WORD, 52, values=(1,)).is_answer_to(read)
    # An old answer to "no job" is no answer to the new read job.
    assert not Pkw(R.NO_RESPONSE).is_answer_to(read)
    assert Pkw(R.NO_RESPONSE, 12).is_answer_to(Pkw(RequestId.NO_JOB))
    # Not indexed: IND is not compared.
    assert Pkw(R.VALUE_WORD, 52, 9, values=(1,)).is_answer_to(read)
    # Indexed: the low byte is compared, device bits are not.
    array = Pkw(RequestId.READ_ARRAY, 4, 2)
    assert Pkw(R.ARRAY_WORD, 4, 2).is_answer_to(array)
    assert Pkw(R.ARRAY_WORD, 4, 0x0402).is_answer_to(array)
    assert not Pkw(R.ARRAY_WORD, 4, 3).is_answer_to(array)
    assert Pkw(R.REFUSED, 4, 2, values=(3,)).is_answer_to(array)
    assert not Pkw(R.REFUSED, 4, 3, values=(3,)).is_answer_to(array)
    # Texts: bits 8 and 9 are part of the job.
    text = Pkw(RequestId.TEXT, 7, make_index(3, text=TextIndex.VALUE_TEXTS))
    assert Pkw(R.TEXT, 7, 0x0203).is_answer_to(text)
    assert not Pkw(R.TEXT, 7, 0x0003).is_answer_to(text)
    # No PKW authority answers change jobs only.
    assert Pkw(R.NO_AUTHORITY, 18).is_answer_to(Pkw(RequestId.WRITE_WORD, 18))
    assert not Pkw(R.NO_AUTHORITY, 18).is_answer_to(Pkw(RequestId.READ_VALUE, 18))
    # A spontaneous message never answers.
    assert not Pkw(R.SPONTANEOUS_WORD, 52, values=(1,)).is_answer_to(read)


def test_word_and_dword_readers() -> None:
    assert Pkw(1, values=(0xFFFF,)).word(signed=True) == -1
    assert Pkw(1, values=(0, 0x7000)).word() == 0x7000
    assert Pkw(2, values=(0xFFFF, 0xFFFE)).dword(signed=True) == -2
    assert Pkw(2, values=(0x1234, 0x5678)).dword() == 0x1234_5678
    assert Pkw(7, values=(5,)).error_number == 5
    assert Pkw(1, values=(5,)).error_number is None
    assert Pkw(7, values=(0, 5)).error_number == 5  # PKW 4: a word travels in PWE2
    assert Pkw(7, values=(5, 0, 0)).error_number == 5  # variable, padded: PWE1
    assert Pkw(7).error_number is None
    with pytest.raises(TelegramError, match="word value"):
        Pkw(1).word()
    with pytest.raises(TelegramError, match="double word"):
        Pkw(2, values=(1,)).dword()


def test_pwe_helpers() -> None:
    assert pwe_word(0x7000) == (0x7000,)
    assert pwe_word(-1) == (0xFFFF,)
    assert pwe_dword(0x4000_0000) == (0x4000, 0)
    assert pwe_dword(-2) == (0xFFFF, 0xFFFE)
    assert pwe_words([1, -1]) == (1, 0xFFFF)
    assert pwe_dwords([1, 0x10002]) == (0, 1, 1, 2)
    assert pwe_float(1.0) == (0x3F80, 0x0000)
    assert Pkw(2, values=pwe_float(-2.5)).float32() == -2.5
    for bad_word in (0x10000, -0x8001, 1.5, True):
        with pytest.raises(ConfigError, match="word value"):
            pwe_word(bad_word)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="double word"):
        pwe_dword(0x1_0000_0000)
    with pytest.raises(ConfigError, match="floating point"):
        pwe_float(1e300)


def test_text_first_character_first() -> None:
    words = pwe_text("300 BAUD", 16)
    assert words == (0x3330, 0x3020, 0x4241, 0x5544, 0x2020, 0x2020, 0x2020, 0x2020)
    assert words_to_text(words) == "300 BAUD"
    assert words_to_text(words, strip=False) == "300 BAUD" + " " * 8
    assert pwe_text("abc") == (0x6162, 0x6320)
    assert words_to_text(pwe_text("Überlast")) == "Überlast"
    with pytest.raises(ConfigError, match="longer than 4"):
        pwe_text("too long", 4)
    with pytest.raises(ConfigError, match="Latin-1"):
        pwe_text("€")


def test_byte_strings_in_storage_order() -> None:
    assert bytes_to_words(b"\x01\x02\x03") == (0x0102, 0x0300)
    assert words_to_bytes([0x0102, 0x0300]) == b"\x01\x02\x03\x00"


@given(st.integers(-0x8000_0000, 0xFFFF_FFFF))
@settings(max_examples=100)
def test_dword_round_trip(value: int) -> None:
    pkw = Pkw(2, values=pwe_dword(value))
    assert pkw.dword(signed=value < 0) == value


@given(st.floats(width=32, allow_nan=False))
@settings(max_examples=100)
def test_float_round_trip(value: float) -> None:
    result = Pkw(2, values=pwe_float(value)).float32()
    assert result == value or (math.isinf(value) and result == value)


@given(st.text(alphabet=st.characters(min_codepoint=0x21, max_codepoint=0xFF), max_size=40))
@settings(max_examples=100)
def test_text_round_trip(text: str) -> None:
    assert words_to_text(pwe_text(text)) == text
