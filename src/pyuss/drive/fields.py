"""The fields of a parameter file, read and checked: the readers every table uses (`Where`
names file, table and field in a `ConfigError`; `choice`, `text_field`, `flag_field`,
`int_list`) and one ``[[parameter]]`` entry as a `Parameter` (`read_parameter`).

Rules an entry holds (docs/drive.md):

- ``pnu`` within the profile's ``max_pnu``; ``name`` at most 16 visible ASCII characters (PBE
  element 6); ``type`` one of the data types; ``array`` 1..254 elements (C 4.2.2); a string
  has a ``length`` of 1..240 (C 4.1.2), no other type has one.
- ``min``, ``max`` and ``allowed`` exist for numbers only (not V2) and fit the type; ``min``
  is not above ``max``.
- ``scaling`` is positive; ``decimals`` (0..15) follows a scaling of 10^-k unless given.
- Value texts exist for unsigned 8/16/32 types, for values up to 253 (text element y = value
  + 1 <= 254, C Table 4.5); index texts for arrays; bit texts for a V2 that is not an array;
  each text at most 16 visible ASCII characters (C 8 example 7).
- ``level`` is an access level 0..4; ``changeable`` letters of C, U, T, never on a read-only
  parameter; a BICO input is a ``uint32`` without ``min``, ``max``, ``allowed`` or ``texts``.
- ``default`` (one value for all elements, or one per element; octets as hex text) passes
  the rules of a write where the parameter is writable (fits its type where it is read-only);
  without one a number is 0 (a writable one brought within its limits, or the first allowed
  value), a text spaces, octets zeros.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, TypeVar

from pyuss.drive.database import (
    CHANGEABLE_LETTERS,
    MAX_ARRAY,
    MAX_STRING,
    TEXT_LENGTH,
    Access,
    DescriptionStyle,
    DisplayFormat,
    NameStyle,
    Parameter,
    ProfileInfo,
)
from pyuss.drive.datatypes import TYPE_NAMES, DataType, Value, is_visible, round_float
from pyuss.drive.faults import ParameterFault
from pyuss.errors import ConfigError

PARAM_KEYS = {
    "pnu",
    "name",
    "type",
    "array",
    "length",
    "default",
    "min",
    "max",
    "allowed",
    "access",
    "active",
    "unit",
    "scaling",
    "decimals",
    "format",
    "command",
    "store",
    "reset_only",
    "stopped_only",
    "texts",
    "index_texts",
    "bit_texts",
    "level",
    "changeable",
    "bico",
    "macro",
    "doc",
    "follows",
    "seed",  # the older name of "follows"
}


class Where:
    """Builds error messages that name file, parameter and field."""

    def __init__(self, source: str, what: str = "") -> None:
        self.source = source
        self.what = what

    def error(self, field_name: str, problem: str) -> ConfigError:
        where = f"{self.source}: {self.what}" if self.what else f"{self.source}:"
        return ConfigError(f"{where} field {field_name!r}: {problem}")


_E = TypeVar("_E", Access, DescriptionStyle, NameStyle)


def choice(kind: type[_E], value: object, where: Where, name: str) -> _E:
    """``value`` as a member of the enumeration ``kind`` (given by its value in the file)."""
    for member in kind:
        if member.value == value:
            return member
    raise where.error(name, "must be one of " + ", ".join(repr(m.value) for m in kind))


def text_field(value: object, where: Where, name: str) -> str:
    if not isinstance(value, str):
        raise where.error(name, "must be a text")
    return value


def flag_field(value: object, where: Where, name: str) -> bool:
    if not isinstance(value, bool):
        raise where.error(name, "must be true or false")
    return value


def int_list(value: object, where: Where, name: str) -> list[int]:
    if not isinstance(value, list) or not all(
        isinstance(v, int) and not isinstance(v, bool) for v in value
    ):
        raise where.error(name, "must be a list of integers")
    return list(value)


def read_parameter(entry: dict[str, Any], where: Where, profile: ProfileInfo) -> Parameter:
    extra = set(entry) - PARAM_KEYS
    if extra:
        raise where.error(sorted(extra)[0], f"unknown; known are {', '.join(sorted(PARAM_KEYS))}")
    pnu = entry["pnu"]
    if not 0 <= pnu <= profile.max_pnu:
        raise where.error("pnu", f"must be 0..{profile.max_pnu} in this profile")
    name = entry.get("name")
    if not isinstance(name, str) or not name:
        raise where.error("name", "required, a non-empty text")
    if len(name) > TEXT_LENGTH or not is_visible(name):
        raise where.error("name", f"at most {TEXT_LENGTH} visible ASCII characters (PBE element 6)")
    type_name = entry.get("type")
    if not isinstance(type_name, str) or type_name not in TYPE_NAMES:
        raise where.error("type", f"required, one of {', '.join(TYPE_NAMES)}")
    dtype = TYPE_NAMES[type_name]

    array = entry.get("array")
    if array is not None and (
        isinstance(array, bool) or not isinstance(array, int) or not 1 <= array <= MAX_ARRAY
    ):
        raise where.error("array", f"must be a number of elements 1..{MAX_ARRAY}")
    length = entry.get("length", 0)
    if dtype.is_string:
        if isinstance(length, bool) or not isinstance(length, int):
            raise where.error("length", "must be an integer")
        if not 1 <= length <= MAX_STRING:
            raise where.error("length", f"a string parameter needs a length 1..{MAX_STRING}")
    elif "length" in entry:
        raise where.error("length", "only string types have a length")

    access = choice(Access, entry.get("access", "rw"), where, "access")

    numeric = dtype.is_integer or dtype is DataType.FLOAT
    minimum = _limit(entry, "min", dtype, where)
    maximum = _limit(entry, "max", dtype, where)
    if dtype is DataType.V2 or not numeric:
        for key in ("min", "max", "allowed"):
            if key in entry:
                raise where.error(key, f"not applicable to type {dtype.label}")
    if minimum is not None and maximum is not None and minimum > maximum:
        raise where.error("min", f"{minimum} is above max {maximum}")
    allowed = None
    if "allowed" in entry:
        values = int_list(entry["allowed"], where, "allowed")
        if not values or not dtype.is_integer:
            raise where.error("allowed", "must be a non-empty list of integers")
        allowed = tuple(values)

    unit = text_field(entry.get("unit", ""), where, "unit")
    scaling = entry.get("scaling")
    if scaling is not None and (
        isinstance(scaling, bool)
        or not isinstance(scaling, int | float)
        or not math.isfinite(scaling)
        or scaling <= 0
    ):
        raise where.error("scaling", "must be a positive number")
    decimals = entry.get("decimals", _decimals_of(scaling))
    if isinstance(decimals, bool) or not isinstance(decimals, int) or not 0 <= decimals <= 15:
        raise where.error("decimals", "must be 0..15")
    display = _display(entry.get("format"), dtype, where)

    texts = _value_texts(entry, dtype, array, where)
    index_texts = _index_texts(entry, array, where)
    bit_texts = _bit_texts(entry, dtype, array, where)

    bico = flag_field(entry.get("bico", False), where, "bico")
    if bico and (dtype is not DataType.UINT32 or {"min", "max", "allowed", "texts"} & set(entry)):
        raise where.error("bico", "a BICO input is a uint32 without min, max, allowed or texts")

    param = Parameter(
        pnu=pnu,
        name=name,
        dtype=dtype,
        default=(),
        array=array,
        length=length if dtype.is_string else 0,
        minimum=minimum,
        maximum=maximum,
        allowed=allowed,
        access=access,
        active=flag_field(entry.get("active", False), where, "active"),
        unit=unit,
        scaling=None if scaling is None else float(scaling),
        decimals=decimals,
        display=display,
        command=flag_field(entry.get("command", False), where, "command"),
        store=flag_field(entry.get("store", True), where, "store"),
        reset_only=flag_field(entry.get("reset_only", False), where, "reset_only"),
        stopped_only=flag_field(entry.get("stopped_only", False), where, "stopped_only"),
        texts=texts,
        index_texts=index_texts,
        bit_texts=bit_texts,
        level=_level(entry.get("level"), where),
        changeable=_changeable(entry.get("changeable"), where, access),
        bico=bico,
        macro=flag_field(entry.get("macro", False), where, "macro"),
        doc=text_field(entry.get("doc", ""), where, "doc"),
        follows=text_field(entry.get("follows", entry.get("seed", "")), where, "follows"),
    )
    defaults = _defaults(entry, param, where)
    return replace(param, default=defaults)


def _level(value: object, where: Where) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 4:
        raise where.error("level", "must be an access level 0..4")
    return value


def _changeable(value: object, where: Where, access: Access) -> str | None:
    if value is None:
        return None
    if (
        not isinstance(value, str)
        or not value
        or any(c not in CHANGEABLE_LETTERS for c in value)
        or len(set(value)) != len(value)
    ):
        raise where.error("changeable", 'must be letters of C, U, T (for example "CT")')
    if access is Access.RO:
        raise where.error("changeable", "a read-only parameter is never changed")
    return "".join(c for c in CHANGEABLE_LETTERS if c in value)


def _limit(entry: dict[str, Any], key: str, dtype: DataType, where: Where) -> int | float | None:
    if key not in entry:
        return None
    value = entry[key]
    if dtype is DataType.FLOAT:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise where.error(key, "must be a number")
        if not math.isfinite(value) or abs(value) > dtype.type_range[1]:
            raise where.error(key, "must be a finite single precision number")
        return round_float(float(value))
    if not dtype.is_integer:
        raise where.error(key, f"not applicable to type {dtype.label}")
    if isinstance(value, bool) or not isinstance(value, int):
        raise where.error(key, "must be an integer")
    low, high = dtype.type_range
    if not low <= value <= high:
        raise where.error(key, f"{value} does not fit {dtype.label}")
    return value


def _decimals_of(scaling: object) -> int:
    """Decimal places implied by a scaling of 10^-k (0 for any other scaling)."""
    if isinstance(scaling, int | float) and not isinstance(scaling, bool):
        for places in range(16):
            if math.isclose(scaling, 10.0**-places, rel_tol=1e-9):
                return places
    return 0


def _display(value: object, dtype: DataType, where: Where) -> DisplayFormat:
    if value is None:
        if dtype.is_string:
            return DisplayFormat.ASCII
        if dtype is DataType.V2:
            return DisplayFormat.HEX
        return DisplayFormat.NORM if dtype is DataType.FLOAT else DisplayFormat.DEC
    if not isinstance(value, str) or value.upper() not in DisplayFormat.__members__:
        names = ", ".join(m.lower() for m in DisplayFormat.__members__)
        raise where.error("format", f"must be one of {names}")
    return DisplayFormat[value.upper()]


def _element_text(text: object, where: Where, key: str) -> str:
    if not isinstance(text, str) or len(text) > TEXT_LENGTH or not is_visible(text):
        raise where.error(key, f"texts are at most {TEXT_LENGTH} visible ASCII characters")
    return text


def _value_texts(
    entry: dict[str, Any], dtype: DataType, array: int | None, where: Where
) -> dict[int, str]:
    table = entry.get("texts")
    if table is None:
        return {}
    if not isinstance(table, dict):
        raise where.error("texts", 'must be a table value = "text"')
    if not dtype.is_unsigned or dtype is DataType.V2:
        raise where.error("texts", "value texts exist for unsigned 8/16/32 types (C Table 4.5)")
    low, high = dtype.type_range
    result = {}
    for key, text in table.items():
        value = _table_key(key, where, "texts", "an integer value")
        if not low <= value <= min(high, 253):
            raise where.error("texts", f"value {value}: text element y = value + 1 must be <= 254")
        result[value] = _element_text(text, where, "texts")
    return dict(sorted(result.items()))


def _table_key(key: str, where: Where, field: str, what: str) -> int:
    """A key of the table ``field`` as the number it writes (``5``, ``0x0A``)."""
    try:
        return int(key, 0)
    except ValueError:
        raise where.error(field, f"key {key!r} is not {what}") from None


def _index_texts(entry: dict[str, Any], array: int | None, where: Where) -> tuple[str, ...]:
    texts = entry.get("index_texts")
    if texts is None:
        return ()
    if array is None:
        raise where.error("index_texts", "only an array has index texts")
    if not isinstance(texts, list) or len(texts) > array:
        raise where.error("index_texts", f"must be a list of at most {array} texts")
    return tuple(_element_text(t, where, "index_texts") for t in texts)


def _bit_texts(
    entry: dict[str, Any], dtype: DataType, array: int | None, where: Where
) -> dict[int, tuple[str, str]]:
    table = entry.get("bit_texts")
    if table is None:
        return {}
    if dtype is not DataType.V2 or array is not None:
        raise where.error("bit_texts", "bit texts exist for a V2 parameter that is not an array")
    if not isinstance(table, dict):
        raise where.error("bit_texts", 'must be a table bit = ["text of 0", "text of 1"]')
    result = {}
    for key, pair in table.items():
        bit = _table_key(key, where, "bit_texts", "a bit number")
        if not 0 <= bit <= 15:
            raise where.error("bit_texts", f"bit {bit} is not 0..15")
        if not isinstance(pair, list) or len(pair) != 2:
            raise where.error("bit_texts", f"bit {bit}: give two texts, for 0 and for 1")
        result[bit] = (
            _element_text(pair[0], where, "bit_texts"),
            _element_text(pair[1], where, "bit_texts"),
        )
    return dict(sorted(result.items()))


def _defaults(entry: dict[str, Any], param: Parameter, where: Where) -> tuple[Value, ...]:
    raw = entry.get("default")
    if raw is None:
        zero: Value = (
            ""
            if param.dtype is DataType.VISIBLE_STRING
            else b""
            if param.dtype is DataType.OCTET_STRING
            else 0.0
            if param.dtype is DataType.FLOAT
            else 0
        )
        if isinstance(zero, int | float) and param.writable:
            zero = min(max(zero, param.low), param.high)
            if param.allowed is not None and zero not in param.allowed:
                zero = param.allowed[0]
            if param.dtype.is_integer:
                zero = int(zero)
        raw = zero
    if param.dtype is DataType.OCTET_STRING and isinstance(raw, str):
        try:
            raw = bytes.fromhex(raw)
        except ValueError:
            raise where.error("default", 'octets are given as hex text, e.g. "01 A0 FF"') from None
    if isinstance(raw, list) and param.dtype is DataType.OCTET_STRING:
        raise where.error("default", "give octets as hex text (one value for every element)")
    if isinstance(raw, list):
        if param.array is None:
            raise where.error("default", "a list of defaults needs an array parameter")
        if len(raw) != param.array:
            raise where.error("default", f"give {param.array} values or one for all elements")
        values = raw
    else:
        values = [raw] * param.elements
    result = []
    for value in values:
        if param.dtype is DataType.OCTET_STRING and isinstance(value, str):
            value = bytes.fromhex(value)
        try:
            checked = param.check_write(value) if param.writable else param.coerce(value)
        except ParameterFault as exc:
            raise where.error("default", exc.detail) from None
        result.append(checked)
    return tuple(result)
