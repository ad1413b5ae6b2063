"""The VALUES of uss log."""

from __future__ import annotations

import pytest

from pyuss.datalog import Kind, parse_values
from pyuss.errors import ConfigError


def test_values_are_understood() -> None:
    values = parse_values(["status", "State", "actual", "fault", "bit9", "P52", "P4.2", "r352"])
    assert [v.kind for v in values] == [
        Kind.STATUS,
        Kind.STATE,
        Kind.ACTUAL,
        Kind.BIT,
        Kind.BIT,
        Kind.PARAMETER,
        Kind.PARAMETER,
        Kind.PARAMETER,
    ]
    assert values[3].bit == 3 and values[4].bit == 9
    assert (values[6].pnu, values[6].index) == (4, 2)
    assert (values[7].pnu, values[7].index) == (352, None)


@pytest.mark.parametrize("text", ["speed", "P", "P4.300", "bit16"])
def test_values_not_understood_are_named(text: str) -> None:
    with pytest.raises(ConfigError, match=text.replace(".", r"\.")):
        parse_values([text])


def test_at_least_one_value() -> None:
    with pytest.raises(ConfigError):
        parse_values([])


def test_parameters_take_every_spelling() -> None:
    values = parse_values(["r0021", "P0947[1]", "21.0", "p1120"])
    assert [(v.pnu, v.index) for v in values] == [(21, None), (947, 1), (21, 0), (1120, None)]
    with pytest.raises(ConfigError) as info:
        parse_values(["P21x"])
    assert str(info.value) == (
        "value 'P21x' is not a parameter number (for example r0021, P1120, 21 or 947.1)"
    )
