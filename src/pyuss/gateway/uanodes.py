"""What the OPC UA face shows and allows, without a server (`pyuss.gateway.opcua` serves it
with asyncua, a drive's nodes made by `pyuss.gateway.opcua_nodes`).

- `unit_id`: the UNECE Recommendation 20 code of a unit as OPC UA's EUInformation.UnitId;
- `percent_range`, `parameter_range`: the EURange of process values and parameters;
- `may_change`: whether a session may write and call the methods that change a drive;
- `argument_fault`: Part 4's status for a method call with a wrong number of arguments;
- `drive_values`: the value of each variable of a drive, by node name, from its state;
- `value_status`: the StatusCode each of them carries (Part 4 7.39): a value of the drive's
  answers is ``BadWaitingForInitialData`` until the drive answered (a parameter: until it
  was read), ``BadNoCommunication`` while the drive is offline (by its bus's offline rule,
  or its bus offline: docs/gateway.md "Availability"), ``UncertainLastUsableValue`` while it
  is online but its latest answer was missed (stale): its last answer is no measurement of
  now. What the gateway sends (control word, setpoints) and its health are its own, and
  Good; a parameter whose last poll failed is
  ``UncertainLastUsableValue`` (the value read before); a process value in the drive's unit
  (``.Actual.main``, ``.Setpoint.main``) is ``BadWaitingForInitialData`` until its
  reference was read.

Status codes are named as OPC UA names them (``"BadTooManyArguments"``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pyuss.points.parameters import ParamMeta
from pyuss.points.state import DriveState, Health
from pyuss.protocol.pzd import FULL_SCALE_16, FULL_SCALE_32

__all__ = [
    "FLOAT32_MAX",
    "UNECE",
    "argument_fault",
    "drive_values",
    "may_change",
    "parameter_range",
    "percent_range",
    "unit_id",
    "value_status",
]

UNECE = {
    "Hz": "HTZ",
    "kHz": "KHZ",
    "A": "AMP",
    "mA": "4K",
    "V": "VLT",
    "W": "WTT",
    "kW": "KWT",
    "s": "SEC",
    "ms": "C26",
    "min": "MIN",
    "h": "HUR",
    "%": "P1",
    "°C": "CEL",
    "K": "KEL",
    "rpm": "RPM",
    "1/min": "RPM",
    "Nm": "NU",
}
"""UNECE Recommendation 20 codes of the units drives use (OPC UA EngineeringUnits)."""

FLOAT32_MAX = 3.4028234663852886e38
"""The largest IEEE 754 single: the range of a float parameter without limits."""


def unit_id(unit: str) -> int:
    """The UnitId of ``unit``: its UNECE code's characters as one number, -1 without one."""
    code = UNECE.get(unit)
    if code is None:
        return -1
    number = 0
    for char in code:
        number = number << 8 | ord(char)
    return number


def percent_range(dword: bool) -> tuple[float, float]:
    """What a process word carries, in percent (16 bits: -200 % .. +199.99 %)."""
    full, bits = (FULL_SCALE_32, 32) if dword else (FULL_SCALE_16, 16)
    return -(1 << (bits - 1)) * 100.0 / full, ((1 << (bits - 1)) - 1) * 100.0 / full


def parameter_range(meta: ParamMeta) -> tuple[float, float]:
    """The EURange of a parameter: its limits where the parameter file gives them, else what
    its word(s) can carry."""
    if meta.minimum is not None and meta.maximum is not None:
        return float(meta.minimum), float(meta.maximum)
    if meta.is_float:
        return -FLOAT32_MAX, FLOAT32_MAX
    bits = 32 if meta.dword else 16
    low, high = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if meta.signed else (0, (1 << bits) - 1)
    return float(meta.physical(low)), float(meta.physical(high))


def may_change(user: str | None, *, anonymous: str, read_only: bool) -> bool:
    """Whether a session may write variables and call the methods that change a drive.
    ``user``: ``"anonymous"``, ``"user"`` (one of the configured users) or None (no
    activated session); ``anonymous``: the face's option (``"read"``, ``"write"``,
    ``"none"``)."""
    if read_only or user is None:
        return False
    if user == "anonymous":
        return anonymous == "write"
    return user == "user"


def argument_fault(given: int, expected: int) -> str | None:
    """The status of a call with ``given`` arguments to a method taking ``expected`` (Part
    4, Call), None if the count is right."""
    if given < expected:
        return "BadArgumentsMissing"
    if given > expected:
        return "BadTooManyArguments"
    return None


def drive_values(state: DriveState) -> dict[str, Any]:
    """The value of each variable of a drive by its name under the drive's object
    (``.StatusWord``, ``.Actual.main``, ...): NaN for a value not known."""
    found: dict[str, Any] = {}
    for _source, values in value_parts(state):
        found.update(values())
    return found


def value_parts(state: DriveState) -> list[tuple[object, Callable[[], dict[str, Any]]]]:
    """`drive_values` in parts, each with what it is made from: a part whose source is the
    same (``==``) as in an earlier state has the same values."""
    return [
        ((state.status_word, state.control_word), lambda: _status_values(state)),
        ((state.health, state.online), lambda: _health_values(state.health, state.online)),
        (
            (state.actual_words, state.setpoint_words, state.reference, state.model),
            lambda: _process_values(state),
        ),
        (
            tuple(state.parameters.items()),
            lambda: {
                f".Parameters.{key}": math.nan if reading.value is None else float(reading.value)
                for key, reading in state.parameters.items()
            },
        ),
    ]


def _status_values(state: DriveState) -> dict[str, Any]:
    found: dict[str, Any] = {
        ".StatusWord": state.status_word or 0,
        ".State": state.state,
        ".ControlWord": state.control_word & 0xFFFF,
        ".StatusText": state.status_text or "",
        ".ControlText": state.control_text,
    }
    for name, on in state.bits.items():
        found[f".Status.{name}"] = on
    return found


def _health_values(health: Health, online: bool) -> dict[str, Any]:
    found: dict[str, Any] = {
        ".Health.Online": online,
        ".Health.NotSending": health.not_sending,
        ".Health.Counters": list(health.counters.words()),
        ".Health.Answers": health.answers & 0xFFFF_FFFF,
        ".Health.Timeouts": health.timeouts & 0xFFFF_FFFF,
        ".Health.LastFault": (health.last_fault or 0) & 0xFFFF_FFFF,
    }
    refusal = health.last_refusal
    if refusal is not None:
        number = 8 if refusal.get("response_id") == 8 else int(refusal.get("number", -1))
        found[".Health.LastErrorNumber"] = number
        found[".Health.LastErrorPnu"] = int(refusal.get("pnu", -1))
    return found


def _process_values(state: DriveState) -> dict[str, Any]:
    found: dict[str, Any] = {}
    for kind, values in (("Actual", state.actual), ("Setpoint", state.setpoints)):
        for key, value in values.items():
            found[f".{kind}.{key}"] = math.nan if value.value is None else value.value
            found[f".{kind}Percent.{key}"] = value.percent
    return found


WAITING = "BadWaitingForInitialData"
LAST_USABLE = "UncertainLastUsableValue"
OFFLINE = "BadNoCommunication"

_ANSWERED = (
    ".StatusWord",
    ".StatusText",
    ".State",
    ".Status.",
    ".Actual.",
    ".ActualPercent.",
)
"""The variables made of the drive's answers (with ``.Parameters.``: of its parameter jobs)."""


def value_status(state: DriveState, key: str) -> str | None:
    """The StatusCode of variable ``key`` in ``state`` (None: Good); see the module
    docstring. A process value in the drive's unit waits for its reference as well."""
    in_unit = key.startswith((".Actual.", ".Setpoint."))
    if in_unit and state.reference is None and state.model.unit != "%":
        return WAITING  # NaN: the physical value of 100 % is not read yet
    if key.startswith(".Parameters."):
        reading = state.parameters.get(key[len(".Parameters.") :])
        if reading is None or reading.value is None:
            return WAITING
        if reading.error is not None:
            return LAST_USABLE  # its last poll failed: the value is the one read before
    elif not key.startswith(_ANSWERED):
        return None
    elif not state.answered:
        return WAITING
    if not state.online:
        return OFFLINE
    return LAST_USABLE if state.stale else None
