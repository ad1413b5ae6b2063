"""BICO inputs as typed values (`pyuss.params.values`): words <-> `Bico` <-> ``r722.2``."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyuss.params.model import ParamInfo, Reading, from_parameter
from pyuss.params.values import ValueRefused, decode, encode, format_value, json_value, parse
from pyuss.profiles import get_profile
from pyuss.protocol.bico import MAX_INDEX, MAX_SOURCE, Bico

DB = get_profile("sinamics-g120c").database()
P0840 = from_parameter(DB.parameter(840), names=DB.profile.names)


def test_p0840_is_a_bico_input_of_two_command_data_sets() -> None:
    assert P0840.bico and P0840.type_name == "uint32" and P0840.array == 2
    assert ParamInfo.from_dict(P0840.to_dict()).bico


def test_the_manuals_example_travels_as_02d2h_fc02h() -> None:
    value = parse(P0840, "r722.2", 1)
    assert value == Bico(722, 2)
    assert encode(P0840, value, 1) == (0x02D2, 0xFC02)
    read = decode(P0840, (0x02D2, 0xFC02), 1)
    assert isinstance(read, Bico) and format_value(P0840, read) == "r722.2"
    reading = Reading(840, 1, P0840, (0x02D2, 0xFC02), read)
    assert reading.text() == "P0840.1 = r722.2 (ON/OFF1 source)"
    assert reading.to_dict()["value"] == "r722.2" == json_value(read)
    assert json.loads(json.dumps(reading.to_dict()))["text"] == "r722.2"


@pytest.mark.parametrize("text", ["r722.2", "722.2", "r0722.2", "r722[2]"])
def test_a_source_is_parsed_in_every_spelling(text: str) -> None:
    assert parse(P0840, text, 1) == Bico(722, 2)


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ("r722.x", r"P0840.1 \(BICO input\): 'r722.x' is not a source such as r722.2"),
        ("", "P0840.1: no value given"),
        ("ON", "is not a source such as r722.2"),
        ("r722.5000", "the index or bit must be 0..1023"),
    ],
)
def test_a_malformed_source_is_refused_before_anything_is_sent(value: str, problem: str) -> None:
    with pytest.raises(ValueRefused, match=problem):
        parse(P0840, value, 1)


def test_other_kinds_of_value_are_refused() -> None:
    with pytest.raises(
        ValueRefused, match=r"P0840\.1 \(BICO input\): 2\.5 is not a source such as r722\.2"
    ):
        encode(P0840, 2.5, 1)
    with pytest.raises(ValueRefused, match="is no BICO source"):
        encode(P0840, 722, 1)  # a plain number carries no 3Fh in PWE2


def test_words_that_carry_no_source_are_shown_as_they_are() -> None:
    value = decode(P0840, (0x0000, 0x0001), 0)
    assert not isinstance(value, Bico)
    assert format_value(P0840, value) == "00000001h (no BICO source)"


def test_a_backup_holds_the_text_and_shows_it_without_quotes() -> None:
    assert format_value(P0840, "r722.2") == "r722.2"
    assert format_value(P0840, ["r2090.0", "r722.2"]) == "[r2090.0, r722.2]"


@given(st.integers(0, MAX_SOURCE), st.integers(0, MAX_INDEX))
def test_encode_decode_and_text_round_trip(pnu: int, index: int) -> None:
    source = Bico(pnu, index)
    words = encode(P0840, source, 0)
    assert words == (pnu, 0xFC00 | index)
    back = decode(P0840, words, 0)
    assert back == source
    assert parse(P0840, format_value(P0840, back), 0) == source
    assert parse(P0840, str(json_value(back)), 0) == source
