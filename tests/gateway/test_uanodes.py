"""The OPC UA face's rules without a server: units, ranges, rights and argument counts."""

from __future__ import annotations

from dataclasses import replace

import pytest

from pyuss.gateway.uanodes import (
    FLOAT32_MAX,
    argument_fault,
    drive_values,
    may_change,
    parameter_range,
    percent_range,
    unit_id,
    value_status,
)
from pyuss.points.config import plant_from_flags
from pyuss.points.model import DriveModel, resolve
from pyuss.points.parameters import ParameterModel, ParamMeta
from pyuss.points.state import DriveState, Health, ParamValue, now, process_value


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


def _drive_5() -> DriveModel:
    """Drive 5 of a generic bus with layout 4,2, as `uss gateway` would configure it."""
    plant = plant_from_flags(
        port="bus://x:1", addresses=[5], baud=38400, layout="4,2", profile="generic"
    )
    return resolve(plant).buses[0].drives[0]


def test_a_value_in_the_drives_unit_waits_for_its_reference() -> None:
    # answered, but P352 not read yet: the value in Hz is not known (NaN), which is no Good
    # value; its percent is
    model = _drive_5()
    main = process_value("main", 2, False, (0x2000,), None, model.unit)
    assert main is not None and main.value is None
    state = DriveState(
        model=model, time=now(), status_word=0x0237, control_word=0x047F,
        actual={"main": main}, setpoints={"main": main}, parameters={}, health=Health(),
        reference=None, actual_words=(0x2000,), setpoint_words=(0x2000,),
    )  # fmt: skip
    assert model.unit == "Hz" and drive_values(state)[".Actual.main"] != 0.0
    for key in (".Actual.main", ".Setpoint.main"):
        assert value_status(state, key) == "BadWaitingForInitialData", key
    for key in (".ActualPercent.main", ".SetpointPercent.main", ".StatusWord"):
        assert value_status(state, key) is None, key
    known = replace(state, reference=50.0)
    assert value_status(known, ".Actual.main") is None


def test_a_parameter_whose_last_poll_failed_is_its_last_usable_value() -> None:
    # P107 read 50 Hz once; the next poll was refused: 50 Hz is what was last read, not what
    # the drive holds now
    model = _drive_5()
    meta = ParameterModel("generic").meta(107, None)
    read = ParamValue(meta, 50.0, now())
    state = DriveState(
        model=model, time=now(), status_word=0x0237, control_word=0x047F, actual={},
        setpoints={}, parameters={"P107": read}, health=Health(), reference=50.0,
    )  # fmt: skip
    assert value_status(state, ".Parameters.P107") is None
    failed = replace(
        read, error={"type": "DriveRefusal", "message": "error 101", "class": "refused"}
    )
    later = replace(state, parameters={"P107": failed})
    assert value_status(later, ".Parameters.P107") == "UncertainLastUsableValue"
