"""Parameter data types and their conversion to and from PKW words (C 6, C 4.2.3).

The types are the ones the drive profile uses for parameters: integers of 8, 16 and 32 bits,
signed and unsigned, IEEE 754 single precision float, V2 (a 16-bit bit field), octet string and
visible string. Their numbers are the PROFIBUS data type codes that the parameter description
carries in element 1 (C 6 cites the profile for them).

Transfer rules (C 6 "Uebertragungsformat der Nutzdaten", reading 6 and 7):

- 8- and 16-bit types travel in one word; 8-bit values are widened to 16 bits (signed ones
  sign-extended), and a word that does not fit the 8-bit range is refused as out of limits.
- 32-bit integers and floats travel as two words, high word first; a float is its IEEE bit
  pattern.
- Octet and visible strings travel byte by byte in storage order, two bytes per word, the first
  byte in the high half; an odd length is padded with one zero byte (octets) or a blank (text).

Python values: integers and V2 are `int`, float is `float` (rounded to single precision), octet
strings are `bytes`, visible strings `str` (printable ASCII, blank-padded to the declared length).
"""

from __future__ import annotations

import enum
import math
import struct
from collections.abc import Sequence

from pyuss.drive.faults import ParameterFault
from pyuss.protocol.pkw import (
    ErrorNumber,
    bytes_to_words,
    pwe_dword,
    pwe_float,
    pwe_text,
    pwe_word,
    words_to_bytes,
)

Value = int | float | str | bytes
"""A parameter value as Python sees it."""

FLOAT_MAX = 3.4028234663852886e38
"""Largest finite IEEE 754 single precision value."""


class DataType(enum.IntEnum):
    """A parameter's data type; the value is the PROFIBUS data type code (PBE element 1)."""

    INT8 = 2
    INT16 = 3
    INT32 = 4
    UINT8 = 5
    UINT16 = 6
    UINT32 = 7
    FLOAT = 8
    VISIBLE_STRING = 9
    OCTET_STRING = 10
    V2 = 35

    @property
    def label(self) -> str:
        """The name the parameter files use for this type."""
        return _LABELS[self]

    @property
    def is_integer(self) -> bool:
        """Integer types and V2 (whose value is an unsigned 16-bit integer)."""
        return self in _INT_RANGES

    @property
    def is_unsigned(self) -> bool:
        """Unsigned integers and V2: the types that may carry value or bit texts (C Table 4.5)."""
        return self in (DataType.UINT8, DataType.UINT16, DataType.UINT32, DataType.V2)

    @property
    def is_string(self) -> bool:
        return self in _STRING_TYPES

    @property
    def byte_size(self) -> int:
        """Size of one value in bytes (0 for strings: their length is the parameter's)."""
        return _BYTE_SIZES[self]

    @property
    def type_range(self) -> tuple[float, float]:
        """The smallest and largest value the type can hold (integers exactly)."""
        if self is DataType.FLOAT:
            return (-FLOAT_MAX, FLOAT_MAX)
        if self in _INT_RANGES:
            return _INT_RANGES[self]
        raise ValueError(f"{self.label} has no numeric range")

    def word_count(self, length: int = 0) -> int:
        """How many 16-bit words one value occupies in the PKW area (C 6)."""
        if self in _STRING_TYPES:
            return (length + 1) // 2
        return 2 if _BYTE_SIZES[self] == 4 else 1


_LABELS: dict[DataType, str] = {
    DataType.INT8: "int8",
    DataType.INT16: "int16",
    DataType.INT32: "int32",
    DataType.UINT8: "uint8",
    DataType.UINT16: "uint16",
    DataType.UINT32: "uint32",
    DataType.FLOAT: "float",
    DataType.VISIBLE_STRING: "string",
    DataType.OCTET_STRING: "octets",
    DataType.V2: "v2",
}

_BYTE_SIZES: dict[DataType, int] = {
    DataType.INT8: 1,
    DataType.INT16: 2,
    DataType.INT32: 4,
    DataType.UINT8: 1,
    DataType.UINT16: 2,
    DataType.UINT32: 4,
    DataType.FLOAT: 4,
    DataType.VISIBLE_STRING: 0,
    DataType.OCTET_STRING: 0,
    DataType.V2: 2,
}

_STRING_TYPES = frozenset({DataType.VISIBLE_STRING, DataType.OCTET_STRING})

_INT_RANGES: dict[DataType, tuple[int, int]] = {
    DataType.INT8: (-0x80, 0x7F),
    DataType.INT16: (-0x8000, 0x7FFF),
    DataType.INT32: (-0x8000_0000, 0x7FFF_FFFF),
    DataType.UINT8: (0, 0xFF),
    DataType.UINT16: (0, 0xFFFF),
    DataType.UINT32: (0, 0xFFFF_FFFF),
    DataType.V2: (0, 0xFFFF),
}

TYPE_NAMES: dict[str, DataType] = {
    **{label: dtype for dtype, label in _LABELS.items()},
    # the short names of the Siemens documents ("Typ: O2", C 3.1; O = unsigned, I = integer)
    "I1": DataType.INT8,
    "I2": DataType.INT16,
    "I4": DataType.INT32,
    "O1": DataType.UINT8,
    "O2": DataType.UINT16,
    "O4": DataType.UINT32,
    "V2": DataType.V2,
}
"""Type names accepted in parameter files."""


def is_visible(text: str) -> bool:
    """Visible string characters: printable ASCII, blank included."""
    return all(" " <= ch <= "~" for ch in text)


def round_float(value: float) -> float:
    """``value`` as IEEE 754 single precision holds it."""
    result: float = struct.unpack(">f", struct.pack(">f", value))[0]
    return result


def float_text(value: float) -> str:
    """The shortest decimal text that reads back as the same single precision number."""
    if not math.isfinite(value):
        return repr(value)
    single = round_float(value)
    text = repr(single)
    for digits in range(1, 10):
        candidate = f"{single:.{digits}g}"
        try:
            if round_float(float(candidate)) == single:
                text = candidate
                break
        except OverflowError:  # rounded up beyond the largest single
            continue
    number = float(text)
    if number == int(number) and abs(number) < 1e15:
        return str(int(number))
    return repr(number)


def shortest_float(value: float) -> float:
    """``value`` (a single precision number) as its shortest decimal: 0.009999999776 -> 0.01."""
    return float(float_text(value))


def encode(dtype: DataType, value: Value, length: int = 0) -> tuple[int, ...]:
    """The PKW words of ``value`` (already checked against the type) in transfer order."""
    if dtype is DataType.FLOAT:
        assert isinstance(value, float | int)
        return pwe_float(float(value))
    if dtype.is_integer:
        assert isinstance(value, int)
        return pwe_dword(value) if dtype.byte_size == 4 else pwe_word(value)
    if dtype is DataType.VISIBLE_STRING:
        assert isinstance(value, str)
        return pwe_text(value, length)
    assert isinstance(value, bytes)
    return bytes_to_words(value.ljust(length, b"\0"))


def decode(dtype: DataType, words: Sequence[int], length: int = 0) -> Value:
    """The value carried by ``words``; refuses a wrong word count (error 5) or a value the type
    cannot hold (error 2)."""
    expected = dtype.word_count(length)
    if len(words) != expected:
        raise ParameterFault(
            ErrorNumber.WRONG_TYPE,
            f"{dtype.label} takes {expected} word(s), the job carries {len(words)}",
        )
    data = words_to_bytes(words)
    if dtype is DataType.FLOAT:
        result: float = struct.unpack(">f", data)[0]
        if not math.isfinite(result):
            raise ParameterFault(ErrorNumber.LIMIT_EXCEEDED, "float value is not a finite number")
        return result
    if dtype.is_integer:
        if dtype.byte_size == 4:
            raw = (words[0] << 16) | words[1]
            return raw - (1 << 32) if dtype is DataType.INT32 and raw & 0x8000_0000 else raw
        raw = words[0]
        signed = dtype in (DataType.INT8, DataType.INT16)
        number = raw - 0x1_0000 if signed and raw & 0x8000 else raw
        low, high = _INT_RANGES[dtype]
        if not low <= number <= high:
            raise ParameterFault(
                ErrorNumber.LIMIT_EXCEEDED, f"word {raw:04X}h does not fit {dtype.label}"
            )
        return number
    data = data[:length]
    if dtype is DataType.OCTET_STRING:
        return data
    text = data.decode("latin-1")
    if not is_visible(text):
        raise ParameterFault(
            ErrorNumber.LIMIT_EXCEEDED, "text holds characters that are not visible"
        )
    return text
