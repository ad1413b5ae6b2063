"""The live points of one drive: its state from every answer, its availability, and what the
faces ask of it, carried out through its drive handle.

Everything that turns a face's wish into process data lives here (its parameter jobs in
`pyuss.points.access`); nothing reaches the line that was not checked first. The rules every
face relies on:

- A request is checked whole before anything goes out, and a refused request changes
  nothing: a setpoint (`DrivePoints.check_setpoint`), a command (one table,
  `pyuss.points.model.COMMAND_TABLE`), a control word, raw process words (all by
  `pyuss.points.checks`), a parameter value (`pyuss.points.access`) - each raises
  `ConfigError` (or `UnknownPoint`) before the master is told anything.
- Until a command the master sends 0000h, no control by the interface, so a face started
  again stops no running drive; a command that would take control with what nobody asked
  for is refused (`NotInControl`, by `pyuss.points.checks.check_takeover`).
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

A `DrivePoints`

- builds a new `DriveState` from every answer of the drive (the master's ``on_update``
  callback) and tells its subscribers when the state changed - so the faces publish at the
  bus cycle, and not at all while nothing changes; the running counters alone are no change
  (`DriveState.signature`), `DrivePoints.snapshot` gives them fresh. The state is built in
  the loop's next turn, once the master has handed its next telegram over (on a virtual bus
  it does so before yielding): the faces' work is done while that telegram is on the line,
  and does not keep it off (what must not wait - the end of a jog on a fault - is done at
  once);
- watches "does not send" (A 5.2.1.1), which no answer reports, when its bus asks
  (`check_health`), and tells when the drive is offline: after its bus's `OfflineRule` (so
  many answers missed in a row, or so long without one; an answer missed short of that makes
  its values stale), or at once when its bus is (`pyuss.points.plant.BusPoints`); the drive
  is online again with its next answer. Each change of availability is one log line
  (WARNING) naming the drive;
- reads the fault number when the fault bit rises, and holds a `ParameterAccess` for the
  reference, the polled parameters and the parameter jobs faces ask (its methods are
  offered here as well).

Subscribers: `DrivePoints.subscribe` takes a callback (called in the loop's task that
changed the state, or in the turn after an answer: it must not block), `DrivePoints.updates`
is an async iterator that always yields the newest state and skips what a slow reader
missed, so memory stays bounded.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import logging
import time
from collections import deque
from collections.abc import AsyncIterator, Callable, Mapping, Sequence
from typing import Any

from pyuss import _callbacks, system
from pyuss.drive.datatypes import Value
from pyuss.errors import UssError
from pyuss.master.drive import Drive
from pyuss.master.process import DriveStatus
from pyuss.params import ParamInfo
from pyuss.params.model import Reading
from pyuss.points.access import ParameterAccess
from pyuss.points.checks import (
    check_takeover,
    checked_control,
    checked_words,
    command_named,
    drive_setpoint,
    setpoint_point,
    setpoint_units,
)
from pyuss.points.config import ProcessConfig
from pyuss.points.model import Command, DriveModel, OfflineRule, line_model
from pyuss.points.parameters import ParamMeta
from pyuss.points.state import (
    DriveState,
    Health,
    ParamValue,
    ProcessValue,
    Sample,
    now,
    process_value,
)
from pyuss.protocol.frozen import builder
from pyuss.protocol.pzd import SWITCHES_ON, ControlWord, StatusWord
from pyuss.transport.reconnect import duration_text

__all__ = ["GIVEN_BACK", "JOG_GRACE", "DrivePoints"]

log = logging.getLogger("pyuss.points")

_drive_state = builder(DriveState)
_health = builder(Health)

_FAULT = int(StatusWord.FAULT)
"""The fault bit as a plain int: tested at every answer, where a flag's own `&` costs three
Python calls."""

GIVEN_BACK = "control given back (0000h: it keeps what it had; a command takes control again)"
"""What a log line says of a drive given back (`DrivePoints._release`)."""
DEFAULT_OFFLINE = OfflineRule()
"""The rule of a drive's points made without a bus (`DrivePoints.around`)."""
JOG_GRACE = 0.2
"""How long a jog runs on after a missed answer (seconds): one answer lost on a noisy line or
to a busy computer does not stop it, a drive silent longer may have lost its power, and would
jog again on the standing bit once it is back. Far shorter than any drive's power-up; the jog
ends at most `pyuss.points.plant.HEALTH_PERIOD` later."""


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
        self.access = ParameterAccess(model, drive, self._changed)
        """Its parameters and reference; its methods are offered here as well."""
        self.parameter_model = self.access.parameter_model
        self._last_fault: int | None = None
        self._last_fault_time: datetime.datetime | None = None
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
        return self.access.reference

    # -- building states ---------------------------------------------------------------------
    def _process(
        self, items: tuple[ProcessConfig, ...], words: tuple[int, ...]
    ) -> dict[str, ProcessValue]:
        found: dict[str, ProcessValue] = {}
        reference, unit = self.access.reference, self.model.unit
        for item in items:
            value = process_value(item.key, item.pzd, item.dword, words, reference, unit)
            if value is not None:
                found[item.key] = value
        return found

    def _build(self) -> DriveState:
        drive, access = self.drive, self.access
        status = drive.status
        diag = drive.counts()
        actual_words = status.actual if status is not None else ()
        setpoint_words = drive.setpoints
        # (made at every answer: the dataclasses built without their __init__, all fields
        # in their order)
        return _drive_state(
            self.model,
            datetime.datetime.now(datetime.UTC),  # `pyuss.points.state.now`
            status.word if status is not None else None,
            drive.control,
            self._process(self.model.actual, actual_words) if status is not None else {},
            self._process(self.model.setpoints, setpoint_words),
            dict(access.params),
            _health(
                drive.not_sending,
                diag.counters,
                diag.exchanges,
                diag.answers,
                diag.timeouts,
                self._last_fault,
                self._last_fault_time,
                access.last_refusal,
            ),
            access.reference,
            actual_words,
            setpoint_words,
            self._bus_online,
            self._answering,
            self._missed,
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
            self._samples.append(
                Sample(time.time(), status.word, self.access.actual_row(status.actual))
            )
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
        # (asked for every drive several times a second: the calls only when they may act)
        if self._missed:
            self._jog_silent()
        if self._bus_online and (
            self._missed >= self.offline.missed
            or system.clock() - self._heard >= self.offline.silence
        ):
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

    def bus_changed(self, online: bool) -> bool:
        """Its bus went online or offline (told by its `pyuss.points.plant.BusPoints`); True
        when the drive was given back (`_release`)."""
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
    async def command(self, name: str, *, timeout: float | None = None) -> DriveState:
        """One of `pyuss.points.model.COMMAND_TABLE`: ``on``, ``off1``, ``off2``, ``off3``,
        ``acknowledge``, ``jog1``, ``jog2``, ``jog_off``. Returns once a telegram carrying it
        was answered."""
        command = command_named(name)
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
            self._check_takeover(command_named(command), given)

    def _check_word(self, word: int, words: set[int]) -> None:
        """`_check_takeover` for a control word a face sends itself (with the PZD words
        ``words`` of the same request): one with control by the interface (bit 10) and ON
        or a jog bit is an ON."""
        if word & ControlWord.CONTROL_BY_PLC:
            moves = bool(word & SWITCHES_ON)
            command = Command(f"control word {word:04X}h", "control_word", moves=moves)
            self._check_takeover(command, words)

    def _check_takeover(self, command: Command, given: set[int] | None = None) -> None:
        """`pyuss.points.checks.check_takeover` of ``command`` on this drive now, while this
        master has sent it no control word (0000h); ``given``: the PZD words the request sets
        besides."""
        if not self.drive.control & ControlWord.CONTROL_BY_PLC:
            unset = self._unset_setpoints(given or set())
            check_takeover(command, unset, self.drive.running_elsewhere(), self.key)

    def _unset_setpoints(self, given: set[int]) -> list[str]:
        """The setpoints of the drive whose words no face has set since the start (nor
        sets now: the PZD numbers ``given``)."""
        return [
            item.key
            for item in self.model.setpoints
            if not {item.pzd, item.pzd + item.dword} <= self._given | given
        ]

    async def set_control_word(self, word: int) -> DriveState:
        self._check_word(checked_control(word), set())
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
        if control is not None:
            checked_control(control)
        words = checked_words(words or {}, self.model.layout, self.key)
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
        """The first PZD number of setpoint ``key`` and whether it is a double word."""
        return setpoint_point(self.model, key)

    def setpoint_units(self) -> tuple[str, ...]:
        """The units a setpoint may be given in: ``%`` and, where the reference is known,
        its unit (``raw`` besides, for the word itself)."""
        return setpoint_units(self.model, self.reference)

    def check_setpoint(
        self, value: object, key: str = "main", *, unit: str = "value"
    ) -> ProcessValue:
        """The setpoint ``value`` checked whole, as it would be sent: ``unit`` is ``value``
        (the point's unit; percent when no reference is known), ``percent`` (or ``%``), the
        reference's unit by name (``Hz``) or ``raw``; a number, or a number as text. The
        word's range bounds it (16 bits: -200 % .. +199.99 %, C 5.2.2); `ConfigError` names
        what is wrong. Nothing is sent (`pyuss.points.checks.drive_setpoint`)."""
        return drive_setpoint(self.model, self.reference, value, key, unit)

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

    def setpoint_value(self) -> float | None:
        """The main setpoint as sent (PZD2), in the unit of the main actual value."""
        main = process_value("main", 2, False, self.drive.setpoints, self.reference, "")
        if main is None:
            return None
        return main.percent if main.value is None else main.value

    # -- its parameters (`ParameterAccess`) --------------------------------------------------
    def process_parameter(self, number: int) -> ParamInfo | None:
        """`ParameterAccess.process_parameter`: the parameter of actual value PZD``number``."""
        return self.access.process_parameter(number)

    def actual_columns(self) -> list[dict[str, Any]]:
        """`ParameterAccess.actual_columns`: name and unit of each value of `actual_row`."""
        return self.access.actual_columns()

    def actual_items(self, words: Sequence[int]) -> list[tuple[Value, ParamInfo | None]]:
        """`ParameterAccess.actual_items`: an answer's PZD2... as typed values."""
        return self.access.actual_items(words)

    def actual_row(self, words: Sequence[int]) -> tuple[float, ...]:
        """`ParameterAccess.actual_row`: an answer's PZD2... as numbers."""
        return self.access.actual_row(words)

    def meta(self, pnu: int, index: int | None = None) -> ParamMeta:
        """`ParameterAccess.meta`: what is known of P``pnu``."""
        return self.access.meta(pnu, index)

    async def read_parameter(self, pnu: int, index: int | None = None) -> ParamValue:
        """`ParameterAccess.read_parameter`: read P``pnu`` now as a number."""
        return await self.access.read_parameter(pnu, index)

    async def write_parameter(
        self, pnu: int, value: float, index: int | None = None, *, eeprom: bool = False
    ) -> ParamValue:
        """`ParameterAccess.write_parameter`: write a number in the parameter's unit."""
        return await self.access.write_parameter(pnu, value, index, eeprom=eeprom)

    async def read_value(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> Reading:
        """`ParameterAccess.read_value`: read any parameter, typed by the parameter book."""
        return await self.access.read_value(pnu, index, timeout=timeout)

    async def write_value(
        self,
        pnu: int,
        index: int | None,
        text: str,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
    ) -> Reading:
        """`ParameterAccess.write_value`: write a value as a person types it, checked first."""
        return await self.access.write_value(pnu, index, text, eeprom=eeprom, timeout=timeout)

    def is_reference(self, pnu: int, index: int | None = None) -> bool:
        """`ParameterAccess.is_reference`: whether P``pnu`` is the reference parameter."""
        return self.access.is_reference(pnu, index)

    async def read_reference(self) -> float | None:
        """`ParameterAccess.read_reference`: read the reference now."""
        return await self.access.read_reference()

    async def run(self) -> None:
        """Read the reference, then the polled parameters when due, until cancelled
        (`ParameterAccess.run`)."""
        await self.access.run()

    def close(self) -> None:
        for remove in self._removers:
            remove()
        if self._fault_task is not None:
            self._fault_task.cancel()
