"""The Broadcast Enable Array and the rules of the appendix table."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError, TelegramError
from pyuss.protocol.broadcast import BroadcastEnableArray, apply_broadcast
from pyuss.protocol.pkw import Pkw

BEA = BroadcastEnableArray


def test_examples_of_the_appendix() -> None:
    assert BEA.from_selection(words=[2]) == BEA(0x0005, 0, 0, 0)
    assert BEA.from_selection(bits={1: 0x0020}) == BEA(0x0003, 0x0020, 0, 0)


def test_whole_command_words_enable_all_their_bits() -> None:
    assert BEA.from_selection(words=[1, 4, 5, 15]) == BEA(0x8033, 0xFFFF, 0xFFFF, 0xFFFF)
    assert BEA.from_selection(words=[4], bits={4: 0x00F0}) == BEA(0x0011, 0, 0x00F0, 0)


def test_selection_errors() -> None:
    with pytest.raises(ConfigError, match="16 is never taken"):
        BEA.from_selection(words=[16])
    with pytest.raises(ConfigError, match=r"1\.\.15"):
        BEA.from_selection(words=[0])
    with pytest.raises(ConfigError, match="words 1, 4 and 5"):
        BEA.from_selection(bits={2: 1})
    with pytest.raises(ConfigError, match="bit mask"):
        BEA.from_selection(bits={1: 0x10000})
    with pytest.raises(ConfigError, match="enable word a"):
        BEA(0x10000)


def test_words_and_pkw() -> None:
    bea = BEA(0x0003, 0x0020, 0, 0)
    assert bea.to_pkw_words() == (3, 0x20, 0, 0)
    assert BEA.from_words([3, 0x20, 0, 0]) == bea
    assert bea.to_pkw() == Pkw(0, 3, 0x20, False, (0, 0))
    assert BEA.from_pkw(bea.to_pkw()) == bea
    with pytest.raises(TelegramError, match="4 words"):
        BEA.from_words([3, 0, 0])
    assert bea.flag
    assert bea.enabled_words == {1}


def test_apply_follows_the_table() -> None:
    previous = [0x047E, 100, 200, 0xAAAA, 0x5555, *range(6, 16), 0x1616]
    received = [0x0021, 1, 2, 0x0F0F, 0xF0F0, *range(106, 116), 0x9999]
    bea = BEA.from_selection(words=[2, 6, 15], bits={1: 0x0020, 4: 0x00FF})
    result = apply_broadcast(previous, received, bea)
    assert result[0] == 0x047E | 0x0020  # word 1: only bit 5
    assert result[1] == 1  # word 2 enabled
    assert result[2] == 200  # word 3 not enabled
    assert result[3] == 0xAA0F  # word 4 through mask c
    assert result[4] == 0x5555  # word 5 not enabled in word a
    assert result[5] == 106  # word 6 enabled
    assert result[6:14] == previous[6:14]
    assert result[14] == 115  # word 15 enabled
    assert result[15] == 0x1616  # word 16 never


def test_word_16_is_never_taken_even_with_every_bit_set() -> None:
    bea = BEA(0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF)
    assert bea.mask(16) == 0
    result = apply_broadcast([0] * 16, [0xFFFF] * 16, bea)
    assert result == [0xFFFF] * 15 + [0]


def test_word_a_bit_is_needed_for_command_words() -> None:
    # Mask b set, but word 1 not enabled in word a: nothing taken (condition I of the appendix).
    bea = BEA(0x0001, 0xFFFF, 0, 0)
    assert apply_broadcast([0x047E], [0x0001], bea) == [0x047E]


def test_without_flag_nothing_is_taken() -> None:
    assert apply_broadcast([1, 2], [3, 4], BEA(0xFFFE, 0xFFFF)) == [1, 2]


def test_length_mismatch() -> None:
    with pytest.raises(TelegramError, match="carries 3 PZD words, the image has 2"):
        apply_broadcast([0, 0], [0, 0, 0], BEA(1))


@given(
    st.lists(st.integers(0, 0xFFFF), min_size=16, max_size=16),
    st.lists(st.integers(0, 0xFFFF), min_size=16, max_size=16),
    st.tuples(*[st.integers(0, 0xFFFF)] * 4),
)
@settings(max_examples=100)
def test_every_bit_comes_from_one_of_the_two(
    previous: list[int], received: list[int], words: tuple[int, int, int, int]
) -> None:
    bea = BEA(*words)
    result = apply_broadcast(previous, received, bea)
    for k, (old, new, out) in enumerate(zip(previous, received, result, strict=True), 1):
        mask = bea.mask(k)
        assert out == (old & ~mask & 0xFFFF) | (new & mask)
        assert out & ~mask & 0xFFFF == old & ~mask & 0xFFFF
    assert result[15] == previous[15]
