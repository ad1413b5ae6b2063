"""A small TOML writer: what pyuss writes (backups, the ``uss.toml`` of ``uss scan --save``)
with the standard library only (``tomllib`` reads TOML but cannot write it).

`dumps` takes a mapping of strings to strings, integers (64 bits, as TOML has them), floats
(``nan`` and ``inf`` included), booleans, lists and mappings, nested at will. A mapping becomes
a ``[table]``, a non-empty list of mappings an array of tables (``[[table]]``); inside a list a
mapping is written inline (``{ a = 1 }``). The values of a table come before its sub-tables, so
the text reads back (``tomllib.loads``) as the data given. Anything else (None, dates, bytes,
keys that are not strings) is a `TypeError` naming the key: TOML has no null.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["dumps"]

_BARE = re.compile(r"[A-Za-z0-9_-]+")
_ESCAPES = {
    "\\": "\\\\",
    '"': '\\"',
    "\b": "\\b",
    "\t": "\\t",
    "\n": "\\n",
    "\f": "\\f",
    "\r": "\\r",
}
_INT_RANGE = (-(2**63), 2**63 - 1)


def dumps(data: Mapping[str, Any]) -> str:
    """The TOML text of ``data`` (see the module docstring)."""
    lines: list[str] = []
    _table(lines, (), data, header=None)
    return "\n".join(lines) + "\n" if lines else ""


def _key(key: object, path: Sequence[str]) -> str:
    if not isinstance(key, str):
        where = ".".join(path) or "the top"
        raise TypeError(f"TOML keys are text: {key!r} in {where}")
    return key if _BARE.fullmatch(key) else _string(key)


def _string(text: str) -> str:
    out = []
    for char in text:
        if char in _ESCAPES:
            out.append(_ESCAPES[char])
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04X}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'


def _is_table_array(value: object) -> bool:
    return (
        isinstance(value, Sequence)
        and not isinstance(value, str)
        and len(value) > 0
        and all(isinstance(item, Mapping) for item in value)
    )


def _table(
    lines: list[str], path: tuple[str, ...], table: Mapping[str, Any], header: str | None
) -> None:
    """Write ``table`` at ``path`` (its ``header`` line first, if any): values, then tables."""
    if header is not None:
        if lines:
            lines.append("")
        lines.append(header)
    later: list[tuple[str, Any]] = []
    for key, value in table.items():
        name = _key(key, path)
        if isinstance(value, Mapping) or _is_table_array(value):
            later.append((name, value))
        else:
            lines.append(f"{name} = {_value(value, (*path, name))}")
    for name, value in later:
        here = (*path, name)
        if isinstance(value, Mapping):
            _table(lines, here, value, header=f"[{'.'.join(here)}]")
        else:
            for item in value:
                _table(lines, here, item, header=f"[[{'.'.join(here)}]]")


def _value(value: Any, path: tuple[str, ...]) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        if not _INT_RANGE[0] <= value <= _INT_RANGE[1]:
            raise TypeError(f"{'.'.join(path)}: {value} is beyond the 64 bits of a TOML integer")
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, Mapping):
        items = [f"{_key(k, path)} = {_value(v, (*path, _key(k, path)))}" for k, v in value.items()]
        return "{ " + ", ".join(items) + " }" if items else "{}"
    if isinstance(value, Sequence) and not isinstance(value, bytes | bytearray):
        return "[" + ", ".join(_value(item, path) for item in value) + "]"
    raise TypeError(f"{'.'.join(path)}: TOML has no value for {type(value).__name__} {value!r}")
