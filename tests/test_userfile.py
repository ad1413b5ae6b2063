"""Files a user hands to pyuss: every reader refuses a bad one in one line naming it (the
commands' tests run `bad_files` through ``uss gateway --config``, ``uss diff``, ``uss restore``
and ``--params``); brackets in strings and comments are no nesting."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.userfile import (
    MAX_DEPTH,
    NotJson,
    parse_json,
    parse_message,
    parse_toml,
    read_text,
)

DEEP = 5000
"""Far deeper than Python's recursion limit."""


def bad_files(folder: Path, what: str, *, json_too: bool = False) -> list[tuple[Path, str]]:
    """Files in ``folder`` that no reader takes, each with what the message refusing it says
    after ``FILE: `` (``what``: how the reader names such a file)."""
    nested = f"lists or tables nested more than {MAX_DEPTH} deep"
    contents: dict[str, tuple[bytes | None, str]] = {
        "missing.toml": (None, f"cannot read {what}: No such file or directory"),
        "latin1.toml": ('name = "Drehzahl für"\n'.encode("latin-1"), f"{what} is not UTF-8"),
        "binary.toml": (b"\x00\x01\x02\x03PK", f"{what} is not a text file"),
        "empty.toml": (b"\n", f"{what} is empty"),
        "lists.toml": (f"a = {'[' * DEEP}{']' * DEEP}\n".encode(), f"line 1: {nested}"),
        "tables.toml": (f"\na = {'{b = ' * DEEP}1{'}' * DEEP}\n".encode(), f"line 2: {nested}"),
        "dotted.toml": (f"[{'.'.join(['a'] * DEEP)}]\n".encode(), nested),
        "long.toml": (f"a = 1{'0' * DEEP}\n".encode(), "a number of thousands of digits"),
    }
    if json_too:
        contents["lists.json"] = (f'{{"a": {"[" * DEEP}{"]" * DEEP}}}'.encode(), nested)
    cases = []
    for name, (data, message) in contents.items():
        path = folder / name
        if data is not None:
            path.write_bytes(data)
        cases.append((path, message))
    folder_case = folder / "folder.toml"
    folder_case.mkdir()
    cases.append((folder_case, f"cannot read {what}: it is a folder"))
    return cases


def test_every_bad_file_is_one_clear_error(tmp_path: Path) -> None:
    for path, message in bad_files(tmp_path, "the file", json_too=True):
        with pytest.raises(ConfigError) as caught:
            text = read_text(path, "the file")
            (parse_json if path.suffix == ".json" else parse_toml)(text, str(path))
        assert refuses(str(caught.value), path, message)


def refuses(line: str, path: Path, message: str) -> bool:
    """Whether ``line`` is the refusal of ``path`` that `bad_files` expects."""
    return line.startswith(f"{path}: ") and message in line


def test_brackets_in_strings_and_comments_are_no_nesting() -> None:
    many = "[{" * 100
    text = (
        f"a = \"{many}\"\nb = '{many}'\nc = \"\"\"\n{many}\n\"\"\"\nd = '''{many}'''\n"
        f"# {many}\ne = [[[1]]]\n"
    )
    assert parse_toml(text, "t.toml")["e"] == [[[1]]]
    assert parse_json(json.dumps({"a": many, "b": [[1]]}), "t.json")["a"] == many


def test_the_deepest_nesting_allowed_is_read() -> None:
    inner = MAX_DEPTH - 1  # the document itself is a table: one level
    assert parse_toml(f"a = {'[' * inner}{']' * inner}", "t.toml")
    with pytest.raises(ConfigError, match="nested more than"):
        parse_toml(f"a = {'[' * (inner + 1)}{']' * (inner + 1)}", "t.toml")


JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**15), 10**15)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=20),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=20,
)


@given(JSON_VALUES)
def test_a_network_message_within_its_bounds_reads_as_written(value: object) -> None:
    raw = json.dumps(value).encode()
    assert parse_message(raw, "the message", max_depth=64, max_number=32) == value


@pytest.mark.parametrize(
    ("raw", "words"),
    [
        (b"[" * DEEP + b"]" * DEEP, "the message is nested deeper than 4 levels"),
        (b'{"a": [[[[[1]]]]]}', "the message is nested deeper than 4 levels"),
        (b" " * 20_001, "the message has 20001 bytes; at most 20000 are read"),
        (b"\xff\xfe{}", "the message is not UTF-8 text"),
        (b"[1" + b"0" * 40 + b"]", "the message: a number has at most 24 characters, not 41"),
        (b'{"v": NaN}', "the message: NaN is no JSON number"),
        (b"[-Infinity]", "the message: -Infinity is no JSON number"),
    ],
)
def test_a_network_message_beyond_its_bounds_is_refused_naming_why(raw: bytes, words: str) -> None:
    with pytest.raises(ConfigError) as refused:
        parse_message(raw, "the message", max_depth=4, max_bytes=20_000, max_number=24)
    assert str(refused.value) == words
    assert not isinstance(refused.value, NotJson)


def test_bounded_text_that_is_no_json_is_told_apart() -> None:
    for raw in (b"ON", b"", b"{", b'"open'):
        with pytest.raises(NotJson, match="the payload is not JSON"):
            parse_message(raw, "the payload", max_depth=4)
    # a string holding brackets is no nesting
    assert parse_message(b'"[[[[[[[["', "the payload", max_depth=1) == "[[[[[[[["


# -- where in the file a bad value is written ---------------------------------------------

PLANT_TEXT = """\
[[bus]]
name = "l1"
port = "tcp://127.0.0.1:1"

[[bus.drive]]
name = "a"
address = 5

[[bus]]
name = "l2"
"port" = "tcp://127.0.0.1:2"
[[bus.drive]]
name = "b"
address = 5
[[bus.drive]]
name = "c"
address = 300

[mqtt]
qos = 7
"""


@pytest.mark.parametrize(
    ("key", "line"),
    [
        ("bus[0].port", 3),
        ("bus[0].drive[0].address", 7),
        ("bus[1].port", 11),  # a quoted key
        ("bus[1].drive[1].address", 17),
        ("bus[1].drive[1]", 15),  # a table: its header
        ("bus[1].drive[1].speed", 15),  # a key not written: the table it belongs in
        ("mqtt.qos", 20),
        ("opcua.listen", None),  # nothing of it in the file
    ],
)
def test_a_bad_value_is_found_on_its_line(key: str, line: int | None) -> None:
    from pyuss.userfile import toml_line

    assert toml_line(PLANT_TEXT, key) == line


def test_a_configuration_error_names_the_file_the_line_and_the_key(tmp_path: Path) -> None:
    from pyuss.gateway.config import load_config

    path = tmp_path / "uss gateway.toml"
    path.write_text(PLANT_TEXT.replace("[mqtt]\nqos = 7\n", ""), encoding="utf-8")
    with pytest.raises(ConfigError) as error:
        load_config(path)
    assert str(error.value) == f"{path}, line 17: bus[1].drive[1].address: 300 is not 0..31"
