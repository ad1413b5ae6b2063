"""Control and status words as a person reads them (`pyuss.params.words`): the hex word and
the names of its set bits, one line, the same on every face."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.params.words import (
    NO_BIT_SET,
    WordKind,
    bit_names,
    changed_bits,
    describe_word,
    format_word,
    word_kind,
)
from pyuss.profiles import Profile, get_profile, profile_names

words = st.integers(0, 0xFFFF)
kinds = st.sampled_from(list(WordKind))
families = st.sampled_from([None, *profile_names()])


def family(name: str | None) -> Profile | None:
    return None if name is None else get_profile(name)


def test_the_line_of_a_start_and_of_a_v20_after_power_up() -> None:
    v20 = get_profile("sinamics-v20")
    assert format_word(0x047F, WordKind.CONTROL, v20) == (
        "047Fh  ON, no OFF2, no OFF3, enable operation, ramp generator enabled, "
        "ramp generator running, setpoint enabled, control by PLC"
    )
    # the low-active warning bits 11, 13, 15 are 1 while no warning is there
    assert format_word(0xEA40, WordKind.STATUS, v20) == (
        "EA40h  switch-on inhibited, control requested, no motor current limit warning, "
        "no motor overload, motor turns right, no inverter overload"
    )
    assert format_word(0, WordKind.STATUS, v20) == f"0000h  {NO_BIT_SET}"


def test_a_drive_of_unknown_kind_gets_no_family_names_for_bits_11_to_15() -> None:
    assert format_word(0xEA40, WordKind.STATUS) == (
        "EA40h  switch-on inhibited, control requested, bit 11, bit 13, bit 14, bit 15"
    )
    nord = get_profile("nord-sk500e")
    assert format_word(0x4800, WordKind.CONTROL, nord) == (
        "4800h  rotation right, parameter set bit 0"
    )


@given(words, kinds, families)
def test_the_line_names_every_set_bit_once_in_bit_order(
    word: int, kind: WordKind, name: str | None
) -> None:
    profile = family(name)
    line = format_word(word, kind, profile)
    hex_part, _, names_part = line.partition("h  ")
    assert int(hex_part, 16) == word and len(hex_part) == 4
    by_name = {text: bit for bit, text in bit_names(kind, profile).items()}
    if word == 0:
        assert names_part == NO_BIT_SET
        return
    back = [by_name[text] for text in names_part.split(", ")]
    # the names read back to the word: each bit named is set, each set bit named, in order
    assert back == sorted(back) and sum(1 << bit for bit in back) == word
    assert "\n" not in line and "(" not in names_part


@pytest.mark.parametrize("name", [None, *profile_names()])
@pytest.mark.parametrize("kind", list(WordKind))
def test_every_bit_of_every_family_has_a_name_of_its_own(name: str | None, kind: WordKind) -> None:
    names = bit_names(kind, family(name))
    assert sorted(names) == list(range(16))
    assert len(set(names.values())) == 16, names
    assert all(", " not in text and text for text in names.values())


@given(words, kinds)
def test_the_dict_says_what_the_line_says(word: int, kind: WordKind) -> None:
    text = describe_word(word, kind, get_profile("micromaster440"))
    data = text.to_dict()
    assert data["word"] == word and data["hex"] == f"{word:04X}"
    assert data["text"] == text.text() == str(text)
    assert sum(1 << b["bit"] for b in data["bits"]) == word


@given(words, words, kinds, families)
def test_the_changed_bits_lead_from_one_word_to_the_other(
    before: int, after: int, kind: WordKind, name: str | None
) -> None:
    profile = family(name)
    text = changed_bits(before, after, kind, profile)
    by_name = {name: bit for bit, name in bit_names(kind, profile).items()}
    word = before
    for part in text.split(", ") if text else []:
        bit = by_name[part[1:]]
        assert (part[0] == "+") == bool(after >> bit & 1)
        word ^= 1 << bit
    assert word == after


@pytest.mark.parametrize("bad", [-1, 0x10000, True, 1.5, "047F"])
def test_a_word_is_a_16_bit_number(bad: object) -> None:
    with pytest.raises(ConfigError, match="16-bit number"):
        describe_word(bad, WordKind.STATUS)  # type: ignore[arg-type]


def test_the_control_and_status_word_parameters_are_those_of_the_family_file() -> None:
    v20 = get_profile("sinamics-v20")
    assert word_kind(v20, 52) is WordKind.STATUS
    assert word_kind(v20, 54) is WordKind.CONTROL
    assert word_kind(v20, 1120, 0) is None
    assert word_kind(get_profile("generic"), 552) is WordKind.STATUS
    assert word_kind(None, 52) is None  # a drive of unknown kind: nothing names them
