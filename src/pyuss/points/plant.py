"""The running plant: one `Master` per bus, and per drive its points, live.

Everything that turns a face's wish into process data or a parameter job lives here; nothing
reaches the line that was not checked here first. The rules every face relies on:

- A request is checked whole before anything goes out, and a refused request changes
  nothing: a setpoint (`DrivePoints.check_setpoint`: in percent, in the reference's unit or
  raw, finite, within the word's range, 4000h = 100 % of C 5.2.2), a command (one table,
  `pyuss.points.model.COMMAND_TABLE`), a control word, raw process words, a parameter value
  (its type, limits and access, `write_value` / `write_parameter`) - each raises
  `ConfigError` (or `UnknownPoint`) before the master is told anything.
- Until a command the master sends 0000h, no control by the interface, so a face started
  again stops no running drive. On a drive that is switched on (or has not answered) a
  command that changes bits of the word in force (acknowledge, jog) would take control
  with OFF1 then, and ON with setpoints nobody set here: refused (`NotInControl`).
- Process data whose request failed are taken back (`_taken_back`): the words of before
  are sent again, so a request its client was told failed does not act later.
- A fault or the drive lost ends a jog: the jog bits are dropped (`_end_jog`), so an
  acknowledge or the drive's return does not set the motor turning again. Lost is silent for
  `JOG_GRACE` (0.2 s, far shorter than a power-up): one answer missed on a noisy line does not
  stop a jog.
- A drive gone offline (by its bus's `OfflineRule`, or its line down) is given back
  (`_release`): the control word goes back to 0000h, no control by the interface, as from a
  gateway started again, so the line or the drive coming back resends no command nobody
  gave again (a drive that stopped meanwhile - a power cut, its own telegram monitoring -
  stays stopped; one that ran on runs on as it was). The setpoints stay as set; a command
  takes control again by the takeover rules above.
- Process data become values in one place: `pyuss.points.state.process_value` on the
  `pyuss.protocol.pzd` helpers (a double word joined and split once), the other words of an
  answer through the parameters the profile maps them to (`actual_row`); the status bits and
  the state they spell come from `pyuss.points.state`.
- What goes out goes through the drive handle, so everything queues in the master and
  nothing interleaves on the line.

`Plant` opens one master per bus (`BusPoints`), takes a `Drive` handle per configured drive and
keeps a `DrivePoints` per drive, which

- builds a new `DriveState` from every answer of the drive (the master's ``on_update``
  callback) and tells its subscribers when the state changed - so the faces publish at the
  bus cycle, and not at all while nothing changes; the running counters alone are no change
  (`DriveState.signature`), `DrivePoints.snapshot` gives them fresh. The state is built in
  the loop's next turn, once the master has handed its next telegram over (on a virtual bus
  it does so before yielding): the faces' work is done while that telegram is on the line,
  and does not keep it off (what must not wait - the end of a jog on a fault - is done at
  once);
- watches "does not send" (A 5.2.1.1), which no answer reports, on a short timer, and tells
  when the drive is offline: after its bus's `OfflineRule` (so many answers missed in a row,
  or so long without one; an answer missed short of that makes its values stale), or at
  once when its bus is (`BusPoints`: the master does not exchange, its port lost and being
  reopened, or stopped); the drive is online again with its next answer. Each change of
  availability is one log line (WARNING) naming the drive, one per bus for the bus's;
- reads the reference (the physical value of 100 %) once it can, the fault number when the
  fault bit rises, and the polled parameters when due;
- carries out what the faces ask - commands, control word, setpoints, parameter reads and
  writes - through the drive handle, so everything queues in the master and nothing
  interleaves on the line; a refusal is raised to the caller (`pyuss.errors.DriveRefusal`
  with the drive's error number, `NoWriteAuthority`) and kept as the drive's last refusal.

Subscribers: `DrivePoints.subscribe` / `Plant.subscribe` take a callback (called in the
loop's task that changed the state, or in the turn after an answer: it must not block),
`DrivePoints.updates` is an async iterator that always yields the newest state and skips
what a slow reader missed, so memory stays bounded.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import datetime
import logging
import math
import re
import time
from collections import deque
from collections.abc import AsyncIterator, Callable, Mapping, Sequence
from types import TracebackType
from typing import Any

from pyuss import _callbacks, system
from pyuss.drive.datatypes import Value
from pyuss.errors import ConfigError, DriveRefusal, UssError
from pyuss.master.drive import Drive
from pyuss.master.errors import NoWriteAuthority
from pyuss.master.process import DriveStatus
from pyuss.master.scheduler import Master
from pyuss.params import ParamInfo, ValueRefused, decode, parse
from pyuss.params.model import Reading, param_label
from pyuss.params.values import parse_unknown
from pyuss.points.config import ProcessConfig
from pyuss.points.errors import NotInControl, UnknownPoint, error_dict
from pyuss.points.model import (
    COMMAND_TABLE,
    BusModel,
    Command,
    DriveModel,
    OfflineRule,
    PlantModel,
    line_model,
)
from pyuss.points.parameters import ParameterModel, ParamMeta
from pyuss.points.state import (
    BusState,
    DriveState,
    Health,
    ParamValue,
    ProcessValue,
    Sample,
    now,
    process_value,
    setpoint_span,
    signed,
)
from pyuss.protocol.pzd import (
    SWITCHES_ON,
    ControlWord,
    StatusWord,
    percent_to_raw16,
    percent_to_raw32,
    raw16_to_percent,
    raw32_to_percent,
    split_dword,
)
from pyuss.transport.base import Transport
from pyuss.transport.reconnect import duration_text
from pyuss.transport.url import open_transport

__all__ = ["BusPoints", "DrivePoints", "Plant", "checked_setpoint"]

log = logging.getLogger("pyuss.points")

_FAULT = int(StatusWord.FAULT)
"""The fault bit as a plain int: tested at every answer, where a flag's own `&` costs three
Python calls."""

GIVEN_BACK = "control given back (0000h: it keeps what it had; a command takes control again)"
"""What a log line says of a drive given back (`DrivePoints._release`)."""
DEFAULT_OFFLINE = OfflineRule()
"""The rule of a drive's points made without a bus (`DrivePoints.around`)."""
HEALTH_PERIOD = 0.2
"""How often "does not send" is looked at (seconds)."""
JOG_GRACE = 0.2
"""How long a jog runs on after a missed answer (seconds): one answer lost on a noisy line or
to a busy computer does not stop it, a drive silent longer may have lost its power, and would
jog again on the standing bit once it is back. Far shorter than any drive's power-up; the jog
ends at most `HEALTH_PERIOD` later."""
RETRY_PERIOD = 5.0
"""How long to wait before reading the reference again after a failure (seconds)."""
MAX_TEXT = 64
"""The longest number a face may give as text (a setpoint typed on the page)."""


class _Watch:
    """One `DrivePoints.updates` reader: the newest state, and whether it was taken."""

    def __init__(self) -> None:
        self.state: DriveState | None = None
        self.event = asyncio.Event()

    def put(self, state: DriveState) -> None:
        self.state = state
        self.event.set()


class DrivePoints:
    """The live points of one drive (see the module docstring)."""

    def __init__(
        self,
        model: DriveModel,
        drive: Drive,
        *,
        offline: OfflineRule = DEFAULT_OFFLINE,
        bus_online: bool = True,
    ) -> None:
        self.model = model
        self.drive = drive
        self.offline = offline
        """When the drive is offline (its bus's)."""
        self._bus_online = bus_online
        self._answering = False
        """Whether it answers by `offline` (after its first answer)."""
        self._missed = 0
        self._missed_since = 0.0
        """When the first of the `_missed` answers was missed (the line's clock)."""
        self._heard = system.clock()
        """When it last answered, or its bus came online (the line's clock)."""
        self._told = False
        """Its going offline was logged (its return will be)."""
        self.parameter_model = ParameterModel(model.profile)
        self._reference: float | None = (
            model.reference if isinstance(model.reference, float) else None
        )
        self._params: dict[str, ParamValue] = {p.key: ParamValue(p.meta) for p in model.parameters}
        self._last_fault: int | None = None
        self._last_fault_time: datetime.datetime | None = None
        self._last_refusal: dict[str, object] | None = None
        self._given: set[int] = set()
        """The PZD words (2..16) a face has set since the start."""
        self._serial = 0
        """Counts the changes of process data (`_taken_back`)."""
        self._callbacks: list[Callable[[DriveState], object]] = []
        self._watches: list[_Watch] = []
        self._quick: tuple[object, ...] | None = None
        self._change_due = False
        """A state to build from an answer in the loop's next turn (`_on_update`)."""
        self._fault_task: asyncio.Task[None] | None = None
        self._samples: deque[Sample] | None = None
        self._state = self._build()
        self._signature = self._state.signature()
        self._removers = (drive.on_update(self._on_update), drive.on_missed(self._on_missed))

    def __repr__(self) -> str:
        return f"<DrivePoints {self.model.key} address {self.model.address}>"

    @classmethod
    def around(cls, drive: Drive, *, bus: str = "line") -> DrivePoints:
        """The points of a drive handle of a master run elsewhere (`uss log`): its profile's
        reference (`read_reference`), every word of the answer an actual value
        (`pyuss.points.model.line_model`); the line's settings are the master's."""
        kind = drive.profile.name if drive.profile_named else None
        model = line_model(bus, [(drive.address, kind, drive.layout)])
        return cls(model.drives[0], drive)

    # -- what it is --------------------------------------------------------------------------
    @property
    def key(self) -> str:
        return self.model.key

    @property
    def address(self) -> int:
        return self.model.address

    @property
    def name(self) -> str:
        return self.model.name

    @property
    def state(self) -> DriveState:
        """The state last told to subscribers."""
        return self._state

    def snapshot(self) -> DriveState:
        """The state now, with the running counters as they are."""
        return self._build()

    @property
    def reference(self) -> float | None:
        return self._reference

    # -- building states ---------------------------------------------------------------------
    def _process(
        self, items: tuple[ProcessConfig, ...], words: tuple[int, ...]
    ) -> dict[str, ProcessValue]:
        found: dict[str, ProcessValue] = {}
        for item in items:
            value = process_value(
                item.key, item.pzd, item.dword, words, self._reference, self.model.unit
            )
            if value is not None:
                found[item.key] = value
        return found

    def _build(self) -> DriveState:
        drive = self.drive
        status = drive.status
        diag = drive.counts()
        actual_words = status.actual if status is not None else ()
        setpoint_words = drive.setpoints
        return DriveState(
            model=self.model,
            time=now(),
            status_word=status.word if status is not None else None,
            control_word=drive.control,
            actual=self._process(self.model.actual, actual_words) if status is not None else {},
            setpoints=self._process(self.model.setpoints, setpoint_words),
            parameters=dict(self._params),
            health=Health(
                not_sending=drive.not_sending,
                counters=diag.counters,
                exchanges=diag.exchanges,
                answers=diag.answers,
                timeouts=diag.timeouts,
                last_fault=self._last_fault,
                last_fault_time=self._last_fault_time,
                last_refusal=self._last_refusal,
            ),
            reference=self._reference,
            actual_words=actual_words,
            setpoint_words=setpoint_words,
            bus_online=self._bus_online,
            answering=self._answering,
            missed=self._missed,
        )

    def _changed(self) -> None:
        state = self._build()
        signature = state.signature()
        if signature == self._signature:
            return
        self._state = state
        self._signature = signature
        for callback in list(self._callbacks):
            try:
                callback(state)
            except Exception:
                log.exception("%s: subscriber failed", self.key)
        for watch in self._watches:
            watch.put(state)

    def _on_update(self, status: DriveStatus) -> None:
        if status.word & _FAULT:
            self._end_jog("faulted")
        if self._samples is not None:
            self._samples.append(Sample(time.time(), status.word, self.actual_row(status.actual)))
        back = self._missed or not self._answering
        if back:
            self._answered_again(status.time)
        self._heard = status.time
        quick = (status.word, status.actual, self.drive.control, self.drive.setpoints)
        previous = self._state.status_word
        if quick == self._quick and not back and not self._state.health.not_sending:
            return
        self._quick = quick
        if status.word & _FAULT and not (previous or 0) & _FAULT and self.model.fault is not None:
            self._read_fault_soon()
        if not self._change_due:
            self._change_due = True
            asyncio.get_running_loop().call_soon(self._answer_changed)

    def _answer_changed(self) -> None:
        self._change_due = False
        self._changed()

    def _read_fault_soon(self) -> None:
        if self._fault_task is not None and not self._fault_task.done():
            return
        meta = self.model.fault
        assert meta is not None

        async def read() -> None:
            try:
                value = await self.parameter_model.read(self.drive, meta)
            except UssError as exc:
                log.info("%s: fault number not read: %s", self.key, exc)
                return
            self._last_fault = int(value)
            self._last_fault_time = now()
            self._changed()

        self._fault_task = asyncio.create_task(read(), name=f"{self.key} fault number")

    def check_health(self) -> None:
        """Tell subscribers if "does not send" changed (no answer reports that), and whether
        the drive went so long without an answer that it is offline."""
        self._jog_silent()
        self._judge()
        if self.drive.not_sending != self._state.health.not_sending:
            self._changed()

    # -- availability ------------------------------------------------------------------------
    def _on_missed(self, missed: int) -> None:
        """The master's telegram got no usable answer (the ``missed``-th in a row)."""
        if missed == 1 or not self._missed:
            self._missed_since = system.clock()
        self._missed = missed
        self._jog_silent()
        if not self._judge() and missed == 1 and self._answering:
            self._changed()  # its values are stale now

    def _judge(self) -> bool:
        """Whether the drive is offline now by `offline` (while its bus is online); True if it
        went offline with this look (subscribers told, the drive given back, one log line)."""
        if not self._bus_online:
            return False
        rule = self.offline
        if self._missed >= rule.missed:
            why = f"{self._missed} answers missed in a row"
        else:
            silent = system.clock() - self._heard
            if silent < rule.silence:
                return False
            why = f"no answer for {duration_text(silent)}"
        went = self._answering
        self._answering = False
        released = went and self._release()
        if not self._told:
            self._told = True
            given = "; " + GIVEN_BACK if released else ""
            log.warning("%s offline: %s%s", self.key, why, given)
        if went:
            self._changed()
        return went

    def _answered_again(self, when: float) -> None:
        """An answer: the drive is online (again), its values live."""
        self._missed = 0
        if not self._answering:
            self._answering = True
            if self._told:
                log.warning(
                    "%s online again after %s without an answer",
                    self.key,
                    duration_text(max(0.0, when - self._heard)),
                )
        self._told = False

    def _bus_changed(self, online: bool) -> bool:
        """Its bus went online or offline (`BusPoints`); True when the drive was given back
        (`_release`)."""
        self._bus_online = online
        self._missed = 0
        released = False
        if online:
            self._heard = system.clock()  # the time without an answer counts from now
        else:
            self._answering = False  # online again with its next answer
            released = self._release()
        self._changed()
        return released

    def _release(self) -> bool:
        """The drive is lost (offline, or its line down): give it back - the control word
        0000h, no control by the interface, as from a gateway started again - so that
        neither the line nor the drive coming back resends a command nobody gave again. A
        drive that stopped meanwhile stays stopped, one that ran on runs on as it was; the
        setpoints stay; a command takes control again by the takeover rules
        (`_check_takeover`). True if it was controlled here."""
        if not self.drive.control:
            return False
        self._serial += 1  # a request under way is not to take it back
        self.drive.set_control(0)
        return True

    def _jog_silent(self) -> None:
        """End a jog once the drive has not answered for `JOG_GRACE` (see `_end_jog`)."""
        if self._missed and system.clock() - self._missed_since >= JOG_GRACE:
            self._end_jog(f"does not send (no answer for {duration_text(JOG_GRACE)} or more)")

    def _end_jog(self, why: str) -> None:
        """A jog runs while its bit is held; a fault or a drive lost (a power cut) ends it:
        the jog bits are dropped from the control word, so that the acknowledge of the fault
        or the drive's return does not set the motor turning again (a family that jogs from
        "ready to switch on" would, with the bit still set)."""
        word = self.drive.control
        jog = int(ControlWord.JOG1 | ControlWord.JOG2)
        if word & jog:
            self._serial += 1  # a request under way is not to take it back
            self.drive.set_control(word & ~jog)
            log.warning("%s: jog ended: the drive %s", self.key, why)
            self._changed()

    # -- subscribers -------------------------------------------------------------------------
    def subscribe(self, callback: Callable[[DriveState], object]) -> Callable[[], None]:
        """Call ``callback`` with every changed state (it must not block: see the module
        docstring); returns a function that removes it."""
        return _callbacks.add(self._callbacks, callback)

    async def updates(self, *, initial: bool = True) -> AsyncIterator[DriveState]:
        """The changed states as they come (the current one first with ``initial``); a slow
        reader gets the newest and misses the ones in between."""
        watch = _Watch()
        if initial:
            watch.put(self._state)
        self._watches.append(watch)
        try:
            while True:
                await watch.event.wait()
                watch.event.clear()
                state = watch.state
                assert state is not None
                yield state
        finally:
            self._watches.remove(watch)

    # -- what faces ask ----------------------------------------------------------------------
    def _refused(self, exc: BaseException) -> None:
        if isinstance(exc, DriveRefusal | NoWriteAuthority):
            self._last_refusal = error_dict(exc)
            self._changed()

    async def command(self, name: str, *, timeout: float | None = None) -> DriveState:
        """One of `pyuss.points.model.COMMAND_TABLE`: ``on``, ``off1``, ``off2``, ``off3``,
        ``acknowledge``, ``jog1``, ``jog2``, ``jog_off``. Returns once a telegram carrying it
        was answered."""
        command = _command(name)
        self._check_takeover(command)
        async with self._taken_back():
            await getattr(self.drive, command.method)(*command.args, timeout=timeout)
        self._changed()
        return self._state

    @contextlib.asynccontextmanager
    async def _taken_back(self) -> AsyncIterator[None]:
        """Process data that did not get through are taken back: when the request fails (the
        master not started, closed or failed, the drive not answering, the request cut off)
        the control word and setpoints are set back to those of before, unless a later
        request changed them meanwhile - so a request its client was told failed does not
        act later, when the master starts or the drive answers again."""
        self._serial += 1
        serial = self._serial
        control, setpoints, given = self.drive.control, self.drive.setpoints, set(self._given)
        try:
            yield
        except BaseException:
            if serial == self._serial:
                self.drive.set_control(control)
                for number, word in enumerate(setpoints, start=2):
                    self.drive.set_pzd(number, word)
                self._given = given
                self._changed()
            raise

    def check_takeover(
        self, *, command: str | None = None, control: int | None = None, words: Sequence[int] = ()
    ) -> None:
        """The takeover check of `command` and `set_process` for a request a face carries out
        in parts (a Modbus write: process data, then the command), made before any part is
        sent: the control word ``control`` and the PZD words ``words`` it sets, then
        ``command`` on the word that leaves in force. `NotInControl` if a part would be
        refused; nothing is sent or changed."""
        given = set(words)
        if control is not None:
            self._check_word(control, given)
            if control & ControlWord.CONTROL_BY_PLC:
                return  # the command then changes the word this request put in force
        if command is not None:
            self._check_takeover(_command(command), given)

    def _check_word(self, word: int, words: set[int]) -> None:
        """`_check_takeover` for a control word a face sends itself (with the PZD words
        ``words`` of the same request): one with control by the interface (bit 10) and ON
        or a jog bit is an ON."""
        if word & ControlWord.CONTROL_BY_PLC:
            moves = bool(word & SWITCHES_ON)
            command = Command(f"control word {word:04X}h", "control_word", moves=moves)
            self._check_takeover(command, words)

    def _check_takeover(self, command: Command, given: set[int] | None = None) -> None:
        """Refuse a command that would take over a drive switched on by a master before
        this one (a gateway or page started again) with what nobody asked for: while this
        master has sent no control word (0000h) the drive runs on the process data it had,
        and a command takes control with the setpoints of this master. Acknowledge and jog
        change bits of the word in force and start from 047Eh, OFF1: they would stop it. ON
        would set it to setpoints nobody set here (0 after a start): refused until every
        setpoint of the drive was set here. OFF1/2/3 stop it, as asked."""
        if self.drive.control & ControlWord.CONTROL_BY_PLC:
            return
        unset = self._unset_setpoints(given or set())
        if command.whole and not (command.moves and unset):
            return
        why = self.drive.running_elsewhere()
        if why is None:
            return
        if command.whole:
            would = f"with setpoint {', '.join(unset)} 0, which nobody set here"
            advice = "set the setpoint first (on sends it), or send off1"
        else:
            would = "with OFF1 (047Eh)"
            advice = "set the setpoint and send on, or send off1 first"
        raise NotInControl(
            f"{self.key}: {command.name} refused: the drive {why}, and this master has sent "
            "it no control word yet (0000h: no control by the interface, the drive keeps "
            f"the process data it had), so {command.name} would take control {would}; "
            f"{advice}"
        )

    def _unset_setpoints(self, given: set[int]) -> list[str]:
        """The setpoints of the drive whose words no face has set since the start (nor
        sets now: the PZD numbers ``given``)."""
        return [
            item.key
            for item in self.model.setpoints
            if not {item.pzd, item.pzd + item.dword} <= self._given | given
        ]

    async def set_control_word(self, word: int) -> DriveState:
        if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
            raise ConfigError(f"control word must be 0..65535 (0..FFFFh), not {word!r}")
        self._check_word(word, set())
        async with self._taken_back():
            await self.drive.control_word(word)
        self._changed()
        return self._state

    async def set_process(
        self, *, control: int | None = None, words: Mapping[int, int] | None = None
    ) -> DriveState:
        """Set the control word and raw PZD words (``{number: word}``, 2..16, 0..FFFFh)
        together, all checked before any is set (a refused request changes no word); returns
        once a telegram carrying all of them was answered."""
        if control is not None and (
            isinstance(control, bool) or not isinstance(control, int) or not 0 <= control <= 0xFFFF
        ):
            raise ConfigError(f"control word must be 0..65535 (0..FFFFh), not {control!r}")
        words = dict(words or {})
        for number, value in words.items():  # all checked before any is set
            if isinstance(number, bool) or not isinstance(number, int):
                raise ConfigError(f"PZD number must be a whole number, not {_shown(number)}")
            if not 2 <= number <= self.model.layout.pzd:
                raise UnknownPoint(f"{self.key}: PZD{number} is not in layout {self.model.layout}")
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF:
                raise ConfigError(f"PZD{number} must be a 16-bit value, not {_shown(value)}")
        if control is not None:
            self._check_word(control, set(words))
        async with self._taken_back():
            for number, value in words.items():
                self.drive.set_pzd(number, value)
                self._given.add(number)
            await self.drive.control_word(self.drive.control if control is None else control)
        self._changed()
        return self._state

    def setpoint_point(self, key: str = "main") -> tuple[int, bool]:
        for item in self.model.setpoints:
            if item.key == key:
                return item.pzd, item.dword
        raise UnknownPoint(f"{self.key}: no setpoint {_shown(key)}")

    def setpoint_units(self) -> tuple[str, ...]:
        """The units a setpoint may be given in: ``%`` and, where the reference is known,
        its unit (``raw`` besides, for the word itself)."""
        unit = self.model.unit
        return ("%",) if unit == "%" or self._reference is None else ("%", unit)

    def check_setpoint(
        self, value: object, key: str = "main", *, unit: str = "value"
    ) -> ProcessValue:
        """The setpoint ``value`` checked whole, as it would be sent: ``unit`` is ``value``
        (the point's unit; percent when no reference is known), ``percent`` (or ``%``), the
        reference's unit by name (``Hz``) or ``raw``; a number, or a number as text. The
        word's range bounds it (16 bits: -200 % .. +199.99 %, C 5.2.2); `ConfigError` names
        what is wrong. Nothing is sent."""
        pzd, dword = self.setpoint_point(key)
        return checked_setpoint(
            value,
            self._unit_kind(unit),
            reference=self._reference,
            unit=self.model.unit,
            key=key,
            pzd=pzd,
            dword=dword,
            where=self.key,
        )

    def _unit_kind(self, unit: object) -> str:
        if unit in ("value", "raw"):
            return str(unit)
        if unit in ("percent", "%"):
            return "percent"
        if isinstance(unit, str) and unit == self.model.unit and unit:
            return "value"
        takes = " or ".join(repr(u) for u in (*self.setpoint_units(), "raw"))
        raise ConfigError(f"setpoint unit {_shown(unit)}: {self.key} takes {takes}")

    def setpoint_raw(self, value: float, key: str = "main", *, unit: str = "value") -> int:
        """The signed raw value of `check_setpoint` (the word, or the double word)."""
        return self.check_setpoint(value, key, unit=unit).raw

    async def set_setpoint(
        self,
        value: object,
        key: str = "main",
        *,
        unit: str = "value",
        timeout: float | None = None,
    ) -> DriveState:
        """Set a setpoint (checked by `check_setpoint` first); returns once a telegram
        carrying it was answered."""
        checked = self.check_setpoint(value, key, unit=unit)
        _, dword = self.setpoint_point(key)
        async with self._taken_back():
            self._given.update((checked.pzd, checked.pzd + dword))
            await self.drive.setpoint(
                raw=checked.raw, pzd=checked.pzd, dword=dword, timeout=timeout
            )
        self._changed()
        return self._state

    # -- process data as values --------------------------------------------------------------
    def keep_samples(self, size: int) -> None:
        """Keep the process data of the latest ``size`` answers (`take_samples`)."""
        self._samples = deque(maxlen=size)

    def take_samples(self) -> list[Sample]:
        """The samples kept since the last call (oldest first), see `keep_samples`."""
        if not self._samples:
            return []
        taken = list(self._samples)
        self._samples.clear()
        return taken

    def process_parameter(self, number: int) -> ParamInfo | None:
        """The parameter the profile maps to actual value PZD``number`` (3 and up; None for a
        drive of unknown kind)."""
        if not self.drive.profile_named:
            return None
        pnus = self.drive.profile.database().process_actuals
        pnu = pnus[number - 3] if 0 <= number - 3 < len(pnus) else 0
        return self.drive.params.get(pnu) if pnu else None

    def actual_columns(self) -> list[dict[str, Any]]:
        """Name and unit of every actual value of `actual_row`: PZD2 the main one (in the
        reference's unit or %), PZD3... as the profile's parameters for them."""
        columns: list[dict[str, Any]] = []
        for number in range(2, self.model.layout.pzd + 1):
            if number == 2:
                unit = self.model.unit if self._reference is not None else "%"
                columns.append({"pzd": 2, "name": "Main actual value", "unit": unit})
                continue
            info = self.process_parameter(number)
            if info is not None:
                columns.append({"pzd": number, "name": info.name, "unit": info.unit})
            else:
                columns.append({"pzd": number, "name": f"PZD{number}", "unit": ""})
        return columns

    def actual_items(self, words: Sequence[int]) -> list[tuple[Value, ParamInfo | None]]:
        """The actual values of an answer's PZD2... as values, each with the parameter that
        types it: PZD2 in the reference's unit (or %, no parameter), PZD3... decoded by the
        parameters the profile maps them to (the word as it came, without a parameter, where
        none is known or it does not decode)."""
        out: list[tuple[Value, ParamInfo | None]] = []
        for number, word in enumerate(words, start=2):
            if number == 2:
                main = process_value(
                    "main", 2, False, tuple(words), self._reference, self.model.unit
                )
                assert main is not None
                out.append((main.percent if main.value is None else main.value, None))
                continue
            info = self.process_parameter(number)
            value: Value = word
            typed: ParamInfo | None = None
            if info is not None and info.words == 1:
                with contextlib.suppress(UssError):
                    value, typed = decode(info, (word,)), info
            out.append((value, typed))
        return out

    def actual_row(self, words: Sequence[int]) -> tuple[float, ...]:
        """The actual values of an answer's PZD2... as numbers, in the units
        `actual_columns` names (`actual_items`)."""
        return tuple(
            float(value) if isinstance(value, int | float) else float(word)
            for (value, _), word in zip(self.actual_items(words), words, strict=True)
        )

    def setpoint_value(self) -> float | None:
        """The main setpoint as sent (PZD2), in the unit of the main actual value."""
        main = process_value("main", 2, False, self.drive.setpoints, self._reference, "")
        if main is None:
            return None
        return main.percent if main.value is None else main.value

    def meta(self, pnu: int, index: int | None = None) -> ParamMeta:
        """What is known of P``pnu`` (the configured point's, else the parameter model's)."""
        key = f"P{pnu}" if index is None else f"P{pnu}.{index}"
        point = self.model.parameter(key)
        if point is not None:
            return point.meta
        return self.parameter_model.meta(pnu, index)

    async def read_parameter(self, pnu: int, index: int | None = None) -> ParamValue:
        """Read P``pnu`` (element ``index``) now, any parameter; a configured one's value is
        kept and published."""
        meta = self.meta(pnu, index)
        try:
            value = await self.parameter_model.read(self.drive, meta)
        except (DriveRefusal, NoWriteAuthority) as exc:
            self._refused(exc)
            raise
        reading = ParamValue(meta, value, now())
        if meta.key in self._params:
            self._params[meta.key] = reading
            self._changed()
        return reading

    async def write_parameter(
        self, pnu: int, value: float, index: int | None = None, *, eeprom: bool = False
    ) -> ParamValue:
        """Write ``value`` (in the parameter's unit) as a parameter job; returns what the
        drive answered, with ``written`` where it answered another value (it limits or
        rounds)."""
        meta = self.meta(pnu, index)
        try:
            answered, differs = await self.parameter_model.write(
                self.drive, meta, value, eeprom=eeprom
            )
        except (DriveRefusal, NoWriteAuthority) as exc:
            self._refused(exc)
            raise
        reading = ParamValue(meta, answered, now())
        if meta.key in self._params:
            self._params[meta.key] = reading
            self._changed()
        if self.is_reference(pnu, index):
            self._take_reference(answered)
        if differs:
            return dataclasses.replace(reading, written=value)
        return reading

    async def read_value(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> Reading:
        """Read any parameter, typed by the drive's parameter book (`pyuss.params`): numbers,
        texts, value texts, array elements - what the page's expert list shows."""
        try:
            return await self.drive.read_param(pnu, index, timeout=timeout)
        except (DriveRefusal, NoWriteAuthority) as exc:
            self._refused(exc)
            raise

    async def write_value(
        self,
        pnu: int,
        index: int | None,
        text: str,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
    ) -> Reading:
        """Write a value as a person types it (``2.5``, ``2.5 s``, ``0x7000``, a value text):
        parsed and checked against the parameter's type, limits and access before anything
        is sent (`pyuss.params.parse`; refusals as `ValueRefused`); the drive's refusal
        raises `DriveRefusal`. A write of the reference parameter reads the reference anew. On
        a drive of unknown kind a parameter nothing is known of takes what ``uss write`` takes
        then (`pyuss.params.values.parse_unknown`: an integer, sent as a word or double word,
        or a float), and what the device does not take the device refuses."""
        if not isinstance(text, str) or len(text) > 4 * MAX_TEXT:
            raise ConfigError(f"{param_label(pnu, index)}: the value must be a short text")
        info = await self.drive.info(pnu, timeout=timeout)
        value: object
        if info is None and not self.drive.profile_named:
            value = parse_unknown(text.strip())
        elif info is None:
            raise ConfigError(
                f"{param_label(pnu, index)}: nothing is known of it (no parameter file has "
                "it, the drive gives no description), so its value cannot be checked: write "
                "its words with uss write --raw"
            )
        elif info.read_only:
            raise ValueRefused(f"{param_label(pnu, index)} ({info.name}) is read-only")
        else:
            value = parse(info, text, index)
        try:
            reading = await self.drive.write_param(
                pnu, value, index, eeprom=eeprom, timeout=timeout
            )
        except (DriveRefusal, NoWriteAuthority) as exc:
            self._refused(exc)
            raise
        if self.is_reference(pnu, index):
            with contextlib.suppress(UssError):
                await self.read_reference()
        return reading

    # -- the reference -----------------------------------------------------------------------
    def is_reference(self, pnu: int, index: int | None = None) -> bool:
        """Whether P``pnu`` (element ``index``) is the parameter the reference is read from."""
        reference = self.model.reference
        return isinstance(reference, ParamMeta) and (reference.pnu, reference.index) == (
            pnu,
            index if reference.index is not None else None,
        )

    def _take_reference(self, value: object) -> bool:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        if not math.isfinite(value) or value <= 0:
            return False
        if float(value) != self._reference:
            self._reference = float(value)
            self._changed()
        return True

    async def read_reference(self) -> float | None:
        """Read the reference parameter now (the physical value of 100 %); returns the
        reference (None: the drive has no reference parameter, or its value is no positive
        number). A fixed reference of the configuration is returned as it is."""
        reference = self.model.reference
        if not isinstance(reference, ParamMeta):
            return self._reference
        value = await self.parameter_model.read(self.drive, reference)
        if not self._take_reference(value):
            log.warning("%s: reference %s is %r", self.key, reference.key, value)
        return self._reference

    # -- background reads --------------------------------------------------------------------
    async def run(self) -> None:
        """Read the reference, then the polled parameters when due, until cancelled."""
        reference = self.model.reference
        if isinstance(reference, ParamMeta):
            while self._reference is None:
                try:
                    await self.read_reference()
                except UssError as exc:
                    log.info("%s: reference %s not read: %s", self.key, reference.key, exc)
                if self._reference is None:
                    await asyncio.sleep(RETRY_PERIOD)
        polled = [p for p in self.model.parameters if p.poll is not None]
        if not polled:
            return
        loop = asyncio.get_running_loop()
        due = {p.key: loop.time() for p in polled}
        while True:
            point = min(polled, key=lambda p: due[p.key])
            wait = due[point.key] - loop.time()
            if wait > 0:
                await asyncio.sleep(wait)
            assert point.poll is not None
            due[point.key] = loop.time() + point.poll
            try:
                await self.read_parameter(point.meta.pnu, point.meta.index)
            except UssError as exc:
                old = self._params[point.key]
                self._params[point.key] = ParamValue(old.meta, old.value, old.time, error_dict(exc))
                self._changed()

    def close(self) -> None:
        for remove in self._removers:
            remove()
        if self._fault_task is not None:
            self._fault_task.cancel()


class BusPoints:
    """One bus: its `Master` and the `DrivePoints` of its drives, and whether a master
    exchanges on its line (`state`, `subscribe`). Without a ``transport`` the bus's port URL is
    opened reconnecting (`pyuss.transport.reconnect`) unless the URL says ``reconnect=0``."""

    def __init__(
        self,
        model: BusModel,
        transport: Transport | None = None,
        *,
        close_transport: bool = True,
        rx_tolerance: float | None = None,
    ) -> None:
        config = model.config
        self.model = model
        if transport is None:
            transport = open_transport(config.port, baud=config.baud, reconnect=True)
        self.master = Master(
            transport,
            baud=config.baud,
            profile=config.profile,
            layout=config.layout,
            cycle_time=config.cycle_time,
            job_timeout=config.job_timeout,
            rx_tolerance=rx_tolerance,
            close_transport=close_transport,
        )
        self.drives: dict[int, DrivePoints] = {}
        for drive in model.drives:
            handle = self.master.drive(drive.address, layout=drive.layout, profile=drive.profile)
            self.drives[drive.address] = DrivePoints(
                drive, handle, offline=model.offline, bus_online=False
            )
        self._tasks: list[asyncio.Task[None]] = []
        self._state = BusState(model.name, False, now())
        self._callbacks: list[Callable[[BusState], object]] = []
        self._remove_line = self.master.on_line(self._on_line)

    @property
    def state(self) -> BusState:
        """Whether a master exchanges on the line now (offline until `start`)."""
        return self._state

    @property
    def online(self) -> bool:
        return self._state.online

    def subscribe(self, callback: Callable[[BusState], object]) -> Callable[[], None]:
        """Call ``callback`` with every changed `BusState` (it must not block); returns a
        function that removes it."""
        return _callbacks.add(self._callbacks, callback)

    def _on_line(self, error: UssError | None) -> None:
        """The master's line is lost (``error``) or back (None)."""
        lost = self.master.lost
        if lost is not None:
            log.error(
                "bus %s: the line is lost and not reopened (reconnect=0 in its port URL, or "
                "reconnecting gave up): %s",
                self.name,
                lost,
            )
        self._set_online(error is None, None if lost is None else str(lost))

    def _set_online(self, online: bool, lost: str | None = None) -> None:
        if online == self._state.online and lost is None:
            return
        released = [d.name for d in self.drives.values() if d._bus_changed(online)]
        if released:
            log.warning(
                "bus %s: the line is down: %s %s",
                self.name,
                ", ".join(released),
                GIVEN_BACK.replace("it keeps", "each keeps"),
            )
        self._tell(BusState(self.name, online, now(), lost))

    def _tell(self, state: BusState) -> None:
        """``state`` is the bus's now: each subscriber is told."""
        self._state = state
        _callbacks.call_each(self._callbacks, state, log, "bus %s: subscriber failed", self.name)

    @property
    def name(self) -> str:
        return self.model.name

    def drive(self, which: str | int) -> DrivePoints:
        """A drive by address or name; `UnknownPoint` otherwise."""
        for drive in self.drives.values():
            if which in (drive.address, drive.name) or (
                isinstance(which, str) and which.isdigit() and int(which) == drive.address
            ):
                return drive
        raise UnknownPoint(f"bus {self.name}: no drive {which!r}")

    async def start(self) -> None:
        await self.master.start()
        self._set_online(self.master.online)
        for drive in self.drives.values():
            self._tasks.append(asyncio.create_task(drive.run(), name=f"{drive.key} reads"))
        self._tasks.append(asyncio.create_task(self._watch(), name=f"{self.name} health"))

    async def _watch(self) -> None:
        while True:
            await asyncio.sleep(HEALTH_PERIOD)
            for drive in self.drives.values():
                drive.check_health()

    async def close(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self._tasks.clear()
        self._remove_line()
        for drive in self.drives.values():
            drive.close()
        await self.master.close()
        if self._state.online:
            self._tell(BusState(self.name, False, now()))


class Plant:
    """Every bus of a `PlantModel`, live. ``transports``: a `Transport` per bus name to use
    instead of the bus's port URL (tests, the simulated plant, the web page's tapped line);
    ``close_transports=False`` leaves them open when the plant closes; ``rx_tolerance``: see
    `pyuss.master.Master`."""

    def __init__(
        self,
        model: PlantModel,
        *,
        transports: Mapping[str, Transport] | None = None,
        close_transports: bool = True,
        rx_tolerance: float | None = None,
    ) -> None:
        transports = transports or {}
        self.model = model
        self.buses: dict[str, BusPoints] = {
            bus.name: BusPoints(
                bus,
                transports.get(bus.name),
                close_transport=close_transports,
                rx_tolerance=rx_tolerance,
            )
            for bus in model.buses
        }
        self._started: list[BusPoints] = []

    @property
    def drives(self) -> tuple[DrivePoints, ...]:
        return tuple(d for bus in self.buses.values() for d in bus.drives.values())

    def bus(self, name: str) -> BusPoints:
        try:
            return self.buses[name]
        except KeyError:
            raise UnknownPoint(f"no bus {name!r} (known: {', '.join(self.buses)})") from None

    def drive(self, bus: str, which: str | int) -> DrivePoints:
        return self.bus(bus).drive(which)

    async def lost(self) -> BusState:
        """Wait until a bus's line is lost for good (its master stopped: the port failed and
        is not reopened, `BusState.lost`); that bus's state."""
        found: asyncio.Future[BusState] = asyncio.get_running_loop().create_future()

        def seen(state: BusState) -> None:
            if state.lost is not None and not found.done():
                found.set_result(state)

        removers = [bus.subscribe(seen) for bus in self.buses.values()]
        try:
            for bus in self.buses.values():
                seen(bus.state)
            return await found
        finally:
            for remove in removers:
                remove()

    def subscribe(
        self, callback: Callable[[DrivePoints, DriveState], object]
    ) -> Callable[[], None]:
        """``callback(drive, state)`` for every changed state of every drive."""

        def bind(drive: DrivePoints) -> Callable[[DriveState], object]:
            return lambda state: callback(drive, state)

        removers = [drive.subscribe(bind(drive)) for drive in self.drives]

        def remove() -> None:
            for remover in removers:
                remover()

        return remove

    async def start(self) -> None:
        try:
            for bus in self.buses.values():
                await bus.start()
                self._started.append(bus)
        except BaseException:
            await self.close()
            raise

    async def close(self) -> None:
        started, self._started = self._started, []
        for bus in started:
            await bus.close()

    async def __aenter__(self) -> Plant:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()


def words_of(raw: int, dword: bool) -> tuple[int, ...]:
    """The PZD word(s) of a signed raw process value."""
    if dword:
        return split_dword(raw & 0xFFFF_FFFF)
    return (raw & 0xFFFF,)


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
            raise ConfigError(
                f"raw setpoint {_shown(raw)} does not fit {bits} bits ({low}..{high})"
            )
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
                    f"setpoint {_shown(number)} {unit} is outside {span} ({percents} of the "
                    f"reference, {bits} bits, C 5.2.2)"
                ) from None
            raise ConfigError(
                f"setpoint {_shown(number)} % is outside {percents} of the reference "
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


def _command(name: object) -> Command:
    """The command of `COMMAND_TABLE` named ``name``; `UnknownPoint` naming the known ones."""
    command = COMMAND_TABLE.get(name) if isinstance(name, str) else None
    if command is None:
        raise UnknownPoint(f"unknown command {_shown(name)} (known: {', '.join(COMMAND_TABLE)})")
    return command


def _shown(value: object) -> str:
    """A client's value in an error message, cut short (a 400-digit number, a long text)."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


DECIMAL = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
"""A number as a setpoint is written (``25``, ``-12.5``, ``.5``, ``1e1``): ASCII digits."""
NOT_FINITE = ("inf", "infinity", "nan")
"""Words a float reads as a number that is none (signs and case aside)."""
_DECIMAL = re.compile(DECIMAL, re.ASCII)
_HEX = re.compile(r"[+-]?0[xX][0-9a-fA-F]+", re.ASCII)


def _number(value: object, what: str, *, raw: bool = False) -> int | float:
    """A finite number, or a number as text (at most `MAX_TEXT` characters, ASCII digits:
    ``25``, ``-12.5``, ``1e2``; a ``raw`` one in hexadecimal too: ``0x2000``)."""
    if isinstance(value, str):
        value = _parse_number(value.strip(), what, raw=raw)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"{what} must be a finite number, not {_shown(value)}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{what} must be a finite number, not {value!r}")
    return value


def _parse_number(text: str, what: str, *, raw: bool) -> int | float:
    if len(text) <= MAX_TEXT:
        if _HEX.fullmatch(text):
            if raw:
                return int(text, 16)
            raise ConfigError(
                f"{what} {_shown(text)}: a hexadecimal number is taken as a raw word only; "
                "give percent or the unit in decimal"
            )
        if text.lower().lstrip("+-") in NOT_FINITE:
            raise ConfigError(f"{what} must be a finite number, not {text}")
        if _DECIMAL.fullmatch(text):
            return int(text) if text.lstrip("+-").isdigit() else float(text)
    raise ConfigError(f"{what} {_shown(text)} is not a number")
