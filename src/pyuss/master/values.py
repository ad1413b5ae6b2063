"""The words of a parameter's value as a `pyuss.master.Drive` sends and takes them: functions.

The `Drive` methods of `pyuss.master.drive` call these; they hold no state and do no I/O.
What a known parameter's words mean is `pyuss.params.values`' (`decode`, `encode`); here is
what the master itself decides: which words of an answer are the value (`answer_words`: a
word travels in PWE2 of a fixed 4-word PKW area, C 4.2.3), how an array's words split into
elements (`split_elements`), the element index a request may carry (`element_index`), and
how a value of a parameter nothing is known of travels (`untyped`, `untyped_float`,
`untyped_words`: the unsigned or two's complement word or double word, an IEEE 754 float).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pyuss.errors import ConfigError, TelegramError
from pyuss.params.book import ParamBook
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, ResponseId, pwe_dword, pwe_float, pwe_word

__all__ = [
    "DOUBLE_ANSWERS",
    "WORD_ANSWERS",
    "answer_words",
    "element_index",
    "negative",
    "split_elements",
    "untyped",
    "untyped_float",
    "untyped_words",
]

DOUBLE_ANSWERS = (ResponseId.VALUE_DWORD, ResponseId.ARRAY_DWORD)
WORD_ANSWERS = (ResponseId.VALUE_WORD, ResponseId.ARRAY_WORD)


def element_index(index: int | None) -> int | None:
    if index is None:
        return None
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= 254:
        raise ConfigError(f"index must be 0..254 (255 means the whole array), got {index!r}")
    return index


def untyped(words: Sequence[int], *, signed: bool = False) -> int:
    """A value nothing is known of: the unsigned (or two's complement) word or double word."""
    if len(words) == 1:
        value = words[0]
        return value - 0x1_0000 if signed and value & 0x8000 else value
    if len(words) == 2:
        value = (words[0] << 16) | words[1]
        return value - 0x1_0000_0000 if signed and value & 0x8000_0000 else value
    raise TelegramError(f"{len(words)} words are neither a word nor a double word")


def untyped_float(words: Sequence[int]) -> float:
    if len(words) != 2:
        raise TelegramError("the drive sent a word, not a floating point value")
    return Pkw(ResponseId.VALUE_DWORD, values=tuple(words)).float32()


def negative(value: object) -> bool:
    return isinstance(value, int) and value < 0


def untyped_words(pnu: int, value: object) -> tuple[int, ...]:
    """The words of a value for a parameter nothing is known of."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(
            f"P{pnu} is not known (no parameter file or description has it): give an integer "
            f"or a float, not {value!r}"
        )
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ConfigError(f"value must be a finite number, not {value!r}")
        return pwe_float(value)
    if -0x8000 <= value <= 0xFFFF:
        return pwe_word(value)
    return pwe_dword(value)


def split_elements(words: Sequence[int], size: int, pnu: int) -> list[tuple[int, ...]]:
    if size < 1 or len(words) % size:
        raise TelegramError(f"P{pnu}: {len(words)} words are not whole elements of {size}")
    return [tuple(words[i : i + size]) for i in range(0, len(words), size)]


def answer_words(answer: Pkw, pnu: int, book: ParamBook, layout: Layout) -> tuple[int, ...]:
    """The words of the value in an answer: a word travels in PWE2 of a fixed 4-word PKW
    area (C 4.2.3); a double word is two words."""
    values = answer.values
    if answer.id in DOUBLE_ANSWERS:
        if not values or len(values) % 2:
            raise TelegramError(
                f"{book.label(pnu)}: {len(values)} words are not whole double words"
            )
        return values
    if answer.id not in WORD_ANSWERS:
        raise TelegramError(f"{book.label(pnu)}: answer {answer.id} carries no value")
    if not values:
        raise TelegramError(f"{book.label(pnu)}: the answer carries no value")
    if not layout.variable and len(values) > 1:
        return values[-1:]
    return values
