"""A face's wish checked whole before anything goes out: the pure checks of a request.

No I/O, no event loop: `pyuss.points.drive.DrivePoints` runs these before it tells the
master anything, and ``uss run --setpoint`` runs `checked_setpoint` itself. The rules:

- A setpoint is checked once (`checked_setpoint`; a drive's, `drive_setpoint`): in percent,
  in the reference's unit or raw, a finite number or a number as text, within the word's
  range (16 bits: -200 % .. +199.99 %, 32 bits for a double word; 4000h = 100 % of C 5.2.2).
  A number as text has at most `MAX_TEXT` characters of ASCII digits (`DECIMAL`);
  hexadecimal is a raw word only, and the words of `NOT_FINITE` are no number.
- A command is one of one table (`pyuss.points.model.COMMAND_TABLE`, `command_named`); a
  control word a face sends is 0..FFFFh (`checked_control`), raw process words are 16-bit
  words of the drive's layout, PZD2 and up (`checked_words`), all checked before any is set.
- Until a command the master sends 0000h, no control by the interface, so a face started
  again stops no running drive. On a drive that is switched on (or has not answered) a
  command that changes bits of the word in force (acknowledge, jog) would take control
  with OFF1 then, and ON with setpoints nobody set here: refused (`check_takeover`,
  `NotInControl`).
- A refusal raises `ConfigError` (an unknown point or command `UnknownPoint`) naming what is
  wrong, with the client's value cut short (`shown`); nothing is changed.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence

from pyuss.errors import ConfigError
from pyuss.points.errors import NotInControl, UnknownPoint
from pyuss.points.model import COMMAND_TABLE, Command, DriveModel
from pyuss.points.state import ProcessValue, setpoint_span, signed
from pyuss.protocol.layout import Layout
from pyuss.protocol.pzd import (
    percent_to_raw16,
    percent_to_raw32,
    raw16_to_percent,
    raw32_to_percent,
)

__all__ = [
    "DECIMAL",
    "MAX_TEXT",
    "NOT_FINITE",
    "check_takeover",
    "checked_control",
    "checked_setpoint",
    "checked_words",
    "command_named",
    "drive_setpoint",
    "setpoint_point",
    "setpoint_units",
    "shown",
    "unit_kind",
]

MAX_TEXT = 64
"""The longest number a face may give as text (a setpoint typed on the page)."""
DECIMAL = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
"""A number as a setpoint is written (``25``, ``-12.5``, ``.5``, ``1e1``): ASCII digits."""
NOT_FINITE = ("inf", "infinity", "nan")
"""Words a float reads as a number that is none (signs and case aside)."""
_DECIMAL = re.compile(DECIMAL, re.ASCII)
_HEX = re.compile(r"[+-]?0[xX][0-9a-fA-F]+", re.ASCII)


def checked_setpoint(
    value: object,
    kind: str,
    *,
    reference: float | None,
    unit: str,
    key: str = "main",
    pzd: int = 2,
    dword: bool = False,
    where: str = "the drive",
) -> ProcessValue:
    """The one check of a setpoint (`DrivePoints.check_setpoint`, ``uss run --setpoint``):
    ``value`` a finite number or a number as text; ``kind`` ``value`` (in ``unit``, through
    ``reference``, the physical value of 100 %; percent where ``unit`` is ``%``),
    ``percent`` or ``raw``; the word's range bounds it (16 bits: -200 % .. +199.99 %, 32
    bits with ``dword``; C 5.2.2). Returns the setpoint as it would be sent; `ConfigError`
    names what is wrong, a value beyond the word by the span of `setpoint_span` in the unit
    it was given in."""
    bits = 32 if dword else 16
    number = _number(value, "setpoint", raw=kind == "raw")
    if kind == "raw":
        if number != int(number):
            raise ConfigError(f"a raw setpoint is a whole number, not {number!r}")
        raw = int(number)
        low, high = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
        if not low <= raw <= high:
            raise ConfigError(f"raw setpoint {shown(raw)} does not fit {bits} bits ({low}..{high})")
        word = raw & ((1 << bits) - 1)
    else:
        in_unit = kind == "value" and unit != "%"
        if in_unit and (reference is None or not reference > 0):
            raise ConfigError(
                f"{where}: the reference is not known yet: give the setpoint in percent"
            )
        try:
            percent = number * 100.0 / reference if in_unit and reference else float(number)
            word = percent_to_raw32(percent) if dword else percent_to_raw16(percent)
        except (ConfigError, OverflowError):
            percents = setpoint_span(None, "%", dword=dword)
            if in_unit:
                span = setpoint_span(reference, unit, dword=dword)
                raise ConfigError(
                    f"setpoint {shown(number)} {unit} is outside {span} ({percents} of the "
                    f"reference, {bits} bits, C 5.2.2)"
                ) from None
            raise ConfigError(
                f"setpoint {shown(number)} % is outside {percents} of the reference "
                f"({bits} bits, C 5.2.2)"
            ) from None
    percent = raw32_to_percent(word) if dword else raw16_to_percent(word)
    known = reference is not None or unit == "%"
    return ProcessValue(
        key,
        pzd,
        signed(word, bits),
        round(percent, 6),
        round(percent * (reference or 100.0) / 100.0, 6) if known else None,
        unit,
    )


def checked_control(word: object) -> int:
    """A control word as a face gives it: a whole number 0..FFFFh; `ConfigError` otherwise."""
    if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
        raise ConfigError(f"control word must be 0..65535 (0..FFFFh), not {word!r}")
    return word


def checked_words(words: Mapping[int, int], layout: Layout, where: str) -> dict[int, int]:
    """Raw PZD words (``{number: word}``) as a face gives them, all checked before any is set:
    a number from 2 to the last PZD of ``layout`` (`UnknownPoint` beyond it), a 16-bit word;
    `ConfigError` names what is wrong."""
    words = dict(words)
    for number, value in words.items():
        if isinstance(number, bool) or not isinstance(number, int):
            raise ConfigError(f"PZD number must be a whole number, not {shown(number)}")
        if not 2 <= number <= layout.pzd:
            raise UnknownPoint(f"{where}: PZD{number} is not in layout {layout}")
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF:
            raise ConfigError(f"PZD{number} must be a 16-bit value, not {shown(value)}")
    return words


def drive_setpoint(
    model: DriveModel, reference: float | None, value: object, key: str, unit: object
) -> ProcessValue:
    """`checked_setpoint` of setpoint ``key`` of the drive of ``model``, whose reference is
    ``reference`` (None: not known), with ``unit`` as a face gives it (`unit_kind`)."""
    pzd, dword = setpoint_point(model, key)
    return checked_setpoint(
        value,
        unit_kind(model, reference, unit),
        reference=reference,
        unit=model.unit,
        key=key,
        pzd=pzd,
        dword=dword,
        where=model.key,
    )


def setpoint_point(model: DriveModel, key: str) -> tuple[int, bool]:
    """The first PZD number of setpoint ``key`` of ``model`` and whether it is a double word;
    `UnknownPoint` if the drive has no such setpoint."""
    for item in model.setpoints:
        if item.key == key:
            return item.pzd, item.dword
    raise UnknownPoint(f"{model.key}: no setpoint {shown(key)}")


def setpoint_units(model: DriveModel, reference: float | None) -> tuple[str, ...]:
    """The units a setpoint of ``model`` may be given in: ``%`` and, where the reference is
    known, its unit (``raw`` besides, for the word itself)."""
    unit = model.unit
    return ("%",) if unit == "%" or reference is None else ("%", unit)


def unit_kind(model: DriveModel, reference: float | None, unit: object) -> str:
    """The kind of `checked_setpoint` a setpoint's ``unit`` names: ``value`` (or the drive's
    unit by name), ``percent`` (or ``%``) or ``raw``; `ConfigError` naming the units taken."""
    if unit in ("value", "raw"):
        return str(unit)
    if unit in ("percent", "%"):
        return "percent"
    if isinstance(unit, str) and unit == model.unit and unit:
        return "value"
    takes = " or ".join(repr(u) for u in (*setpoint_units(model, reference), "raw"))
    raise ConfigError(f"setpoint unit {shown(unit)}: {model.key} takes {takes}")


def check_takeover(command: Command, unset: Sequence[str], running: str | None, where: str) -> None:
    """Refuse a command that would take over a drive switched on by a master before this one
    (a gateway or page started again) with what nobody asked for, while this master has sent
    no control word (0000h): the drive runs on the process data it had, and a command takes
    control with the setpoints of this master. Acknowledge and jog change bits of the word in
    force and start from 047Eh, OFF1: they would stop it. ON would set it to setpoints nobody
    set here (0 after a start): refused until every setpoint of the drive was set here
    (``unset`` names the others). OFF1/2/3 stop it, as asked. ``running``: why the drive may
    be running (`pyuss.points.line.Drive.running_elsewhere`), None if it is off or in fault;
    ``where``: the drive, for the message of `NotInControl`."""
    if running is None or (command.whole and not (command.moves and unset)):
        return
    if command.whole:
        would = f"with setpoint {', '.join(unset)} 0, which nobody set here"
        advice = "set the setpoint first (on sends it), or send off1"
    else:
        would = "with OFF1 (047Eh)"
        advice = "set the setpoint and send on, or send off1 first"
    raise NotInControl(
        f"{where}: {command.name} refused: the drive {running}, and this master has sent "
        "it no control word yet (0000h: no control by the interface, the drive keeps "
        f"the process data it had), so {command.name} would take control {would}; "
        f"{advice}"
    )


def command_named(name: object) -> Command:
    """The command of `COMMAND_TABLE` named ``name``; `UnknownPoint` naming the known ones."""
    command = COMMAND_TABLE.get(name) if isinstance(name, str) else None
    if command is None:
        raise UnknownPoint(f"unknown command {shown(name)} (known: {', '.join(COMMAND_TABLE)})")
    return command


def shown(value: object) -> str:
    """A client's value in an error message, cut short (a 400-digit number, a long text)."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _number(value: object, what: str, *, raw: bool = False) -> int | float:
    """A finite number, or a number as text (at most `MAX_TEXT` characters, ASCII digits:
    ``25``, ``-12.5``, ``1e2``; a ``raw`` one in hexadecimal too: ``0x2000``)."""
    if isinstance(value, str):
        value = _parse_number(value.strip(), what, raw=raw)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"{what} must be a finite number, not {shown(value)}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{what} must be a finite number, not {value!r}")
    return value


def _parse_number(text: str, what: str, *, raw: bool) -> int | float:
    if len(text) <= MAX_TEXT:
        if _HEX.fullmatch(text):
            if raw:
                return int(text, 16)
            raise ConfigError(
                f"{what} {shown(text)}: a hexadecimal number is taken as a raw word only; "
                "give percent or the unit in decimal"
            )
        if text.lower().lstrip("+-") in NOT_FINITE:
            raise ConfigError(f"{what} must be a finite number, not {text}")
        if _DECIMAL.fullmatch(text):
            return int(text) if text.lstrip("+-").isdigit() else float(text)
    raise ConfigError(f"{what} {shown(text)} is not a number")
