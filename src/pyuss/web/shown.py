"""How the page shows a drive's values, words and parameters: the JSON pieces the page's two
backends (`pyuss.web.backend.Backend` on a line, `pyuss.web.plant.PlantBackend` over the
broker) build their answers of, the same for both.

Parameter knowledge (names, units, types, limits, value texts) is each drive's parameter book
(`pyuss.params.ParamBook`); values are parsed, checked and shown through `pyuss.params`:
nothing here knows a drive family's facts. A parameter is named ``462`` or ``947.3``
(`param_id`); a value is shown as printed (``10.00 s``, ``1 [READY]``) and as a user types it
to write it again; a parameter the drive's telegram layout cannot carry is not asked.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Mapping, Sequence
from typing import Any

from pyuss.commission import backup as backups
from pyuss.errors import UssError
from pyuss.params import ParamBook, ParamInfo, format_value
from pyuss.params.model import Reading
from pyuss.params.values import physical
from pyuss.params.words import WordKind, format_word
from pyuss.points import DrivePoints, DriveState, ProcessValue
from pyuss.profiles import Profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pzd import STATUS_BITS

__all__ = [
    "control_in_force",
    "expert_row",
    "number_given",
    "param_id",
    "param_label",
    "read_rows",
    "setpoint_in_force",
    "setpoint_text",
    "shown_reading",
    "status_bits",
    "unit_given",
    "word_texts",
]


async def read_rows(
    refs: Sequence[tuple[int, int | None]],
    layout: Layout,
    book: ParamBook,
    read: Callable[[int, int | None], Awaitable[Reading]],
) -> list[dict[str, Any]]:
    """The page's answer to a parameter read, by ``read`` (a drive on the line, or one behind
    a gateway): per parameter ``value`` and ``input``, ``error``, or ``needs`` for one the
    ``layout`` cannot carry (the drive would refuse it, error 103: not asked)."""
    out: list[dict[str, Any]] = []
    for pnu, index in refs:
        item: dict[str, Any] = {"id": param_id(pnu, index)}
        needs = backups.beyond_layout(layout, book.get(pnu))
        if needs is not None:
            out.append({**item, "needs": needs})
            continue
        try:
            reading = await read(pnu, index)
        except UssError as exc:
            item["error"] = str(exc)
        else:
            item.update(shown_reading(reading))
        out.append(item)
    return out


def unit_given(value: object) -> object:
    return value.get("unit", "%") if isinstance(value, dict) else "%"


def number_given(value: object) -> object:
    return value.get("value") if isinstance(value, dict) else value


def setpoint_text(checked: ProcessValue, given: object) -> str:
    """A checked setpoint as a page asks about it, first in the unit it was ``given`` in:
    ``10 Hz (20 % of the reference)``, ``40 % (20 Hz)``."""
    percent = f"{round(checked.percent, 2):g} %"
    if checked.unit == "%" or checked.value is None:
        return percent
    value = f"{round(checked.value, 2):g} {checked.unit}"
    if given == checked.unit:
        return f"{value} ({percent} of the reference)"
    return f"{percent} ({value})"


def status_bits(family: Mapping[int, str]) -> list[dict[str, Any]]:
    """All 16 status bits: the family's text where it has one (what the bit shows when 1;
    "(0 = active)" marks a low-active bit), else the profile's meaning set and clear (C Tables
    5.5, 5.6); bits 11..15 of a family without texts are device-specific."""
    bits = []
    for bit in range(16):
        text = family.get(bit)
        if text is not None:
            bits.append({"bit": bit, "text": text})
        elif bit in STATUS_BITS:
            bits.append({"bit": bit, "set": STATUS_BITS[bit][0], "clear": STATUS_BITS[bit][1]})
        else:
            bits.append({"bit": bit, "text": "device-specific"})
    return bits


def word_texts(
    control: int | None, in_force: int | None, status: int | None, family: Profile | None
) -> dict[str, str | None]:
    """The control word sent, the one in force and the status word as a person reads them
    (`pyuss.params.words`: ``047Fh  ON, no OFF2, ...``, the bits 11..15 by ``family``, None:
    of unknown kind); None for a word not known."""

    def text(word: int | None, kind: WordKind) -> str | None:
        return None if word is None else format_word(word, kind, family)

    return {
        "control_text": text(control, WordKind.CONTROL),
        "control_in_force_text": text(in_force, WordKind.CONTROL),
        "status_text": text(status, WordKind.STATUS),
    }


def control_in_force(points: DrivePoints) -> int | None:
    """The control word of the request the drive's last answer answered."""
    status = points.drive.status
    return None if status is None else status.control


def setpoint_in_force(state: DriveState) -> dict[str, Any] | None:
    """The main setpoint the drive is sent now (percent, and in units where known)."""
    value = state.setpoints.get("main") or next(iter(state.setpoints.values()), None)
    return None if value is None else value.to_dict()


def param_label(pnu: int, index: int | None) -> str:
    return f"P{param_id(pnu, index)}"


def param_id(pnu: int, index: int | None) -> str:
    """How the page names a parameter: ``462``, ``947.3``."""
    return f"{pnu}" if index is None else f"{pnu}.{index}"


def _shown_raw(info: ParamInfo, raw: int | float) -> str:
    return format_value(info, physical(info, raw), unit=False, texts=False)


def _limits(info: ParamInfo) -> tuple[str | None, str | None]:
    """The lowest and highest value a write may set, as shown, where the parameter file or the
    drive's description gives limits (a side it leaves open is the bound of an integer type);
    none for a parameter without (not the bare range of its data type)."""
    if not info.is_numeric or info.is_bit_field:
        return None, None
    if info.minimum is None and info.maximum is None and not info.allowed:
        return None, None
    out: list[str | None] = []
    for raw, given in ((info.low, info.minimum), (info.high, info.maximum)):
        if raw is None or (given is None and not info.allowed and not info.dtype.is_integer):
            out.append(None)
        else:
            out.append(_shown_raw(info, raw))
    return out[0], out[1]


def expert_row(info: ParamInfo, index: int | None) -> dict[str, Any]:
    """One row of the expert list."""
    low, high = _limits(info)
    numeric = info.is_numeric and not info.is_bit_field
    allowed = [_shown_raw(info, a) for a in info.allowed or ()] if numeric else []
    return {
        "id": param_id(info.pnu, index),
        "pnu": info.pnu,
        "index": index,
        "label": info.label(index),
        "name": info.name,
        "unit": info.unit,
        "type": info.type_name,
        "writable": info.writable and not info.is_bit_field,
        "access": info.access.value,
        "min": low,
        "max": high,
        "allowed": allowed or None,
        "texts": {str(k): v.strip() for k, v in info.texts.items()},
        "level": info.level,
        "changeable": info.changeable,
        "source": info.source.value,
        "doc": info.doc,
    }


def _input(reading: Reading) -> str | None:
    """A value as a user types it to write it again (None: not editable on the page)."""
    info, value = reading.info, reading.value
    if info is None or info.is_bit_field or isinstance(value, list):
        return None
    if isinstance(value, bytes):
        return value.hex(" ").upper()
    if isinstance(value, str):
        return value.rstrip()
    return format_value(info, value, unit=False, texts=False)


def shown_reading(reading: Reading) -> dict[str, Any]:
    """``value`` as printed (``10.00 s``, ``1 [READY]``) and ``input`` (see `_input`)."""
    return {
        "value": format_value(reading.info, reading.value),
        "input": _input(reading),
    }
