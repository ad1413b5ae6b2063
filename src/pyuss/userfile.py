"""Files a user hands to pyuss to read: the one way their text is read, checked and parsed.

The gateway configuration, backups and parameter files (``--params``) are read through
`read_text` and parsed with `parse_toml` or `parse_json`; each failure is a `ConfigError` of
one line that names the file and what is wrong with it, never a traceback:

- a file that is missing, a folder or cannot be read (the system's reason);
- a file that is no text: not UTF-8, or holding NUL bytes (a binary file);
- an empty file, and one larger than `MAX_SIZE` (a device such as ``/dev/zero`` included);
- text that is not TOML or JSON (the parser's message, with line and column);
- values nested deeper than `MAX_DEPTH` (lists in lists, tables in tables, dotted keys): no
  file of pyuss comes near it, and a parser or a check that follows the nesting would run out
  of stack on such a file. The brackets are counted before the parser sees the text, the
  tables and lists of what it made after, so neither the parser nor the code reading the
  values ever descends further.

The caller names the file as it wants it named in messages (``where``) and says what it is
(``what``: "the backup", "parameter file"), so the messages read alike for every file.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pyuss.errors import ConfigError

__all__ = [
    "MAX_DEPTH",
    "MAX_SIZE",
    "NotJson",
    "check_depth",
    "in_file",
    "json_depth",
    "parse_json",
    "parse_message",
    "parse_toml",
    "read_text",
]

MAX_DEPTH = 32
"""Deepest nesting of lists and tables a file may have (the deepest file of pyuss, a JSON
backup of arrays, nests 4)."""

MAX_SIZE = 16 * 1024 * 1024
"""Largest file read, in bytes (a backup of every parameter of a drive is some 100 kB)."""

_LONG_NUMBER = "a number of thousands of digits"

_TOML_TOKENS = re.compile(
    r'"""(?:[^\\]|\\.)*?"""'  # multi-line basic string
    r"|'''.*?'''"  # multi-line literal string
    r'|"(?:[^"\\\n]|\\.)*"'  # basic string
    r"|'[^'\n]*'"  # literal string
    r"|#[^\n]*"  # comment
    r"|[\[\]{}\n]",
    re.DOTALL,
)
_JSON_TOKENS = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}\n]', re.DOTALL)


def read_text(path: str | os.PathLike[str], what: str) -> str:
    """The text of the file ``path`` (``what`` it is, for messages); `ConfigError` naming the
    file when it cannot be read, is no UTF-8 text, is empty or too large."""
    where = Path(path)
    if where.is_dir():
        raise ConfigError(f"{where}: cannot read {what}: it is a folder")
    try:
        with open(where, "rb") as file:
            data = file.read(MAX_SIZE + 1)
    except OSError as exc:
        raise ConfigError(f"{where}: cannot read {what}: {exc.strerror or exc}") from None
    if len(data) > MAX_SIZE:
        raise ConfigError(f"{where}: cannot read {what}: larger than {MAX_SIZE // 1024**2} MB")
    if b"\0" in data:
        raise ConfigError(f"{where}: {what} is not a text file (it holds NUL bytes)")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{where}: {what} is not UTF-8 text (byte {exc.start} is {data[exc.start]:#04x})"
        ) from None
    if not text.strip():
        raise ConfigError(f"{where}: {what} is empty")
    return text


def _check_brackets(text: str, tokens: re.Pattern[str], where: str, *, depth: int) -> None:
    """Refuse text whose brackets open more than `MAX_DEPTH` deep, counting from ``depth``
    (1 for TOML, whose document is a table without brackets). Strings and comments are
    skipped; an unterminated string is not: its brackets count, as for a parser reading them."""
    line = 1
    for match in tokens.finditer(text):
        token = match.group()
        if token in ("[", "{"):
            depth += 1
            if depth > MAX_DEPTH:
                raise ConfigError(
                    f"{where}: line {line}: lists or tables nested more than {MAX_DEPTH} deep"
                )
        elif token in ("]", "}"):
            depth = max(0, depth - 1)
        else:
            line += token.count("\n")


def check_depth(data: Any, where: str) -> None:
    """Refuse ``data`` whose lists and tables nest more than `MAX_DEPTH` deep (``data`` itself
    is the first level; looked at without recursion)."""
    stack: list[tuple[Any, int]] = [(data, 1)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, dict):
            children: Any = value.values()
        elif isinstance(value, list):
            children = value
        else:
            continue
        if depth > MAX_DEPTH:
            raise ConfigError(f"{where}: lists or tables nested more than {MAX_DEPTH} deep")
        stack.extend((child, depth + 1) for child in children)


def parse_toml(text: str, where: str, *, problem: str = "not valid TOML") -> dict[str, Any]:
    """The TOML document ``text`` (read from ``where``); `ConfigError` ``where: problem: ...``
    for text that is not TOML, and for nesting deeper than `MAX_DEPTH`."""
    import tomllib  # here: a command that reads no file starts sooner

    data: dict[str, Any] = _parse(
        text, where, problem, _TOML_TOKENS, 1, tomllib.loads, tomllib.TOMLDecodeError
    )
    return data


def parse_json(text: str, where: str, *, problem: str = "not valid JSON") -> Any:
    """The JSON document ``text`` (read from ``where``); as `parse_toml`."""
    import json  # here: a command that reads no file starts sooner

    return _parse(text, where, problem, _JSON_TOKENS, 0, json.loads, json.JSONDecodeError)


def _parse(
    text: str,
    where: str,
    problem: str,
    tokens: re.Pattern[str],
    depth: int,
    load: Callable[[str], Any],
    syntax: type[ValueError],
) -> Any:
    """``load(text)`` with the brackets counted first (from ``depth``) and the result's
    nesting after; the parser's ``syntax`` errors are ``where: problem: ...``."""
    _check_brackets(text, tokens, where, depth=depth)
    try:
        data = load(text)
    except RecursionError:
        raise ConfigError(f"{where}: lists or tables nested too deep") from None
    except syntax as exc:
        raise ConfigError(f"{where}: {problem}: {exc}") from None
    except ValueError:  # an integer of more digits than Python converts
        raise ConfigError(f"{where}: {problem}: {_LONG_NUMBER}") from None
    check_depth(data, where)
    return data


def json_depth(text: str) -> int:
    """The deepest nesting of JSON arrays and objects in ``text``, strings skipped: measured
    before the standard library's parser, which recurses, ever sees a message from the network
    (the MQTT face's commands, the web page's request bodies)."""
    depth = deepest = 0
    quoted = escaped = False
    for char in text:
        if quoted:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == '"':
                quoted = False
        elif char == '"':
            quoted = True
        elif char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    return deepest


class NotJson(ConfigError):
    """A network message within its bounds that is no JSON (the MQTT face takes such a
    payload as a plain value: ``ON``, ``42``)."""


class _Unreadable(Exception):
    """A number or constant the parser hands over that no message of pyuss holds."""


def parse_message(
    raw: bytes,
    what: str,
    *,
    max_depth: int,
    max_bytes: int | None = None,
    max_number: int | None = None,
) -> Any:
    """A JSON message from the network (``what`` names it in errors: "the payload", "the
    request body"), read within bounds before the standard library's parser, which recurses,
    sees it: at most ``max_bytes`` bytes of UTF-8 text, arrays and objects nested at most
    ``max_depth`` deep, numbers of at most ``max_number`` characters, and no NaN or Infinity
    (no JSON numbers, and values the page's answers to a browser could not carry).
    `ConfigError` naming what is wrong; `NotJson` for bounded text that is not JSON."""
    import json  # here: a command that reads no message starts sooner

    if max_bytes is not None and len(raw) > max_bytes:
        raise ConfigError(f"{what} has {len(raw)} bytes; at most {max_bytes} are read")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{what} is not UTF-8 text") from None
    if json_depth(text) > max_depth:
        raise ConfigError(f"{what} is nested deeper than {max_depth} levels")

    def number(kind: Callable[[str], Any]) -> Callable[[str], Any]:
        def parse(digits: str) -> Any:
            if max_number is not None and len(digits) > max_number:
                raise _Unreadable(
                    f"a number has at most {max_number} characters, not {len(digits)}"
                )
            return kind(digits)

        return parse

    def constant(name: str) -> Any:
        raise _Unreadable(f"{name} is no JSON number")

    try:
        return json.loads(
            text, parse_int=number(int), parse_float=number(float), parse_constant=constant
        )
    except _Unreadable as exc:
        raise ConfigError(f"{what}: {exc}") from None
    except ValueError as exc:  # JSONDecodeError, or more digits than Python converts
        raise NotJson(f"{what} is not JSON: {_cut(str(exc))}") from None


def _cut(text: str, width: int = 60) -> str:
    return text if len(text) <= width else text[: width - 3] + "..."


_KEY_PATH = re.compile(r"^([A-Za-z0-9_-]+(?:\[\d+\])*(?:\.[A-Za-z0-9_-]+(?:\[\d+\])*)*): ")
_SEGMENT = re.compile(r"([A-Za-z0-9_-]+)((?:\[\d+\])?)")
_ARRAY_HEADER = re.compile(r"^\[\[\s*([^\]]+?)\s*\]\]")
_TABLE_HEADER = re.compile(r"^\[\s*([^\]]+?)\s*\]")
_KEY_LINE = re.compile(r"""^("[^"]*"|'[^']*'|[A-Za-z0-9_-]+)\s*=""")

Segment = tuple[str, int | None]


def _within(names: list[str], current: tuple[Segment, ...]) -> tuple[Segment, ...]:
    """The table ``names`` (``[a.b]``) as segments, with the array indices of the table the
    text is in where its names lead the way."""
    out: list[Segment] = []
    for i, name in enumerate(names):
        same = i < len(current) and current[i][0] == name
        out.append((name, current[i][1] if same else None))
    return tuple(out)


def toml_line(text: str, key: str) -> int | None:
    """The line of ``text`` (TOML) where ``key`` (``bus[0].drive[1].address``, as the
    configuration checks name a bad value) is written: its ``key =`` line, else the header of
    the deepest table on its way; None where the text does not show it."""
    want = tuple(
        (name, int(index[1:-1]) if index else None) for name, index in _SEGMENT.findall(key)
    )
    table: tuple[Segment, ...] = ()
    counts: dict[tuple[tuple[Segment, ...], str], int] = {}
    best, depth = None, 0
    for number, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        array, plain = _ARRAY_HEADER.match(stripped), _TABLE_HEADER.match(stripped)
        if array or plain:
            header = array or plain
            assert header is not None
            names = [n.strip().strip("\"'") for n in header.group(1).split(".")]
            if array:
                parent = _within(names[:-1], table)
                count = counts[parent, names[-1]] = counts.get((parent, names[-1]), -1) + 1
                table = (*parent, (names[-1], count))
            else:
                table = _within(names, table)
            if len(table) > depth and want[: len(table)] == table:
                best, depth = number, len(table)
            continue
        found = _KEY_LINE.match(stripped)
        if found and (*table, (found.group(1).strip("\"'"), None)) == want:
            return number
    return best


def in_file(path: str | os.PathLike[str], text: str, exc: ConfigError) -> ConfigError:
    """``exc`` of checking the TOML file ``path`` (its ``text``) as one line naming the file,
    the line and the key: ``uss.toml, line 4: bus[0].baud: expected an integer``."""
    key = _KEY_PATH.match(str(exc))
    line = None if key is None else toml_line(text, key.group(1))
    return ConfigError(f"{path}{'' if line is None else f', line {line}'}: {exc}")
