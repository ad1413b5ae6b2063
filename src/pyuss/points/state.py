"""A drive's points at one moment: `DriveState`, the snapshot every face shows; a bus's:
`BusState`.

A state is immutable; the runtime (`pyuss.points.drive`) makes a new one whenever something
changes: an answer with other process data, a parameter read, "does not send" set or
cleared, an answer missed, the drive or its bus offline or back, a fault number read, a job
refused. ``to_dict()`` is the JSON form (the MQTT state topic, the web page), values with
their units and times in ISO 8601 (UTC).

Availability (docs/gateway.md, "Availability"): a drive is `DriveState.online` while its
bus is online (a master exchanges on the line) and it answers by its bus's
`pyuss.points.model.OfflineRule`; while it is online but its latest answers were missed its
values are `DriveState.stale`: the last answer's, kept through a short gap.
"""

from __future__ import annotations

import datetime
import functools
import math
from dataclasses import dataclass, field
from typing import Any

from pyuss.master.process import state_of
from pyuss.params.words import WordKind, format_word
from pyuss.points.model import STATUS_BIT_NAMES, DriveModel
from pyuss.points.parameters import ParamMeta
from pyuss.profiles import UNKNOWN_KIND, get_profile
from pyuss.protocol.diagnostics import Counters
from pyuss.protocol.frozen import builder
from pyuss.protocol.pzd import (
    FULL_SCALE_16,
    FULL_SCALE_32,
    SWITCHES_ON,
    StatusWord,
    join_dword,
    raw16_to_percent,
    raw32_to_percent,
)

__all__ = [
    "COUNTER_FIELDS",
    "STATE_CODES",
    "BusState",
    "DriveState",
    "Health",
    "ParamValue",
    "ProcessValue",
    "Sample",
    "SetpointSpan",
    "decimals",
    "iso",
    "process_decimals",
    "process_value",
    "setpoint_span",
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


_process_value = builder(ProcessValue)
"""`ProcessValue` of values `process_value` made (two for every answer of a drive)."""


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
        # `signed` and `raw16_to_percent` inline (made for every answer): a 16-bit word as
        # the class `int` gives it; anything else goes through the checking call.
        word = words[at]
        if word.__class__ is int and 0 <= word <= 0xFFFF:
            raw = word - 0x10000 if word >> 15 & 1 else word
            percent = raw * 100 / FULL_SCALE_16
        else:
            raw, percent = signed(word), raw16_to_percent(word)
    if reference is not None:
        value = round(percent * reference / 100.0, 6)
    elif unit == "%":
        value = round(percent, 6)
    else:
        value = None
    return _process_value(key, pzd, raw, round(percent, 6), value, unit)


@functools.lru_cache(maxsize=1024)
def _word_text(word: int, kind: WordKind, profile: str | None) -> str:
    """`format_word` by the built-in profile's name: the line of a status or control word,
    made once for each word a drive shows (a state's texts are asked at every change of it)."""
    return format_word(word, kind, None if profile is None else get_profile(profile))


@functools.lru_cache(maxsize=256)
def decimals(step: float) -> int:
    """The decimals a value that moves in steps of ``step`` is shown with: the first decimal
    place at or above the step (steps of 0.003 Hz: 2)."""
    if not math.isfinite(step) or step <= 0:
        return 6
    return max(0, math.floor(-math.log10(step) + 1e-9))


def process_decimals(dword: bool, unit: str, reference: float | None) -> tuple[int, int]:
    """(decimals of the value in its unit, decimals of the percent) of a process value: one
    raw step is 100 % / 4000h (16 bits) or / 4000 0000h (32 bits) of the reference."""
    step = 100.0 / (FULL_SCALE_32 if dword else FULL_SCALE_16)
    value_step = step if reference is None or unit == "%" else step * abs(reference) / 100.0
    return decimals(value_step), decimals(step)


@dataclass(frozen=True, slots=True)
class SetpointSpan:
    """The setpoints a process word takes, as a person enters them: from ``low`` to ``high``
    in ``unit`` (``%``: percent of the reference), each taken as it is, with ``places``
    decimals (`setpoint_span`)."""

    low: float
    high: float
    unit: str
    places: int
    bits: int

    def __str__(self) -> str:
        low, high = _places(self.low, self.places), _places(self.high, self.places)
        return f"{low} {self.unit} .. {high} {self.unit}"


def _places(value: float, places: int) -> str:
    """``value`` with at most ``places`` decimals, no trailing zeros (``-200``, ``199.99``)."""
    text = f"{value:.{places}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def setpoint_span(
    reference: float | None, unit: str, *, dword: bool = False, places: int | None = None
) -> SetpointSpan:
    """The one range of a setpoint as a face offers it: in ``unit`` through ``reference``
    (the physical value of 100 %) where it is known and ``unit`` is not ``%``, else in
    percent; from -200 % (8000h, 8000 0000h for a double word: C 5.2.2) to the highest value
    with ``places`` decimals (default: those of one raw step, `process_decimals`) that the
    word still carries. Every value of the span passes `checked_setpoint`, and a refusal
    names this span."""
    bits = 32 if dword else 16
    full = FULL_SCALE_32 if dword else FULL_SCALE_16
    in_unit = reference is not None and reference > 0 and unit != "%"
    scale = reference / 100.0 if in_unit and reference is not None else 1.0
    value_places, percent_places = process_decimals(dword, unit, reference)
    shown = (value_places if in_unit else percent_places) if places is None else places
    factor = 10.0**shown
    low = -(1 << (bits - 1)) * 100.0 / full * scale
    high = ((1 << (bits - 1)) - 1) * 100.0 / full * scale
    # (rounded to 1e-6 of a decimal first: a float's last bit never moves a bound a step)
    return SetpointSpan(
        math.ceil(round(low * factor, 6)) / factor,
        math.floor(round(high * factor, 6)) / factor,
        unit if in_unit else "%",
        shown,
        bits,
    )


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
    bus_online: bool = True
    """A master exchanges on the drive's line (`BusState.online`)."""
    answering: bool = True
    """The drive answers by its bus's `OfflineRule`: it did not miss as many answers in a
    row, nor go as long without one, as makes it offline."""
    missed: int = 0
    """Answers missed in a row since its last one."""

    @property
    def answered(self) -> bool:
        return self.status_word is not None

    @property
    def online(self) -> bool:
        """The drive is available: it answered, it answers (`answering`: one missed answer is
        no outage), and its bus is online."""
        return self.status_word is not None and self.answering and self.bus_online

    @property
    def stale(self) -> bool:
        """Online, but its latest answers were missed: the values are the last answer's."""
        return self.missed > 0 and self.online

    @property
    def state(self) -> str:
        return state_name(self.status_word)

    @property
    def state_code(self) -> int:
        return STATE_CODES.get(self.state, 0)

    @property
    def status_text(self) -> str | None:
        """The status word as a person reads it (`pyuss.params.words`: ``EA40h  switch-on
        inhibited, ...``, bits 11..15 by the drive's family); None before an answer."""
        if self.status_word is None:
            return None
        return _word_text(self.status_word, WordKind.STATUS, self.model.profile)

    @property
    def control_text(self) -> str:
        """The control word sent, as a person reads it (``047Fh  ON, no OFF2, ...``)."""
        return _word_text(self.control_word & 0xFFFF, WordKind.CONTROL, self.model.profile)

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
        """What a subscriber is told about when it changes (not the running counters): the
        actual values and `events`."""
        return (self.actual_words, *self.events())

    def events(self) -> tuple[object, ...]:
        """What a subscriber is told about when it changes, but the actual values: the
        status word, what was sent, parameters, "does not send", faults and refusals - what
        a face that thins out the actual values still tells at once (`signature`)."""
        return (
            self.status_word,
            self.control_word,
            self.setpoint_words,
            tuple((k, v.value, v.error is None) for k, v in self.parameters.items())
            if self.parameters
            else (),
            self.health.not_sending,
            self.bus_online,
            self.answering,
            self.missed > 0,
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
            "status_text": self.status_text,
            "state": self.state,
            "bits": self.bits,
            "control_word": self.control_word,
            "control_text": self.control_text,
            "reference": {"value": self.reference, "unit": model.unit},
            "actual": {k: v.to_dict() for k, v in self.actual.items()},
            "setpoint": {k: v.to_dict() for k, v in self.setpoints.items()},
            "parameters": {k: v.to_dict() for k, v in self.parameters.items()},
            "health": self.health.to_dict(),
        }


@dataclass(frozen=True, slots=True)
class BusState:
    """A bus at one moment: whether a master exchanges telegrams on its line."""

    name: str
    online: bool
    """The bus's master runs and its link is up (offline before the start, while the port
    is lost and being reopened, and once the master stopped)."""
    since: datetime.datetime
    """When ``online`` last changed (wall clock, UTC)."""
    lost: str | None = None
    """Why the line is lost for good: the master stopped, its port failed and is not
    reopened (``reconnect=0`` in the port's URL, or reconnecting gave up)."""
