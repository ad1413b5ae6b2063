"""BICO sources in PWE1/PWE2 (`pyuss.protocol.bico`): the manual's example, the codec's
round trip, and what is no source."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.protocol.bico import MAX_INDEX, MAX_SOURCE, Bico, BicoError, is_bico, parse_bico

sources = st.builds(Bico, st.integers(0, MAX_SOURCE), st.integers(0, MAX_INDEX))


def test_the_manuals_example_p0840_1_is_722_2() -> None:
    # p0840[1] = 722.2 (digital input 2): PWE1 = 2D2h (722), PWE2 = 3Fh << 10 | 2 = FC02h
    source = parse_bico("r722.2")
    assert source.words == (0x02D2, 0xFC02)
    assert int(source) == 0x02D2_FC02  # as a U32 value travels: high word first
    assert (source.pnu, source.index) == (722, 2)
    assert str(source) == source.text() == "r722.2" == f"{source}"
    assert Bico.from_words([0x02D2, 0xFC02]) == source
    assert Bico(2090, 0).words == (0x082A, 0xFC00)  # r2090.0: control word 1 bit 0


@pytest.mark.parametrize("text", ["r722.2", "722.2", "R722.2", "r0722.2", "r722[2]", " 722.2 "])
def test_the_spellings_of_a_source(text: str) -> None:
    assert parse_bico(text) == Bico(722, 2)


def test_a_source_without_index_is_index_0() -> None:
    assert parse_bico("r63") == Bico(63, 0)


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("r722.x", "is not a source such as r722.2"),
        ("", "is not a source"),
        ("722.2.1", "is not a source"),
        ("x722", "is not a source"),
        ("r-1.0", "is not a source"),
        ("r70000.0", "source parameter must be 0..65535"),
        ("r722.1024", "index or bit must be 0..1023"),
    ],
)
def test_what_is_no_source_is_refused_saying_so(text: str, problem: str) -> None:
    with pytest.raises(BicoError, match=problem) as caught:
        parse_bico(text)
    assert isinstance(caught.value, ConfigError)


def test_words_without_the_drive_object_are_no_source() -> None:
    assert not is_bico(0x02D2_0002)
    with pytest.raises(BicoError, match=r"02D2h 0002h is no BICO source: PWE2 bits 15..10 are 00h"):
        Bico.from_raw(0x02D2_0002)
    with pytest.raises(BicoError, match="two 16-bit words"):
        Bico.from_words([0x02D2])
    with pytest.raises(BicoError, match=r"0\.\.1023"):
        Bico(722, 1024)


@given(sources)
def test_words_and_text_give_back_the_source(source: Bico) -> None:
    pwe1, pwe2 = source.words
    assert pwe1 == source.pnu and pwe2 >> 10 == 0x3F and pwe2 & 0x3FF == source.index
    assert Bico.from_words(source.words) == source
    assert Bico.from_raw(int(source)) == source and is_bico(int(source))
    assert parse_bico(source.text()) == source
    assert parse_bico(f"{source.pnu}.{source.index}") == source


@given(st.integers(0, 0xFFFF_FFFF))
def test_any_32_bit_value_is_a_source_or_refused(raw: int) -> None:
    if raw & 0xFC00 == 0xFC00:
        assert int(Bico.from_raw(raw)) == raw
    else:
        with pytest.raises(BicoError):
            Bico.from_raw(raw)
