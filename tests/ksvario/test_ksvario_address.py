"""Address map (KS VARIO interface description 9.2, reading 11): the vectors, the three views, user
input."""

from __future__ import annotations

import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.ksvario.address import Address, Area, View, channel_area, parse_address
from support.paths import load_vectors

VECTORS = load_vectors("ksvario")


@pytest.mark.parametrize("vec", VECTORS["addresses"], ids=lambda v: v["section"][:5])
def test_vector_addresses_round_trip(vec: dict[str, str]) -> None:
    """Each vector decodes to the channel and view its name gives, and encodes back."""
    word = int(vec["address"], 16)
    address = Address.decode(word)
    assert address.encode() == int(vec["expect"], 16)
    found = re.search(r"channel (\d+) (Integer|FixPoint1|Float)", vec["name"])
    assert found is not None, vec["name"]
    assert address.channel_number == int(found.group(1))
    assert address.view.name == found.group(2).upper()


def test_worked_examples_are_built_from_area_and_datum() -> None:
    # 4.5.1: FixPoint1, channel 1, Pb1 = 96h
    assert Address.channel(1, 0x96, View.FIXPOINT1).encode() == 0x4496
    # 4.5.2: float, channel 2, SPLo = 69h -> offset D2h
    assert Address.channel(2, 0x69, View.FLOAT).encode() == 0x8CD2
    # 4.5.3: integer, channel 30, td1 = 9Ah
    assert Address.channel(30, 0x9A, View.INTEGER).encode() == 0x3E9A
    # 4.5.4: channel 30's float area starts at FC00h (reading 11: the text's 3C00h is an erratum)
    assert Address.of(View.FLOAT, channel_area(30), 0).encode() == 0xFC00
    fd09 = Address.decode(0xFD09)
    assert (fd09.view, fd09.channel_number, fd09.offset, fd09.datum) == (
        View.FLOAT,
        30,
        0x109,
        0x84,
    )


def test_area_starts_of_the_directory() -> None:
    # 9.2 tables: integer areas of 512 words, float areas of 1024 addresses
    assert Address.of(View.INTEGER, Area.VISUALISATION, 0).encode() == 0x200
    assert Address.channel(1, 0).encode() == 0x400
    assert Address.channel(2, 0).encode() == 0x600
    assert Address.channel(30, 0x1FF).encode() == 0x3FFF
    assert Address.of(View.FLOAT, Area.DEVICE, 0).encode() == 0x8000
    assert Address.of(View.FLOAT, Area.VISUALISATION, 0).encode() == 0x8400
    assert Address.channel(1, 0, View.FLOAT).encode() == 0x8800
    assert Address.channel(30, 0x1FF, View.FLOAT).encode() == 0xFFFE


def test_views_convert_the_same_datum() -> None:
    a = Address.decode(0x4496)
    assert a.as_view(View.INTEGER).encode() == 0x0496
    assert a.as_view(View.FLOAT).encode() == 0x8800 + 2 * 0x96
    assert Address.decode(0x8CD2).as_view(View.INTEGER).encode() == 0x600 + 0x69


@settings(max_examples=200)
@given(st.integers(0, 0xFFFF))
def test_every_word_decodes_and_encodes_to_itself(word: int) -> None:
    assert Address.decode(word).encode() == word


@settings(max_examples=100)
@given(st.integers(0, 31), st.integers(0, 511), st.sampled_from(list(View)))
def test_datum_survives_every_view(area: int, datum: int, view: View) -> None:
    a = Address.of(view, area, datum)
    for other in View:
        assert a.as_view(other).datum == datum
        assert a.as_view(other).area == area


def test_out_of_range_parts_are_refused() -> None:
    with pytest.raises(ConfigError, match="channel 31"):
        channel_area(31)
    with pytest.raises(ConfigError, match="datum 512"):
        Address.channel(1, 512)
    with pytest.raises(ConfigError, match="16-bit"):
        Address.decode(0x10000)


@pytest.mark.parametrize(
    ("text", "word"),
    [
        ("0x4496", 0x4496),
        ("4496h", 0x4496),
        ("17558", 0x4496),
        ("fix1:ch1:0x96", 0x4496),
        ("float:ch2:69h", 0x8CD2),
        ("int:ch30:0x9a", 0x3E9A),
        ("int:vis:5", 0x205),
        ("float:dev:1", 0x8002),
    ],
)
def test_parse_address(text: str, word: int) -> None:
    assert parse_address(text).encode() == word


@pytest.mark.parametrize("text", ["", "0xZZ", "fix1:ch31:1", "bogus:ch1:1", "int:ch1", "70000"])
def test_parse_address_names_bad_input(text: str) -> None:
    with pytest.raises(ConfigError, match="bad address"):
        parse_address(text)
