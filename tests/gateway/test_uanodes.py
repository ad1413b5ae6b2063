"""The OPC UA face's rules without a server: units, ranges, rights and argument counts."""

from __future__ import annotations

import pytest

from pyuss.gateway.uanodes import (
    FLOAT32_MAX,
    argument_fault,
    may_change,
    parameter_range,
    percent_range,
    unit_id,
)
from pyuss.points.parameters import ParameterModel, ParamMeta


def test_a_unit_id_is_its_unece_code_and_minus_one_without_one() -> None:
    assert unit_id("Hz") == ord("H") << 16 | ord("T") << 8 | ord("Z")
    assert unit_id("%") == ord("P") << 8 | ord("1")
    assert unit_id("furlong") == -1


def test_a_process_word_carries_minus_200_to_just_below_200_percent() -> None:
    assert percent_range(False) == (-200.0, 32767 * 100 / 16384)
    assert percent_range(True) == (-200.0, (2**31 - 1) * 100 / 2**30)


def test_a_parameter_range_is_its_limits_else_what_its_words_carry() -> None:
    model = ParameterModel("generic")
    assert parameter_range(model.meta(107, None)) == (8.0, 600.0)  # limits in the file
    assert parameter_range(model.meta(3, None)) == (-327.68, 327.67)  # signed word, 0.01 Hz
    assert parameter_range(ParamMeta(2000, None, "P2000")) == (0.0, 65535.0)
    dword = ParamMeta(9, None, "P9", dword=True, signed=True)
    assert parameter_range(dword) == (-(2.0**31), 2.0**31 - 1)
    assert parameter_range(ParamMeta(9, None, "P9", is_float=True)) == (-FLOAT32_MAX, FLOAT32_MAX)


@pytest.mark.parametrize(
    ("user", "anonymous", "read_only", "allowed"),
    [
        ("user", "read", False, True),
        ("user", "read", True, False),
        ("anonymous", "read", False, False),
        ("anonymous", "write", False, True),
        ("anonymous", "write", True, False),
        (None, "write", False, False),  # no activated session
        ("admin", "write", False, False),  # no client is an admin
    ],
)
def test_who_may_change_a_drive(
    user: str | None, anonymous: str, read_only: bool, allowed: bool
) -> None:
    assert may_change(user, anonymous=anonymous, read_only=read_only) is allowed


def test_a_wrong_argument_count_is_missing_or_too_many() -> None:
    assert argument_fault(2, 3) == "BadArgumentsMissing"
    assert argument_fault(4, 3) == "BadTooManyArguments"
    assert argument_fault(0, 0) is None
