"""`pyuss.tomlwrite`: what it writes, ``tomllib`` reads back as the data given."""

from __future__ import annotations

import math
import tomllib
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.tomlwrite import dumps

KEYS = st.text(st.characters(exclude_categories=("Cs",)), max_size=8)
TEXT = st.text(st.characters(exclude_categories=("Cs",)), max_size=20)
SCALARS = TEXT | st.integers(-(2**63), 2**63 - 1) | st.floats(allow_nan=False) | st.booleans()
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(KEYS, inner, max_size=4),
    max_leaves=20,
)
TABLES = st.dictionaries(KEYS, VALUES, max_size=6)


@settings(max_examples=300, deadline=None)
@given(TABLES)
def test_tomllib_reads_back_what_was_written(data: dict[str, Any]) -> None:
    assert tomllib.loads(dumps(data)) == data


def test_tables_and_arrays_of_tables_are_written_as_such() -> None:
    data = {
        "name": "x",
        "bus": [{"name": "line1", "baud": 19200, "drive": [{"address": 5}, {"address": 6}]}],
        "web": {"port": 8080, "open": False},
    }
    text = dumps(data)
    assert "[[bus]]" in text and "[[bus.drive]]" in text and "[web]" in text
    assert tomllib.loads(text) == data


def test_nan_and_infinity_are_written_as_toml_has_them() -> None:
    back = tomllib.loads(dumps({"a": math.nan, "b": math.inf, "c": -math.inf}))
    assert math.isnan(back["a"]) and back["b"] == math.inf and back["c"] == -math.inf


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"a": None}, "a: TOML has no value for NoneType None"),
        ({"a": {"b": 2**64}}, "a.b: 18446744073709551616 is beyond the 64 bits"),
        ({"a": [b"x"]}, "a: TOML has no value for bytes"),
        ({1: 2}, "TOML keys are text: 1 in the top"),
    ],
)
def test_what_toml_cannot_hold_is_refused_naming_the_key(
    data: dict[Any, Any], message: str
) -> None:
    with pytest.raises(TypeError, match="^" + message.replace("(", r"\(")):
        dumps(data)
