"""Parameter values: PWE words <-> typed values <-> text, by what a `ParamInfo` says.

Three forms of a value:

- words: the PWE words as they travel (C 6: 8/16-bit types one word, 32-bit integers and
  floats two words high word first, strings two characters per word);
- raw: what the words mean in the data type (an `int`, a `float`, `str`, `bytes`): the numbers
  of the parameter file's limits and of the description's elements 7 and 8;
- value (physical): the raw value times the scaling for a scaled integer (NORD P102: raw 200,
  scaling 0.01 -> 2.0 s), the raw value otherwise. A value text stays a number (its text is
  for display).

`decode` and `encode` go between words and values; `parse` reads what a user types (``10``,
``10.0``, ``10 s``, ``500 ms`` for a parameter in s, ``0x7000``, the text of an enumerated
value) and refuses, before anything is sent, a value of the wrong kind or out of the
parameter's limits with a `ValueRefused` (a `ConfigError`) that names the parameter, the value
and the limits. Bit fields (V2) are not typed values: their words go through the raw calls
(`Drive.write_raw`, ``uss write --raw``). `format_value` gives the text a drive engineer reads
(``10.00 s``, ``2.00 s``, ``1 [READY]``, ``4000h``).

Floats are single precision (IEEE 754, 32 bits): a float shows as the shortest decimal that
gives the same single precision number (0.01 rather than 0.009999999776482582), with at least
two decimals (`pyuss.drive.datatypes.float_text`, beside the type).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence

from pyuss.drive.database import TIME_UNITS
from pyuss.drive.datatypes import (
    DataType,
    Value,
    float_text,
    is_visible,
    round_float,
    shortest_float,
)
from pyuss.drive.datatypes import decode as decode_raw
from pyuss.drive.datatypes import encode as encode_raw
from pyuss.drive.faults import ParameterFault
from pyuss.errors import ConfigError, TelegramError
from pyuss.params.info import ParamInfo
from pyuss.protocol.bico import Bico, BicoError, is_bico, parse_bico, to_bico

__all__ = [
    "ValueRefused",
    "check_raw",
    "decode",
    "encode",
    "float_text",
    "format_value",
    "json_value",
    "parse",
    "parse_unknown",
    "physical",
    "raw_of",
    "shortest_float",
    "words_text",
]

_RESOLUTION = 1e-6
"""How far value / scaling may be from a whole number and still count as one (float noise)."""


class ValueRefused(ConfigError):
    """A value for a parameter is of the wrong kind or outside its limits (nothing was sent)."""


def label(info: ParamInfo, index: int | None = None) -> str:
    """``P1120``, ``r0021`` or ``P947.3``: as the drive's family writes it (`ParamInfo.label`)."""
    return info.label(index)


def _clean(number: float) -> float:
    """A product of raw value and scaling without binary noise (7 x 0.1 = 0.7)."""
    return float(f"{number:.12g}")


# -- words <-> values ------------------------------------------------------------------------


def physical(info: ParamInfo, raw: Value) -> Value:
    """The physical value of ``raw``: raw x scaling for a scaled integer."""
    if info.bico and isinstance(raw, int) and is_bico(raw):
        return Bico.from_raw(raw)
    if info.is_scaled and isinstance(raw, int) and info.scaling is not None:
        return _clean(raw * info.scaling)
    return raw


def decode(info: ParamInfo, words: Sequence[int], index: int | None = None) -> Value:
    """The value that ``words`` carry; `TelegramError` if they do not fit the data type."""
    try:
        raw = decode_raw(info.dtype, tuple(words), info.length)
    except ParameterFault as exc:
        raise TelegramError(
            f"{label(info, index)} ({info.type_name}): the drive sent "
            f"{words_text(words) or 'no words'}: {exc.detail}"
        ) from None
    if isinstance(raw, str):
        raw = raw.rstrip()
    return physical(info, raw)


def raw_of(info: ParamInfo, value: object, index: int | None = None) -> Value:
    """The raw value of a physical ``value`` of the parameter's kind (not yet range-checked);
    `ValueRefused` for a value of another kind or between two steps of the scaling."""
    where = label(info, index)
    dtype = info.dtype
    if info.bico:
        return _bico_of(value, where)
    if dtype is DataType.V2:
        raise ValueRefused(
            f"{where} is a bit field (V2): write its bit pattern as raw words "
            "(uss write --raw, Drive.write_raw)"
        )
    if dtype.is_string:
        if dtype is DataType.VISIBLE_STRING:
            if not isinstance(value, str):
                raise ValueRefused(f"{where} holds text, not {value!r}")
            return value
        if not isinstance(value, bytes | bytearray):
            raise ValueRefused(f"{where} holds bytes, not {value!r}")
        return bytes(value)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueRefused(f"{where} ({info.type_name}) takes a number, not {value!r}")
    if not math.isfinite(value):
        raise ValueRefused(f"{where}: {value!r} is not a finite number")
    if dtype is DataType.FLOAT:
        try:
            return round_float(float(value))
        except OverflowError:
            raise ValueRefused(
                f"{where}: {value!r} does not fit a single precision float"
            ) from None
    if info.is_scaled and info.scaling is not None:
        steps = value / info.scaling
        whole = round(steps)
        if abs(steps - whole) > _RESOLUTION * max(1.0, abs(steps)):
            raise ValueRefused(
                f"{where}: {value!r}{_unit(info)} is not a multiple of the resolution "
                f"{float_text(info.scaling)}{_unit(info)}"
            )
        return whole
    if isinstance(value, float):
        if value != int(value):
            raise ValueRefused(f"{where} ({info.type_name}) takes a whole number, not {value!r}")
        return int(value)
    return value


def _bico_of(value: object, where: str) -> Bico:
    """The source a BICO input is given: a `Bico`, its text or its 32-bit value."""
    try:
        return to_bico(value)
    except BicoError as exc:
        raise ValueRefused(f"{where} (BICO input): {exc}") from None


def check_raw(info: ParamInfo, raw: Value, index: int | None = None) -> None:
    """Refuse a raw value outside the type, the limits or the allowed values, or a reset-only
    parameter set to anything but 0 (`ValueRefused`)."""
    where = label(info, index)
    dtype = info.dtype
    if dtype is DataType.VISIBLE_STRING:
        assert isinstance(raw, str)
        if len(raw) > info.length or not is_visible(raw):
            raise ValueRefused(
                f"{where}: text must be at most {info.length} visible ASCII characters"
            )
        return
    if dtype is DataType.OCTET_STRING:
        assert isinstance(raw, bytes)
        if len(raw) > info.length:
            raise ValueRefused(f"{where}: at most {info.length} bytes, not {len(raw)}")
        return
    assert isinstance(raw, int | float)
    type_low, type_high = dtype.type_range
    if not type_low <= raw <= type_high:
        raise ValueRefused(
            f"{where}: {format_value(info, physical(info, raw))} does not fit {info.type_name}"
        )
    if info.reset_only and raw != 0:
        raise ValueRefused(f"{where} may only be reset to 0")
    if info.allowed is not None and raw not in info.allowed:
        choices = ", ".join(
            format_value(info, physical(info, a), unit=False, texts=False) for a in info.allowed
        )
        raise ValueRefused(
            f"{where}: {format_value(info, physical(info, raw))} is not one of {choices}"
        )
    low, high = info.low, info.high
    if low is not None and high is not None and not low <= raw <= high:
        raise ValueRefused(
            f"{where}: {format_value(info, physical(info, raw))} is outside "
            f"{format_value(info, physical(info, low), unit=False, texts=False)}.."
            f"{format_value(info, physical(info, high), texts=False)}"
        )


def encode(info: ParamInfo, value: object, index: int | None = None) -> tuple[int, ...]:
    """The PWE words of a physical ``value``, checked first (`ValueRefused`)."""
    raw = raw_of(info, value, index)
    check_raw(info, raw, index)
    if info.dtype.is_integer:
        assert isinstance(raw, int)
    return encode_raw(info.dtype, raw, info.length)


# -- text -------------------------------------------------------------------------------------

_NUMBER = re.compile(
    r"""^(?P<number>[+-]?(?:0[xX][0-9a-fA-F_]+|0[bB][01_]+|0[oO][0-7_]+
        |(?:\d[\d_]*(?:\.[\d_]*)?|\.\d[\d_]*)(?:[eE][+-]?\d+)?))
        \s*(?P<unit>.*?)\s*$""",
    re.VERBOSE | re.ASCII,  # digits 0-9: another script's digits are no number here
)


def _unit(info: ParamInfo) -> str:
    return f" {info.unit}" if info.unit else ""


def parse(info: ParamInfo, text: str, index: int | None = None) -> Value:
    """The value a user typed for this parameter, checked against its kind and limits.

    Numbers in decimal (``10``, ``-2.5``, ``1e3``) or, for integers that are not scaled, with
    a base prefix (``0x7000``, ``0b101``); an optional unit that must be the parameter's
    (time units are converted: ``500 ms`` for a parameter in s); the text of an enumerated
    value (case does not matter); text for a string parameter, hex bytes for an octet string.
    """
    where = label(info, index)
    source = text.strip()
    dtype = info.dtype
    if info.bico:
        if not source:
            raise ValueRefused(f"{where}: no value given")
        return _bico_of(source, where)
    if dtype is DataType.VISIBLE_STRING:
        if len(source) >= 2 and source[0] == source[-1] and source[0] in "\"'":
            source = source[1:-1]
        value: Value = source
        encode(info, value, index)
        return value
    if dtype is DataType.OCTET_STRING:
        try:
            data = bytes.fromhex(source)
        except ValueError:
            raise ValueRefused(f"{where}: give bytes as hex, for example '01 A0 FF'") from None
        encode(info, data, index)
        return data
    if dtype is DataType.V2:
        raw_of(info, 0, index)  # refuses with the message for bit fields
    if not source:
        raise ValueRefused(f"{where}: no value given")
    for raw, name in info.texts.items():
        if source.casefold() == name.strip().casefold():
            value = physical(info, raw)
            encode(info, value, index)
            return value
    match = _NUMBER.match(source)
    if match is None:
        raise ValueRefused(f"{where}: {text!r} {_expected(info)}")
    number_text, unit = match.group("number"), match.group("unit")
    prefixed = number_text.lstrip("+-")[:2].lower() in ("0x", "0b", "0o")
    if prefixed and (dtype is DataType.FLOAT or info.is_scaled):
        raise ValueRefused(
            f"{where}: {number_text} is a raw bit pattern; {info.type_name} values are given "
            "in decimal (raw words: --raw)"
        )
    try:
        number: int | float = int(number_text, 0) if prefixed else _decimal(number_text)
    except ValueError:
        raise ValueRefused(f"{where}: {text!r} {_expected(info)}") from None
    if unit:
        if info.texts and not info.unit:
            raise ValueRefused(f"{where}: {text!r} {_expected(info)}")
        number = _convert_unit(info, number, unit, where)
    value = number
    if dtype.is_integer and not info.is_scaled and isinstance(value, float):
        if value != int(value):
            raise ValueRefused(f"{where} ({info.type_name}) takes a whole number, not {text!r}")
        value = int(value)
    encode(info, value, index)
    return round_float(float(value)) if dtype is DataType.FLOAT else value


def parse_unknown(text: str) -> int | float:
    """A value for a parameter nothing is known of (a drive of unknown kind): an integer (any
    base prefix; it travels as a word if it fits -32768..65535, else as a double word) or a
    finite float; `ValueRefused` for anything else."""
    try:
        return int(text, 0)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise ValueRefused(
            f"VALUE {text!r} is not an integer or a number (the parameter is not known: give "
            "--params FILE or --profile for texts and units)"
        ) from None
    if not math.isfinite(value):
        raise ValueRefused(f"VALUE {text!r} is not a finite number")
    return value


def _decimal(text: str) -> int | float:
    clean = text.replace("_", "")
    if re.fullmatch(r"[+-]?[0-9]+", clean):
        return int(clean)
    return float(clean)


def _expected(info: ParamInfo) -> str:
    if info.texts:
        names = ", ".join(info.texts.values())
        return f"is not a number nor one of {names}"
    return f"is not a {'number' if info.dtype is DataType.FLOAT else 'number of its kind'}"


def _convert_unit(info: ParamInfo, number: int | float, unit: str, where: str) -> int | float:
    if unit == info.unit:
        return number
    if unit in TIME_UNITS and info.unit in TIME_UNITS:
        return _clean(number * TIME_UNITS[unit] / TIME_UNITS[info.unit])
    wanted = f"its unit is {info.unit!r}" if info.unit else "it has no unit"
    raise ValueRefused(f"{where}: unit {unit!r} does not fit: {wanted}")


def _decimals(info: ParamInfo) -> int | None:
    if info.decimals is not None:
        return info.decimals
    if info.is_scaled and info.scaling is not None:
        text = float_text(info.scaling)
        return len(text.partition(".")[2]) if "." in text else 0
    return None


def format_value(
    info: ParamInfo | None,
    value: Value | Sequence[Value],
    *,
    unit: bool = True,
    texts: bool = True,
) -> str:
    """The text of a value: ``10.00 s``, ``2.00 s`` (scaled), ``1 [READY]``, ``4000h`` (bit
    field), ``"text"``; a list for a whole array. Without ``info`` an integer shows in
    decimal and hex (``16384 (4000h)``)."""
    if isinstance(value, list | tuple):
        inner = ", ".join(format_value(info, v, unit=False, texts=texts) for v in value)
        suffix = f" {info.unit}" if unit and info is not None and info.unit else ""
        return f"[{inner}]{suffix}"
    assert isinstance(value, int | float | str | bytes)
    if isinstance(value, Bico):
        return value.text()
    if info is not None and info.bico and isinstance(value, int | str):
        try:  # a backup holds a source as its text
            return (parse_bico(value) if isinstance(value, str) else Bico.from_raw(value)).text()
        except BicoError:
            if isinstance(value, int):
                return f"{value:08X}h (no BICO source)"
    if info is None:
        if isinstance(value, float):
            return float_text(value)
        if isinstance(value, int):
            if value < 0:
                return str(value)
            return f"{value} ({value:0{8 if value > 0xFFFF else 4}X}h)"
        return _plain(value)
    text = _number_text(info, value) if isinstance(value, int | float) else _plain(value)
    if unit and info.unit:
        text = f"{text} {info.unit}"
    if texts and info.texts and isinstance(value, int | float):
        name = info.texts.get(int(value)) if value == int(value) else None
        if name is not None:
            text = f"{text} [{name.strip()}]"
    return text


def _number_text(info: ParamInfo, value: int | float) -> str:
    if info.dtype is DataType.V2 and isinstance(value, int):
        return f"{value:04X}h"
    decimals = _decimals(info)
    if isinstance(value, float) or info.is_scaled:
        if decimals is not None:
            return f"{float(value):.{decimals}f}"
        text = float_text(float(value))
        whole, _, fraction = text.partition(".")
        if "e" in text:
            return text
        return f"{whole}.{fraction.ljust(2, '0')}"
    return str(value)


def _plain(value: Value) -> str:
    if isinstance(value, bytes):
        return value.hex(" ").upper()
    if isinstance(value, str):
        return f'"{value.rstrip()}"'
    return str(value)


def words_text(words: Sequence[int]) -> str:
    """``4120h 0000h``."""
    return " ".join(f"{w:04X}h" for w in words)


def json_value(value: Value | Sequence[Value]) -> object:
    """A value for JSON: bytes as hex text, strings without their padding, lists as lists."""
    if isinstance(value, list | tuple):
        return [json_value(v) for v in value]
    if isinstance(value, Bico):
        return value.text()
    if isinstance(value, bytes):
        return value.hex(" ").upper()
    if isinstance(value, str):
        return value.rstrip()
    return value
