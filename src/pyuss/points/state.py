"""A drive's points at one moment: `DriveState`, the snapshot every face shows.

A state is immutable; the runtime (`pyuss.points.plant`) makes a new one whenever something
changes: an answer with other process data, a parameter read, "does not send" set or
cleared, a fault number read, a job refused. ``to_dict()`` is the JSON form (the MQTT state
topic, the web page), values with their units and times in ISO 8601 (UTC).
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from typing import Any

from pyuss.master.process import state_of
from pyuss.points.model import STATUS_BIT_NAMES, DriveModel
from pyuss.points.parameters import ParamMeta
from pyuss.profiles import UNKNOWN_KIND
from pyuss.protocol.diagnostics import Counters
from pyuss.protocol.pzd import (
    SWITCHES_ON,
    StatusWord,
    join_dword,
    raw16_to_percent,
    raw32_to_percent,
)

__all__ = [
    "COUNTER_FIELDS",
    "STATE_CODES",
    "DriveState",
    "Health",
    "ParamValue",
    "ProcessValue",
    "Sample",
    "iso",
    "process_value",
    "signed",
    "state_name",
]

STATE_CODES: dict[str, int] = {
    "no answer": 0,
    "not ready to switch on": 1,
    "switch-on inhibited": 2,
    "ready to switch on": 3,
    "ready": 4,
    "operation enabled": 5,
    "fault": 6,
    "OFF2 (coasting)": 7,
    "OFF3 (quick stop)": 8,
}
"""The drive state as a number, for faces that carry numbers only (Modbus)."""

COUNTER_FIELDS = tuple(Counters.__dataclass_fields__)
"""The names of the diagnostic counters, in the order of the JSON form."""


def state_name(word: int | None) -> str:
    """The drive state a status word spells (C Tables 5.5, 5.6); ``no answer`` for None."""
    return "no answer" if word is None else state_of(word)


def iso(when: datetime.datetime | None) -> str | None:
    return None if when is None else when.isoformat(timespec="milliseconds").replace("+00:00", "Z")


def now() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC)


@dataclass(frozen=True, slots=True)
class ProcessValue:
    """One actual value or setpoint: the raw word(s), percent, and the value in ``unit``."""

    key: str
    pzd: int
    raw: int
    """Signed: 16 bits, or 32 bits for a double word."""
    percent: float
    value: float | None
    """In ``unit``; None while the reference is not known."""
    unit: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "value": self.value,
            "unit": self.unit,
            "percent": self.percent,
            "raw": self.raw,
            "pzd": self.pzd,
        }


@dataclass(frozen=True, slots=True)
class Sample:
    """The process data of one answer, for a trend: wall-clock time (Unix seconds), the
    status word and every actual value in its unit (`DrivePoints.actual_row`)."""

    time: float
    status: int
    values: tuple[float, ...]


def signed(word: int, bits: int = 16) -> int:
    """A PZD word (or a joined double word) as the signed number it carries."""
    return word - (1 << bits) if word >> (bits - 1) & 1 else word


def process_value(
    key: str, pzd: int, dword: bool, words: tuple[int, ...], reference: float | None, unit: str
) -> ProcessValue | None:
    """``words`` are PZD2... (setpoints or actual values); the one scaling of process data:
    4000h = 100 % (4000 0000h for a double word, high word first, C 5.2.2), and the value in
    ``unit`` where the reference is known (percent is its own unit)."""
    at = pzd - 2
    if len(words) < at + (2 if dword else 1):
        return None
    if dword:
        word = join_dword(words[at], words[at + 1])
        raw, percent = signed(word, 32), raw32_to_percent(word)
    else:
        raw, percent = signed(words[at]), raw16_to_percent(words[at])
    return _process(key, pzd, raw, percent, reference, unit)


def _process(
    key: str, pzd: int, raw: int, percent: float, reference: float | None, unit: str
) -> ProcessValue:
    value = percent * reference / 100.0 if reference is not None else None
    if reference is None and unit == "%":
        value = percent
    return ProcessValue(key, pzd, raw, round(percent, 6), _round(value), unit)


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 6)


@dataclass(frozen=True, slots=True)
class ParamValue:
    """A parameter as last read (or written): the value in its unit, when, or the error."""

    meta: ParamMeta
    value: int | float | None = None
    time: datetime.datetime | None = None
    error: dict[str, Any] | None = None
    written: int | float | None = None
    """For the answer to a write the drive answered with another value (it limits or
    rounds): the value written; ``value`` is what the drive holds."""

    @property
    def text(self) -> str | None:
        """The value text of an enumerated parameter (C Table 4.5), if it has one."""
        if isinstance(self.value, int):
            return self.meta.texts.get(self.value)
        return None

    def to_dict(self) -> dict[str, Any]:
        item: dict[str, Any] = {
            "pnu": self.meta.pnu,
            "index": self.meta.index,
            "name": self.meta.name,
            "value": self.value,
            "unit": self.meta.unit,
            "time": iso(self.time),
        }
        if self.text is not None:
            item["text"] = self.text
        if self.error is not None:
            item["error"] = self.error
        if self.written is not None:
            item["written"] = self.written
        return item


@dataclass(frozen=True, slots=True)
class Health:
    not_sending: bool = False
    """ "Slave x does not send" (A 5.2.1.1)."""
    counters: Counters = field(default_factory=Counters)
    """The 16 diagnostic parameters of A 5.2.3 for the drive's answers."""
    exchanges: int = 0
    answers: int = 0
    timeouts: int = 0
    last_fault: int | None = None
    """The drive's fault number, read when the fault bit rose (None: none seen, or the
    profile names no fault parameter)."""
    last_fault_time: datetime.datetime | None = None
    last_refusal: dict[str, Any] | None = None
    """The last job the drive refused, as `pyuss.points.errors.error_dict`."""

    def to_dict(self) -> dict[str, Any]:
        counters = {}
        for name in COUNTER_FIELDS:
            value = getattr(self.counters, name)
            counters[name] = value if isinstance(value, int) else int(value)
        return {
            "not_sending": self.not_sending,
            "exchanges": self.exchanges,
            "answers": self.answers,
            "timeouts": self.timeouts,
            "counters": counters,
            "last_fault": self.last_fault,
            "last_fault_time": iso(self.last_fault_time),
            "last_refusal": self.last_refusal,
        }


@dataclass(frozen=True, slots=True)
class DriveState:
    """A drive's points at one moment (see the module docstring)."""

    model: DriveModel
    time: datetime.datetime
    status_word: int | None
    """None until the drive's first answer."""
    control_word: int
    actual: dict[str, ProcessValue]
    setpoints: dict[str, ProcessValue]
    parameters: dict[str, ParamValue]
    health: Health
    reference: float | None
    """The physical value of 100 % in ``model.unit`` (None: not known yet, or percent)."""
    actual_words: tuple[int, ...] = ()
    setpoint_words: tuple[int, ...] = ()

    @property
    def answered(self) -> bool:
        return self.status_word is not None

    @property
    def online(self) -> bool:
        """The drive answers: it answered once and is not marked "does not send"."""
        return self.answered and not self.health.not_sending

    @property
    def state(self) -> str:
        return state_name(self.status_word)

    @property
    def state_code(self) -> int:
        return STATE_CODES.get(self.state, 0)

    @property
    def bits(self) -> dict[str, bool]:
        word = self.status_word or 0
        return {name: bool(word >> bit & 1) for bit, name in STATUS_BIT_NAMES.items()}

    @property
    def fault(self) -> bool:
        return bool((self.status_word or 0) & StatusWord.FAULT)

    @property
    def warning(self) -> bool:
        return bool((self.status_word or 0) & StatusWord.WARNING)

    @property
    def running(self) -> bool:
        return bool((self.status_word or 0) & StatusWord.OPERATION_ENABLED)

    @property
    def told_to_run(self) -> bool:
        """The control word sent tells the drive to run (ON, or a jog bit), or the drive,
        answering, says it runs (operation enabled)."""
        return bool(self.control_word & SWITCHES_ON) or (self.online and self.running)

    def signature(self) -> tuple[object, ...]:
        """What a subscriber is told about when it changes (not the running counters)."""
        return (
            self.status_word,
            self.control_word,
            self.actual_words,
            self.setpoint_words,
            tuple((k, v.value, v.error is None) for k, v in self.parameters.items()),
            self.health.not_sending,
            self.health.last_fault,
            self.health.last_fault_time,
            None if self.health.last_refusal is None else id(self.health.last_refusal),
            int(self.health.counters.error_status),
            self.reference,
        )

    def to_dict(self) -> dict[str, Any]:
        model = self.model
        return {
            "bus": model.bus,
            "address": model.address,
            "name": model.name,
            "profile": model.profile or UNKNOWN_KIND,
            "time": iso(self.time),
            "online": self.online,
            "status_word": self.status_word,
            "status_hex": None if self.status_word is None else f"{self.status_word:04X}",
            "state": self.state,
            "bits": self.bits,
            "control_word": self.control_word,
            "reference": {"value": self.reference, "unit": model.unit},
            "actual": {k: v.to_dict() for k, v in self.actual.items()},
            "setpoint": {k: v.to_dict() for k, v in self.setpoints.items()},
            "parameters": {k: v.to_dict() for k, v in self.parameters.items()},
            "health": self.health.to_dict(),
        }
