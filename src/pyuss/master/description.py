"""Reading a parameter description (PBE, C 6) that a drive sends, element by element or whole.

The figure of C 6 with the description's layout was lost in the scan; the elements and their
numbers follow the text of C 6 ("Kennzeichen" is 1, "Anzahl der Array-Elemente" 2, ..., 9
reserved, "Kennzeichen-Erweiterung" 10) and the PROFIBUS drive profile it cites, as the
project's drive simulator sends them (docs/drive.md):

====  ============================  ======================================================
 no.  element                       words
====  ============================  ======================================================
  1   identifier                    1: bits 0-7 data type, 8 no scaling, 9 read-only,
                                    10 texts, 12 changed from factory value, 13 reset only,
                                    14 array, 15 active parameter (C 4.2.1.2)
  2   number of array elements      1
  3   standardisation factor        2: float
  4   variable attribute            1
  5   reserved                      2
  6   name                          8: 16 characters
  7   lower limit                   the parameter's width: 1 word (8/16 bit, V2), 2 words
                                    (32 bit, float; strings: 2 zero words)
  8   upper limit                   as 7
  9   reserved                      1
 10   identifier extension          1
====  ============================  ======================================================

Baumueller drives (Baumueller manual 2.2.1) have elements 1 (attribute), 2 (info, 32 bits), 5
(minimum)
and 6 (maximum) only; the attribute says the value's size and type.

`decode_description` splits the words of a whole description (IND 255, variable length only,
C 4.2.2) into elements; `decode_element` reads one. Values are decoded where the layout says
how; ``words`` always keeps what was received.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pyuss.drive.database import DescriptionStyle
from pyuss.drive.datatypes import DataType
from pyuss.drive.description import BAUMUELLER_ELEMENTS, PROFIBUS_ELEMENTS
from pyuss.errors import TelegramError
from pyuss.protocol.pkw import words_to_text

__all__ = [
    "BAUMUELLER_ELEMENTS",
    "DATA_TYPES",
    "PROFIBUS_ELEMENTS",
    "Description",
    "DescriptionElement",
    "decode_description",
    "decode_element",
    "element_size",
    "layout_text",
]

DATA_TYPES: dict[int, str] = {t.value: t.label for t in DataType}
"""PROFIBUS data type codes in identifier bits 0..7."""

_FIXED_SIZES = {1: 1, 2: 1, 3: 2, 4: 1, 5: 2, 6: 8, 9: 1, 10: 1}
_SIGNED = {2, 3, 4}
_WIDE = {4, 7, 8, 9, 10}


def _signed(value: int, bits: int) -> int:
    return value - (1 << bits) if value >> (bits - 1) & 1 else value


def _float(words: Sequence[int]) -> float:
    value: float = struct.unpack(">f", struct.pack(">HH", words[0], words[1]))[0]
    return value


def _limit(words: Sequence[int], type_code: int | None) -> int | float | None:
    if type_code in (9, 10) or not words:
        return None
    if type_code == 8 and len(words) == 2:
        return _float(words)
    raw = words[0] if len(words) == 1 else (words[0] << 16) | words[1]
    bits = 16 * len(words)
    return _signed(raw, bits) if type_code in _SIGNED else raw


@dataclass(frozen=True, slots=True)
class DescriptionElement:
    """One description element: its number, name, the words received and their value."""

    number: int
    name: str
    words: tuple[int, ...]
    value: int | float | str | None

    def to_dict(self) -> dict[str, Any]:
        return {
            "number": self.number,
            "name": self.name,
            "words": list(self.words),
            "value": self.value,
        }


def decode_element(
    number: int,
    words: Sequence[int],
    style: DescriptionStyle = DescriptionStyle.PROFIBUS,
    *,
    type_code: int | None = None,
    attribute: int | None = None,
) -> DescriptionElement:
    """Element ``number`` from its ``words``. Limits need the data type: ``type_code`` (from
    element 1, PROFIBUS layout) or ``attribute`` (element 1, Baumueller layout)."""
    words = tuple(words)
    if style is DescriptionStyle.BAUMUELLER:
        name = BAUMUELLER_ELEMENTS.get(number, f"element {number}")
        value: int | float | str | None
        if number in (5, 6) and attribute is not None:
            value = _limit(words, _baumueller_type(attribute))
        elif number == 2 and len(words) == 2:
            value = (words[0] << 16) | words[1]
        else:
            value = words[0] if len(words) == 1 else None
        return DescriptionElement(number, name, words, value)
    name = PROFIBUS_ELEMENTS.get(number, f"element {number}")
    if number == 3 and len(words) == 2:
        value = _float(words)
    elif number == 6:
        value = words_to_text(words)
    elif number in (7, 8):
        value = _limit(words, type_code)
    elif len(words) == 1:
        value = words[0]
    else:
        value = None
    return DescriptionElement(number, name, words, value)


def _baumueller_type(attribute: int) -> int:
    """A PROFIBUS type code for Baumueller's attribute (bits 0-1 size 1/2/4/8 bytes, bits 2-3
    signed/unsigned/float)."""
    size = (1, 2, 4, 8)[attribute & 3]
    kind = attribute >> 2 & 3
    if kind == 2:
        return 8
    if size >= 4:
        return 4 if kind == 0 else 7
    return 3 if kind == 0 else 6


@dataclass(frozen=True, slots=True)
class Description:
    """A parameter description: the elements read, by number."""

    pnu: int
    style: DescriptionStyle
    elements: Mapping[int, DescriptionElement] = field(default_factory=dict)

    def get(self, number: int) -> int | float | str | None:
        element = self.elements.get(number)
        return None if element is None else element.value

    @property
    def identifier(self) -> int | None:
        value = self.get(1)
        return value if isinstance(value, int) else None

    @property
    def type_code(self) -> int | None:
        """The PROFIBUS data type code (identifier bits 0..7, or from Baumueller's attribute)."""
        ident = self.identifier
        if ident is None:
            return None
        if self.style is DescriptionStyle.BAUMUELLER:
            return _baumueller_type(ident)
        return ident & 0xFF

    @property
    def data_type(self) -> str | None:
        code = self.type_code
        return None if code is None else DATA_TYPES.get(code, f"type {code}")

    def _flag(self, bit: int) -> bool | None:
        ident = self.identifier
        if ident is None or self.style is not DescriptionStyle.PROFIBUS:
            return None
        return bool(ident >> bit & 1)

    @property
    def read_only(self) -> bool | None:
        if self.style is DescriptionStyle.BAUMUELLER:
            info = self.get(2)
            return None if not isinstance(info, int) else bool(info & 7)
        return self._flag(9)

    @property
    def is_array(self) -> bool | None:
        return self._flag(14)

    @property
    def active(self) -> bool | None:
        """Active parameter: a change elsewhere is reported spontaneously (C 4.2.1.2)."""
        return self._flag(15)

    @property
    def has_texts(self) -> bool | None:
        return self._flag(10)

    @property
    def name(self) -> str | None:
        value = self.get(6) if self.style is DescriptionStyle.PROFIBUS else None
        return value if isinstance(value, str) else None

    @property
    def array_length(self) -> int | None:
        value = self.get(2) if self.style is DescriptionStyle.PROFIBUS else None
        return value if isinstance(value, int) else None

    @property
    def scaling(self) -> float | None:
        value = self.get(3) if self.style is DescriptionStyle.PROFIBUS else None
        return value if isinstance(value, float) else None

    @property
    def low(self) -> int | float | None:
        value = self.get(7 if self.style is DescriptionStyle.PROFIBUS else 5)
        return value if isinstance(value, int | float) else None

    @property
    def high(self) -> int | float | None:
        value = self.get(8 if self.style is DescriptionStyle.PROFIBUS else 6)
        return value if isinstance(value, int | float) else None

    def to_dict(self) -> dict[str, Any]:
        return {
            "pnu": self.pnu,
            "style": self.style.value,
            "data_type": self.data_type,
            "name": self.name,
            "read_only": self.read_only,
            "array": self.is_array,
            "active": self.active,
            "array_length": self.array_length,
            "scaling": self.scaling,
            "low": self.low,
            "high": self.high,
            "elements": [e.to_dict() for e in self.elements.values()],
        }


_LAYOUT_TEXTS = {
    DescriptionStyle.PROFIBUS: "elements 1..10 of USS specification C 6 (the PROFIBUS drive "
    "profile's layout)",
    DescriptionStyle.BAUMUELLER: "elements 1, 2, 5, 6 (attribute, info, minimum, maximum) of "
    "the Baumueller communication software manual 2.2.1",
}


def layout_text(style: DescriptionStyle) -> str:
    """The elements a description of ``style`` has and the document that lays them out, in
    words (what ``uss describe`` prints instead of the style's name)."""
    return _LAYOUT_TEXTS[style]


def limit_words(type_code: int | None) -> int:
    """Words of a limit element for a data type (strings and unknown types: 2)."""
    if type_code is None:
        return 2
    return 2 if type_code in _WIDE else 1


def element_size(
    number: int,
    style: DescriptionStyle,
    *,
    type_code: int | None = None,
    attribute: int | None = None,
) -> int | None:
    """How many words element ``number`` has (None when the layout does not say)."""
    if style is DescriptionStyle.BAUMUELLER:
        if number in (5, 6):
            return None if attribute is None else limit_words(_baumueller_type(attribute))
        return {1: 1, 2: 2}.get(number)
    if number in (7, 8):
        return None if type_code is None else limit_words(type_code)
    return _FIXED_SIZES.get(number)


def decode_description(
    pnu: int, words: Sequence[int], style: DescriptionStyle = DescriptionStyle.PROFIBUS
) -> Description:
    """Split the words of a whole description (IND 255) into its elements."""
    words = tuple(words)
    elements: dict[int, DescriptionElement] = {}
    pos = 0
    if style is DescriptionStyle.BAUMUELLER:
        if len(words) < 3:
            raise TelegramError(f"P{pnu}: {len(words)} description words, need at least 3")
        attribute = words[0]
        width = limit_words(_baumueller_type(attribute))
        sizes = {1: 1, 2: 2, 5: width, 6: width}
        type_code = None
    else:
        if not words:
            raise TelegramError(f"P{pnu}: an empty parameter description")
        type_code = words[0] & 0xFF
        width = limit_words(type_code)
        sizes = {**_FIXED_SIZES, 7: width, 8: width}
        attribute = None
    for number in sorted(sizes):
        size = sizes[number]
        if pos + size > len(words):
            raise TelegramError(
                f"P{pnu}: description ends in element {number} ({len(words)} words received)"
            )
        elements[number] = decode_element(
            number, words[pos : pos + size], style, type_code=type_code, attribute=attribute
        )
        pos += size
    if pos != len(words):
        raise TelegramError(
            f"P{pnu}: description has {len(words)} words, the {style.value} layout {pos}"
        )
    return Description(pnu, style, elements)
