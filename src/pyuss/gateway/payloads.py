"""The messages the MQTT face publishes - a drive's state, a parameter as last read, the reply
to a command - and when a drive's state is due, without a broker (the topics they go to and
the commands they answer: `pyuss.gateway.topics`; each carries `CONTRACT_VERSION`).

States, parameters and results carry values rounded to their resolution (`state_dict`,
`reading_dict`); a state holds every configured process value, its numbers null until the
drive answered. `StateThrottle` says when a state is due (``max_rate``, ``deadband``).
`StatePayloads` builds a drive's state messages, byte for byte `state_payload`, from the
parts of the state that changed: the MQTT face's hot path.

Replies: ``{"v", "id", "command", "drive", "ok": true, "result": {...}}`` or ``{"ok": false,
"error": {"type", "message", "class", "number", "meaning"}}`` (`pyuss.points.errors`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

from pyuss.gateway.topics import CONTRACT_VERSION, Command
from pyuss.points.parameters import ParamMeta
from pyuss.points.state import (
    COUNTER_FIELDS,
    DriveState,
    Health,
    ParamValue,
    decimals,
    iso,
    process_decimals,
)
from pyuss.profiles import UNKNOWN_KIND

__all__ = [
    "StatePayloads",
    "StateThrottle",
    "param_payload",
    "param_places",
    "param_value",
    "reading_dict",
    "reply_payload",
    "state_dict",
    "state_payload",
]


def param_places(meta: ParamMeta) -> int | None:
    """The decimals of a parameter's resolution: those of its scaling, those its parameter
    file gives a float (`decimals`), 0 for an integer; None: a float whose file names none,
    shown to the 7 significant digits of a 32-bit float."""
    if meta.scaling is not None and not meta.is_float:
        return decimals(abs(meta.scaling))
    if meta.is_float:
        return meta.decimals or None
    return 0


def param_value(meta: ParamMeta, value: int | float | None) -> int | float | None:
    """A parameter's value rounded to its resolution (`param_places`); integers as they
    are."""
    if not isinstance(value, float) or not math.isfinite(value):
        return value
    places = param_places(meta)
    return float(f"{value:.7g}") if places is None else round(value, places)


def reading_dict(reading: ParamValue) -> dict[str, Any]:
    """`ParamValue.to_dict` with the value rounded to its resolution (`param_value`)."""
    item = reading.to_dict()
    item["value"] = param_value(reading.meta, reading.value)
    return item


def state_dict(state: DriveState) -> dict[str, Any]:
    """`DriveState.to_dict` with the process values and parameters rounded to their
    resolution (`process_decimals`, `param_value`): a 20 Hz setpoint of a 50 Hz reference
    is 20.0, not the 20.001221 its raw word 199Ah stands for."""
    data = state.to_dict()
    data["actual"] = _process_dict(state, "actual")
    data["setpoint"] = _process_dict(state, "setpoint")
    data["parameters"] = _parameters_dict(state)
    return data


def _process_dict(state: DriveState, group: str) -> dict[str, Any]:
    """The ``actual`` or ``setpoint`` part of `state_dict`: every configured process value,
    with ``value``, ``percent`` and ``raw`` null while it is not known (no answer yet)."""
    model = state.model
    values, items = (
        (state.actual, model.actual) if group == "actual" else (state.setpoints, model.setpoints)
    )
    data: dict[str, Any] = {}
    for item in items:
        value = values.get(item.key)
        if value is None:
            data[item.key] = {
                "value": None,
                "unit": model.unit,
                "percent": None,
                "raw": None,
                "pzd": item.pzd,
            }
            continue
        entry = value.to_dict()
        places, percent_places = process_decimals(item.dword, model.unit, state.reference)
        if entry["value"] is not None:
            entry["value"] = round(entry["value"], places)
        entry["percent"] = round(entry["percent"], percent_places)
        data[item.key] = entry
    return data


def _parameters_dict(state: DriveState) -> dict[str, Any]:
    return {key: reading_dict(reading) for key, reading in state.parameters.items()}


def _dumps(data: object) -> str:
    return json.dumps(data, separators=(",", ":"))


def state_payload(state: DriveState) -> bytes:
    """The state message (schema ``state.json``)."""
    data = {"v": CONTRACT_VERSION, **state_dict(state)}
    return _dumps(data).encode()


class StatePayloads:
    """The state messages of one drive, byte for byte `state_payload`, each built from the
    parts that changed since the last one: a drive that ramps changes its time, its actual
    values and its counters at every answer, and its identity, state, bits, setpoints and
    parameters seldom. Each part's JSON is kept with what it was made from (the process
    values from their raw words and the reference, the parameters by the readings
    themselves) and made again only when that differs."""

    def __init__(self) -> None:
        self._parts: dict[str, tuple[object, str]] = {}
        self._readings: tuple[object, ...] | None = None
        self._parameters = ""

    def _part(self, name: str, key: object, build: Callable[[], str]) -> str:
        last = self._parts.get(name)
        if last is not None and (last[0] is key or last[0] == key):
            return last[1]
        text = build()
        self._parts[name] = (key, text)
        return text

    def payload(self, state: DriveState) -> bytes:
        model = state.model
        reference = (state.reference, type(state.reference), model.unit)
        head = self._part(
            "head",
            model,
            lambda: _dumps(
                {
                    "v": CONTRACT_VERSION,
                    "bus": model.bus,
                    "address": model.address,
                    "name": model.name,
                    "profile": model.profile or UNKNOWN_KIND,
                }
            )[:-1],
        )
        status = self._part(
            "status",
            (state.online, state.status_word, state.control_word, reference),
            lambda: self._status(state),
        )
        actual = self._part(
            "actual",
            (state.actual_words, tuple(state.actual), reference),
            lambda: _dumps(_process_dict(state, "actual")),
        )
        setpoint = self._part(
            "setpoint",
            (state.setpoint_words, tuple(state.setpoints), reference),
            lambda: _dumps(_process_dict(state, "setpoint")),
        )
        # the readings themselves: a reading is kept until the parameter is read again
        readings = (*state.parameters, *state.parameters.values())
        if (
            self._readings is None
            or len(readings) != len(self._readings)
            or (readings and any(a is not b for a, b in zip(readings, self._readings, strict=True)))
        ):
            self._readings = readings
            self._parameters = _dumps(_parameters_dict(state))
        return (
            f'{head},"time":"{iso(state.time)}",{status},"actual":{actual},'
            f'"setpoint":{setpoint},"parameters":{self._parameters},'
            f'"health":{self._health(state.health)}}}'
        ).encode()

    def _health(self, health: Health) -> str:
        """``Health.to_dict`` as JSON: the counters (whole numbers, as ``to_dict`` makes
        them) into a template, the fault and refusal as they last were."""
        faults = self._part(
            "faults",
            (health.last_fault, health.last_fault_time, health.last_refusal),
            lambda: _dumps(
                {
                    "last_fault": health.last_fault,
                    "last_fault_time": iso(health.last_fault_time),
                    "last_refusal": health.last_refusal,
                }
            )[1:-1],
        )
        counters = health.counters
        return _HEALTH % (
            "true" if health.not_sending else "false",
            health.exchanges,
            health.answers,
            health.timeouts,
            *[int(getattr(counters, name)) for name in COUNTER_FIELDS],
            faults,
        )

    @staticmethod
    def _status(state: DriveState) -> str:
        data = state.to_dict()
        part = {key: data[key] for key in _STATUS_KEYS}
        return _dumps(part)[1:-1]


_HEALTH = (
    '{"not_sending":%s,"exchanges":%d,"answers":%d,"timeouts":%d,"counters":{'
    + ",".join(f'"{name}":%d' for name in COUNTER_FIELDS)
    + "},%s}"
)
_STATUS_KEYS = (
    "online",
    "status_word",
    "status_hex",
    "status_text",
    "state",
    "bits",
    "control_word",
    "control_text",
    "reference",
)


class StateThrottle:
    """When a drive's new state is to be published (`offer`): at once if anything but its
    actual values changed since the last one published (a status bit, a fault, what was
    sent, a parameter, its availability: `DriveState.events`); if only actual values
    changed, once one of them moved ``deadband`` percent of the reference or more from the
    value last published, and not sooner than ``interval`` seconds after the last state
    published - the newest one then, so that the last state of a ramp is always published.
    ``interval`` 0: no wait; ``deadband`` 0: every change counts."""

    def __init__(self, interval: float = 0.0, deadband: float = 0.0) -> None:
        self.interval = interval
        self.deadband = deadband
        self._last: DriveState | None = None
        self._events: tuple[object, ...] = ()
        self._time = 0.0

    def offer(self, state: DriveState, now: float) -> float | None:
        """Seconds to wait before ``state`` is published (0: now); None: not to be published
        (its actual values are within the deadband of those published, nothing else
        changed): a state held back earlier is dropped then too, being no newer than the
        one published."""
        last = self._last
        if last is None or state.events() != self._events:
            return 0.0
        if not self._moved(state, last):
            return None
        return max(0.0, self._time + self.interval - now)

    def sent(self, state: DriveState, now: float) -> None:
        """``state`` was published at ``now``."""
        self._last = state
        self._events = state.events()
        self._time = now

    def _moved(self, state: DriveState, last: DriveState) -> bool:
        if state.actual.keys() != last.actual.keys():
            return True
        band = self.deadband
        for key, value in state.actual.items():
            before = last.actual[key].percent
            if value.percent != before and abs(value.percent - before) >= band:
                return True
        return False


def param_payload(reading: ParamValue) -> bytes:
    """The message of a parameter as last read (schema ``param.json``)."""
    data = {"v": CONTRACT_VERSION, **reading_dict(reading)}
    return json.dumps(data, separators=(",", ":")).encode()


def reply_payload(
    command: Command,
    *,
    result: dict[str, Any] | None = None,
    error: dict[str, Any] | None = None,
    duplicate: bool = False,
) -> dict[str, Any]:
    """The reply to ``command`` (schema ``reply.json``)."""
    reply: dict[str, Any] = {
        "v": CONTRACT_VERSION,
        "id": command.id,
        "command": command.name,
        "drive": command.drive,
        "ok": error is None,
    }
    if error is None:
        reply["result"] = result or {}
    else:
        reply["error"] = error
    if duplicate:
        reply["duplicate"] = True
    return reply
