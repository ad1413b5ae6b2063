"""What a drive's points mean to a person at a panel: did a command take, is the drive ramping,
which setpoint is in force, what a refused setpoint needs - the words of the web page's drive
view (`pyuss.web`), read from `DriveState` and `DrivePoints` alone.

- `motion`: the ramp state from the status bits, the control word in force and the main
  actual value against the setpoint: ``ramping up``, ``at setpoint``, ``OFF1 active, ramping
  down``, ``jogging``, ``stopped``.
- `command_outcome`: after a command's telegram was answered, whether the drive took it - its
  state becomes the one the command leads to within a short time (`TAKE_TIME`) - and if not,
  what it did instead and what to do.
- `fault_panel`: the active fault and warning, the fault history and the warning numbers
  with the family's texts, read through the parameter channel where the family has them.
- `key_actuals` / `read_key_actuals`: the family's key actual values (frequency, current,
  voltages, power, motor temperature) through the parameter channel, where its file has them.
- `setpoint_refusal`: why a setpoint cannot be sent, in words, with the span the drive's word
  carries.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pyuss.errors import ConfigError, UssError, UssTimeout
from pyuss.params.book import ParamReader
from pyuss.params.model import Reading
from pyuss.params.values import format_value
from pyuss.points.drive import DrivePoints
from pyuss.points.errors import Failure, classify
from pyuss.points.state import DriveState, ProcessValue
from pyuss.protocol.pzd import ControlWord, StatusWord

__all__ = [
    "TAKE_TIME",
    "Outcome",
    "ParamReader",
    "command_outcome",
    "fault_history",
    "fault_panel",
    "key_actual",
    "key_actuals",
    "motion",
    "read_key_actuals",
    "setpoint_refusal",
]

TAKE_TIME = 1.5
"""How long a command's state may take to show after its telegram was answered (seconds)."""
AT_REST = 0.5
"""An actual value below this (percent of the reference) is a motor at rest."""
AT_SETPOINT = 1.0
"""An actual value this close to the setpoint (percent of the reference) is at setpoint; the
values decide, not status bit 8 alone (whose tolerance band is the drive's)."""

Goal = Callable[[DriveState, DriveState], bool]
"""``goal(before, now)``: the state ``now`` is the one a command leads to."""


def _running(state: DriveState) -> bool:
    return bool((state.status_word or 0) & StatusWord.OPERATION_ENABLED)


def _main(values: dict[str, ProcessValue]) -> ProcessValue | None:
    return values.get("main") or next(iter(values.values()), None)


def _stopping(before: DriveState, now: DriveState) -> bool:
    """Leaving operation, or ramping down towards it (the OFF commands, jog off)."""
    if not _running(now):
        return True
    word = now.status_word or 0
    if not _running(before) and not word & StatusWord.OPERATION_ENABLED:
        return True
    return motion(now).startswith(("OFF1", "ramping down"))


def _off(bit: StatusWord) -> Goal:
    def goal(before: DriveState, now: DriveState) -> bool:
        return not (now.status_word or 0) & bit or not _running(now)

    return goal


GOALS: dict[str, tuple[str, Goal]] = {
    "on": ("operation enabled", lambda before, now: _running(now)),
    "off1": ("ramping down and switched off", _stopping),
    "off2": ("pulses off, the motor coasts", _off(StatusWord.NO_OFF2)),
    "off3": ("quick stop", _off(StatusWord.NO_OFF3)),
    "acknowledge": (
        "no fault",
        lambda before, now: not (now.status_word or 0) & StatusWord.FAULT,
    ),
    "jog1": ("jogging (operation enabled)", lambda before, now: _running(now)),
    "jog2": ("jogging (operation enabled)", lambda before, now: _running(now)),
    "jog_off": (
        "jog off",
        lambda before, now: not _running(before) or _stopping(before, now),
    ),
}
"""What each command of `pyuss.points.COMMAND_TABLE` leads to, and how to tell it did."""

ADVICE: dict[str, str] = {
    "on": "switch on needs the drive ready: acknowledge a fault, give OFF1 once after OFF2 or "
    "OFF3, and check that the drive takes its commands from the bus (control requested, "
    "status bit 9)",
    "jog1": "jog needs the drive at standstill and switched off (ready to switch on) on most "
    "drives; give OFF1 first, and check that the drive takes its commands from the bus",
    "acknowledge": "the cause of the fault is still there: remove it, then acknowledge again",
}
ADVICE["jog2"] = ADVICE["jog1"]
GENERAL_ADVICE = (
    "check that the drive takes its commands from the bus (control requested, status bit 9)"
)


def motion(state: DriveState) -> str:
    """The ramp state a panel shows: ``stopped`` (or the state, when not running), ``jogging``,
    ``OFF1 active, ramping down``, ``at setpoint``, ``ramping up``, ``ramping down``;
    ``running (local operation)`` while status bit 9 says the bus's words are not in force. OFF1
    keeps a drive in "operation enabled" while it ramps down (control bit 0 = 0, status bit 2
    still 1). The main actual value against the setpoint in force tells the ramp (within
    `AT_SETPOINT`: at setpoint); status bit 8 only where either is missing. A drive marked
    "does not send" (A 5.2.1.1) is ``does not send``: its last answer tells nothing of now."""
    if state.answered and state.health.not_sending:
        return "does not send"
    actual = _main(state.actual)
    setpoint = _main(state.setpoints)
    return motion_of(
        state.status_word,
        state.control_word,
        None if actual is None else actual.percent,
        None if setpoint is None else setpoint.percent,
    )


def motion_of(word: int | None, control: int, actual: float | None, setpoint: float | None) -> str:
    """`motion` from the status word, the control word sent, and the main actual value and
    setpoint in percent (None: not there), as a state message of the gateway carries them."""
    if word is None:
        return "no answer"
    if not word & StatusWord.OPERATION_ENABLED:
        return "stopped" if not word & StatusWord.FAULT else "fault"
    if not word & StatusWord.CONTROL_REQUESTED:
        # local operation only (C Table 5.5 bit 9): the words the bus sends are not in force
        return "running (local operation)"
    turning = actual is not None and abs(actual) >= AT_REST
    if control & (ControlWord.JOG1 | ControlWord.JOG2):
        return "jogging"
    if not control & ControlWord.ON:
        return "OFF1 active, ramping down" if turning else "OFF1 active, stopping"
    if actual is None or setpoint is None:
        return "at setpoint" if word & StatusWord.IN_TOLERANCE else "running"
    if abs(actual - setpoint) <= AT_SETPOINT:
        return "at setpoint"
    if turning and actual * setpoint < 0:
        return "ramping down"  # towards standstill, to run up the other way
    if abs(actual) < abs(setpoint):
        return "ramping up"
    return "ramping down"


@dataclass(frozen=True, slots=True)
class Outcome:
    """Whether the drive took a command, in words (`command_outcome`)."""

    command: str
    taken: bool
    text: str
    state: DriveState

    def to_dict(self) -> dict[str, Any]:
        word = self.state.status_word
        return {
            "command": self.command,
            "taken": self.taken,
            "text": self.text,
            "state": self.state.state,
            "status": word,
            "motion": motion(self.state),
        }


def _shown(state: DriveState) -> str:
    word = state.status_word
    return state.state if word is None else f"{state.state} ({word:04X}h)"


async def command_outcome(
    points: DrivePoints,
    name: str,
    before: DriveState,
    *,
    within: float = TAKE_TIME,
) -> Outcome:
    """After command ``name`` was answered: wait (at most ``within`` seconds) for the state
    the command leads to (`GOALS`); an Outcome says whether the drive took it, and when not,
    what it shows instead and what to do."""
    what, aim = GOALS[name]

    def goal(before: DriveState, now: DriveState) -> bool:
        return now.online and aim(before, now)  # a silent drive's last word tells nothing

    deadline = time.monotonic() + within
    state = points.snapshot()
    while not goal(before, state):
        left = deadline - time.monotonic()
        if left <= 0:
            break
        with contextlib.suppress(TimeoutError, UssError):
            await points.drive.next_update(timeout=min(left, 0.25))
        state = points.snapshot()
    if goal(before, state):
        return Outcome(name, True, f"{name}: done, the drive is {_motion_text(state)}.", state)
    if state.answered and not state.online:
        said = (
            f"{name}: the drive does not send (A 5.2.1.1): whether it took the command is not "
            "known. What to do: check the drive's power supply and the line"
        )
        return Outcome(name, False, f"{said}.", state)
    unchanged = state.status_word == before.status_word
    said = (
        f"the drive did not take it: its status word stayed {_shown(state)}"
        if unchanged
        else f"the drive did not take it: it shows {_shown(state)}, not {what}"
    )
    advice = ADVICE.get(name, GENERAL_ADVICE)
    return Outcome(name, False, f"{name}: {said}. What to do: {advice}.", state)


def _motion_text(state: DriveState) -> str:
    shown = _shown(state)
    moving = motion(state)
    return shown if moving in ("stopped", "fault", "no answer") else f"{shown}, {moving}"


def setpoint_refusal(points: DrivePoints, value: object, unit: str) -> str | None:
    """Why setpoint ``value`` (in ``unit``) cannot be sent, in words a person acts on, with the
    span the drive's setpoint word carries; None if it can be sent."""
    try:
        points.check_setpoint(value, unit=unit)
    except ConfigError as exc:
        reason = str(exc)
    else:
        return None
    if "is outside" not in reason:
        return f"setpoint not sent: {reason}"
    _, dword = points.setpoint_point()
    bits = 32 if dword else 16
    low, high = -200.0, 100.0 * ((1 << (bits - 1)) - 1) / (1 << (bits - 2))
    span = f"{low:g} % .. {_down(high)} %"
    reference = points.reference
    if reference is not None and points.model.unit != "%":
        scale = reference / 100.0
        span += f" ({low * scale:g} .. {_down(high * scale)} {points.model.unit})"
    return (
        f"setpoint {_cut(value)} {unit} not sent: it is beyond what the drive's setpoint word "
        "can carry. "
        f"Enter a value within {span} of the reference (USS specification C 5.2.2)."
    )


def _cut(value: object) -> str:
    """A value a person typed, cut short for a message (a 400-digit number)."""
    text = str(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _down(value: float) -> str:
    """``value`` cut (not rounded) to two decimals: the highest a person may type."""
    return f"{math.floor(value * 100) / 100:g}"


FAULT_PARAMETERS: dict[str, int] = {
    "numbers": 947,
    "times": 948,
    "values": 949,
    "warnings": 2110,
}
"""The fault history and warning parameters of the Siemens families (r0947 fault numbers,
r0948 fault times, r0949 fault values, r2110 warning numbers); read where the family's
parameter file has them."""


async def _elements(
    reader: ParamReader, pnu: int, timeout: float | None
) -> list[tuple[int | None, object]] | None:
    """Every element of ``pnu`` as ``(index, value)`` (None: the family has no such
    parameter); an element the drive refuses is left out. A job without an answer (the drive
    does not send, the line or gateway is gone) is raised: what could not be read is no
    empty history."""
    book = reader.params
    info = book.get(pnu)
    if info is None:
        return None
    indexes: list[int | None] = [None] if info.array is None else list(book.indices(info))
    out: list[tuple[int | None, object]] = []
    for index in indexes:
        try:
            reading = await reader.read_param(pnu, index, timeout=timeout)
        except UssError as exc:
            if classify(exc) in (Failure.NO_ANSWER, Failure.UNAVAILABLE):
                raise
            continue
        out.append((index, reading.value))
    return out


def _number(value: object) -> int | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return int(value)


TIME_WORDS = 3
"""Words of the fault time parameter a trip takes where it holds a time per trip rather than
per fault number (MICROMASTER 440 r0948[12] for r0947[8]: the system run time in seconds as
upper and lower word, then 0; MICROMASTER 440 Parameter List, r0948)."""


def _fault_times(
    elements: list[tuple[int | None, object]], numbers: list[int | None]
) -> dict[int | None, object]:
    """The time of each fault number element (``numbers``: their indexes): by the same index
    where the fault time parameter has one element per fault number; where it has
    `TIME_WORDS` a trip (fewer trips than fault numbers), the seconds of the trip the fault
    number belongs to (None while the drive recorded none)."""
    trips = len(elements) // TIME_WORDS
    if not trips or len(elements) == len(numbers) or len(numbers) % trips:
        return dict(elements)
    words = [_number(value) for _, value in elements]
    per_trip = len(numbers) // trips
    out: dict[int | None, object] = {}
    for position, index in enumerate(numbers):
        trip = position // per_trip
        seconds = (words[TIME_WORDS * trip] or 0) << 16 | (words[TIME_WORDS * trip + 1] or 0)
        out[index] = seconds or None
    return out


async def fault_panel(points: DrivePoints, *, timeout: float | None = None) -> dict[str, Any]:
    """The drive's faults and warnings as a panel shows them: whether a fault or warning is
    active now (status bits 3 and 7), the fault history (number, text from the family's file,
    time and value where the family keeps them) and the warning numbers with their texts.
    ``history`` and ``warnings`` are None where the family's parameter file has no such
    parameter."""
    state = points.snapshot()
    if state.answered and state.health.not_sending:
        # its last status word is no "no fault" of now, and a family without a fault
        # history would read nothing that could say so: its next answer is waited for
        with contextlib.suppress(TimeoutError, UssError):
            await points.drive.next_update(timeout=timeout or TAKE_TIME)
        state = points.snapshot()
        if not state.online:
            raise UssTimeout(
                f"drive {points.address} does not send (A 5.2.1.1): its faults are not known"
            )
    return await fault_history(
        points.drive, fault=state.fault, warning=state.warning, timeout=timeout
    )


def _numbered(
    elements: list[tuple[int | None, object]] | None, texts: Mapping[int, str]
) -> list[dict[str, Any]] | None:
    """The faults or warnings of a history parameter's ``elements`` (None: not read), each
    with its index, number and text; the elements that hold none (0) left out."""
    if elements is None:
        return None
    return [
        {"index": index, "number": number, "text": texts.get(number, "")}
        for index, raw in elements
        if (number := _number(raw))
    ]


async def fault_history(
    reader: ParamReader, *, fault: bool, warning: bool, timeout: float | None = None
) -> dict[str, Any]:
    """`fault_panel` of a drive read through ``reader``, its fault and warning bits given."""
    named = reader.profile_named  # a drive of unknown kind: numbers without texts
    profile = reader.profile
    found: dict[str, list[tuple[int | None, object]] | None] = {}
    for key, pnu in FAULT_PARAMETERS.items():
        found[key] = await _elements(reader, pnu, timeout)
    times = _fault_times(found["times"] or [], [i for i, _ in found["numbers"] or []])
    values = dict(found["values"] or [])
    history = _numbered(found["numbers"], profile.faults if named else {})
    for entry in history or ():
        entry["time"] = times.get(entry["index"])
        entry["value"] = values.get(entry["index"])
    warnings = _numbered(found["warnings"], profile.warnings if named else {})
    return {
        "fault": fault,
        "warning": warning,
        "history": history,
        "warnings": warnings,
        "parameters": {key: pnu for key, pnu in FAULT_PARAMETERS.items() if found[key] is not None},
    }


KEY_ACTUALS: tuple[int, ...] = (21, 27, 25, 26, 32, 35)
"""The key actual values of a Siemens drive's panel: output frequency (r0021), current
(r0027), voltage (r0025), DC-link voltage (r0026), power (r0032), motor temperature (r0035)."""


def key_actuals(points: DrivePoints) -> list[dict[str, Any]]:
    """Which of `KEY_ACTUALS` the drive's parameter file has (number, name, unit): the values a
    panel polls through the parameter channel beside the process data."""
    out = []
    for pnu in KEY_ACTUALS:
        info = points.drive.params.get(pnu)
        if info is not None and info.array is None and info.is_numeric:
            out.append({"pnu": pnu, "name": info.name, "unit": info.unit})
    return out


async def read_key_actuals(
    points: DrivePoints, *, timeout: float | None = None
) -> list[dict[str, Any]]:
    """The values of `key_actuals` now: ``value`` (a number in ``unit``) or ``error``."""
    out = []
    for item in key_actuals(points):
        try:
            reading = await points.read_value(item["pnu"], None, timeout=timeout)
        except UssError as exc:
            out.append({**item, "error": str(exc)})
            continue
        out.append(key_actual(item, reading))
    return out


def key_actual(item: dict[str, Any], reading: Reading) -> dict[str, Any]:
    """A key actual value ``item`` as read: ``value`` (a number in ``unit``, for the trend)
    and ``text``, the value as the parameter list and `uss read` show it (the digits of its
    parameter, with the unit)."""
    value = reading.value
    number = float(value) if isinstance(value, int | float) else None
    return {**item, "value": number, "text": format_value(reading.info, value)}
