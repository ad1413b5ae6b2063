"""The parameter description (PBE) of a parameter, generated from its database entry.

Two layouts exist; a profile picks one (``[profile] description``).

``profibus`` - C 6 (Bild 6.1, lost in the scan) with the element numbers the text gives
("Kennzeichen" is 1, "Anzahl der Array-Elemente" 2, ..., 9 reserved, "Kennzeichen-Erweiterung"
10) and the elements of the PROFIBUS profile the spec cites:

====  ============================  =====================================================
 no.  element                       words
====  ============================  =====================================================
  1   identifier ("Kennzeichen")    1: bits 0-7 data type code, 8 scaling not relevant,
                                    9 read-only, 10 text array present, 12 value differs
                                    from factory setting, 13 reset only, 14 array,
                                    15 active parameter (C 4.2.1.2 puts the active flag
                                    in this element; the profile leaves bit 15 reserved)
  2   number of array elements      1: array size, string length, 0 for a scalar
  3   standardisation factor        2: float, the scaling (1.0 without scaling)
  4   variable attribute            1: 0
  5   reserved                      2: 0
  6   name                          8: 16 visible characters, blank-padded
  7   lower limit                   the parameter's own width (1 word for 8/16 bit)
  8   upper limit                   as 7
  9   reserved                      1: 0
 10   identifier extension          1: 0
====  ============================  =====================================================

The limits travel in the parameter's own format: C 8 example 4 reads the lower limit 5FFFh of
a word parameter with PKW_ANZ = 3, which a four-byte element would not fit. Strings have no
limits; their limit elements are two zero words. An element number outside 1..10 is refused
with error 3 (faulty IND).

``baumueller`` - Baumueller manual 2.2.1: element 1 attribute (bits 0-1 length 1/2/4/8 bytes, 2-3
type
signed/unsigned/float, 4-5 fixed/variable number of elements, 6-7 data/command, 8-11 display
format, 12-15 decimal places), element 2 info (32 bits, low 16 used: bits 0-2 write protection
0 unprotected / 1 protected, bit 3 stored), element 5 minimum and 6 maximum value. Any other
element is refused with error 104. A read-only parameter shows write protection 1 as well.
"""

from __future__ import annotations

from dataclasses import dataclass

from pyuss.drive.database import TEXT_LENGTH, Access, DescriptionStyle, Parameter
from pyuss.drive.datatypes import DataType, encode
from pyuss.drive.faults import DriveErrorNumber, ParameterFault
from pyuss.protocol.pkw import ErrorNumber


@dataclass(frozen=True, slots=True)
class DescriptionElement:
    """One element of a parameter description: its number, name and PKW words."""

    number: int
    name: str
    words: tuple[int, ...]


PROFIBUS_ELEMENTS = {
    1: "identifier",
    2: "number of array elements",
    3: "standardisation factor",
    4: "variable attribute",
    5: "reserved",
    6: "name",
    7: "lower limit",
    8: "upper limit",
    9: "reserved",
    10: "identifier extension",
}

BAUMUELLER_ELEMENTS = {1: "attribute", 2: "info", 5: "minimum", 6: "maximum"}


def element_numbers(style: DescriptionStyle) -> tuple[int, ...]:
    """The element numbers a layout has, in transfer order."""
    table = PROFIBUS_ELEMENTS if style is DescriptionStyle.PROFIBUS else BAUMUELLER_ELEMENTS
    return tuple(table)


def identifier(param: Parameter, *, changed: bool = False) -> int:
    """Element 1 of the ``profibus`` layout."""
    word = int(param.dtype) & 0xFF
    if param.scaling is None:
        word |= 1 << 8
    if not param.writable:
        word |= 1 << 9
    if param.texts or param.index_texts or param.bit_texts:
        word |= 1 << 10
    if changed:
        word |= 1 << 12
    if param.reset_only:
        word |= 1 << 13
    if param.is_array:
        word |= 1 << 14
    if param.active:
        word |= 1 << 15
    return word


def attribute(param: Parameter) -> int:
    """Element 1 of the ``baumueller`` layout."""
    dtype = param.dtype
    size = 1 if dtype.is_string else dtype.byte_size
    length_code = {1: 0, 2: 1, 4: 2, 8: 3}[size]
    if dtype is DataType.FLOAT:
        type_code = 2
    elif dtype in (DataType.INT8, DataType.INT16, DataType.INT32):
        type_code = 0
    else:
        type_code = 1
    variable = 1 if param.is_array or dtype.is_string else 0
    return (
        length_code
        | type_code << 2
        | variable << 4
        | (1 if param.command else 0) << 6
        | int(param.display) << 8
        | param.decimals << 12
    )


def info(param: Parameter) -> int:
    """Element 2 of the ``baumueller`` layout (32 bits, the upper 16 reserved)."""
    protection = 0 if param.access is Access.RW else 1
    return protection | (1 << 3 if param.store else 0)


def _limit_words(param: Parameter, which: str) -> tuple[int, ...]:
    dtype = param.dtype
    if dtype.is_string:
        return (0, 0)
    if dtype is DataType.V2:
        return (0,) if which == "low" else (0xFFFF,)
    value = param.low if which == "low" else param.high
    if dtype is DataType.FLOAT:
        return encode(dtype, float(value))
    return encode(dtype, int(value))


def _name_words(param: Parameter) -> tuple[int, ...]:
    return encode(DataType.VISIBLE_STRING, param.name, TEXT_LENGTH)


def element(
    param: Parameter, number: int, style: DescriptionStyle, *, changed: bool = False
) -> DescriptionElement:
    """Description element ``number`` of ``param`` (IND low byte 1..254)."""
    baumueller = style is DescriptionStyle.BAUMUELLER
    table = BAUMUELLER_ELEMENTS if baumueller else PROFIBUS_ELEMENTS
    if number not in table:
        raise ParameterFault(
            DriveErrorNumber.NO_SUCH_ELEMENT if baumueller else ErrorNumber.BAD_INDEX,
            f"description element {number} does not exist ({', '.join(map(str, table))} do)",
            pnu=param.pnu,
            index=number,
        )
    words: tuple[int, ...]
    if baumueller:
        if number == 1:
            words = (attribute(param),)
        elif number == 2:
            words = (0, info(param))
        else:
            words = _limit_words(param, "low" if number == 5 else "high")
        return DescriptionElement(number, table[number], words)
    if number == 1:
        words = (identifier(param, changed=changed),)
    elif number == 2:
        words = (param.array if param.array is not None else param.length,)
    elif number == 3:
        words = encode(DataType.FLOAT, 1.0 if param.scaling is None else param.scaling)
    elif number in (4, 9, 10):
        words = (0,)
    elif number == 5:
        words = (0, 0)
    elif number == 6:
        words = _name_words(param)
    else:
        words = _limit_words(param, "low" if number == 7 else "high")
    return DescriptionElement(number, PROFIBUS_ELEMENTS[number], words)


def description(
    param: Parameter, style: DescriptionStyle, *, changed: bool = False
) -> tuple[DescriptionElement, ...]:
    """The whole description (IND 255): every element of the layout, in order."""
    return tuple(element(param, n, style, changed=changed) for n in element_numbers(style))
