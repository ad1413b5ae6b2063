"""The running plant: one `Master` per bus, and per drive its points, live.

`Plant` opens one master per bus (`BusPoints`), takes a `Drive` handle per configured drive and
keeps a `DrivePoints` per drive, which

- builds a new `DriveState` from every answer of the drive (the master's ``on_update``
  callback) and tells its subscribers when the state changed - so the faces publish at the
  bus cycle, and not at all while nothing changes; the running counters alone are no change
  (`DriveState.signature`), `DrivePoints.snapshot` gives them fresh;
- watches "does not send" (A 5.2.1.1), which no answer reports, on a short timer;
- reads the reference (the physical value of 100 %) once it can, the fault number when the
  fault bit rises, and the polled parameters when due;
- carries out what the faces ask - commands, control word, setpoints, parameter reads and
  writes - through the drive handle, so everything queues in the master and nothing
  interleaves on the line; a refusal is raised to the caller (`pyuss.errors.DriveRefusal`
  with the drive's error number, `NoWriteAuthority`) and kept as the drive's last refusal.

Subscribers: `DrivePoints.subscribe` / `Plant.subscribe` take a callback (called in the
master's task: it must not block), `DrivePoints.updates` is an async iterator that always
yields the newest state and skips what a slow reader missed, so memory stays bounded.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import logging
import math
from collections.abc import AsyncIterator, Callable, Mapping
from types import TracebackType

from pyuss.errors import ConfigError, DriveRefusal, UssError
from pyuss.master.drive import Drive
from pyuss.master.errors import NoWriteAuthority
from pyuss.master.process import DriveStatus
from pyuss.master.scheduler import Master
from pyuss.points.config import ProcessConfig
from pyuss.points.errors import UnknownPoint, error_dict
from pyuss.points.model import COMMANDS, BusModel, DriveModel, PlantModel
from pyuss.points.parameters import ParameterModel, ParamMeta
from pyuss.points.state import DriveState, Health, ParamValue, ProcessValue, now, process_value
from pyuss.protocol.pzd import FULL_SCALE_16, FULL_SCALE_32, StatusWord, split_dword
from pyuss.transport.base import Transport

__all__ = ["BusPoints", "DrivePoints", "Plant"]

log = logging.getLogger("pyuss.points")

HEALTH_PERIOD = 0.2
"""How often "does not send" is looked at (seconds)."""
RETRY_PERIOD = 5.0
"""How long to wait before reading the reference again after a failure (seconds)."""


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

    def __init__(self, model: DriveModel, drive: Drive) -> None:
        self.model = model
        self.drive = drive
        self.parameter_model = ParameterModel(model.profile)
        self._reference: float | None = (
            model.reference if isinstance(model.reference, float) else None
        )
        self._params: dict[str, ParamValue] = {p.key: ParamValue(p.meta) for p in model.parameters}
        self._last_fault: int | None = None
        self._last_fault_time: datetime.datetime | None = None
        self._last_refusal: dict[str, object] | None = None
        self._callbacks: list[Callable[[DriveState], object]] = []
        self._watches: list[_Watch] = []
        self._quick: tuple[object, ...] | None = None
        self._fault_task: asyncio.Task[None] | None = None
        self._state = self._build()
        self._signature = self._state.signature()
        self._remove = drive.on_update(self._on_update)

    def __repr__(self) -> str:
        return f"<DrivePoints {self.model.key} address {self.model.address}>"

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
        diag = drive.diagnostics()
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
        quick = (status.word, status.actual, self.drive.control, self.drive.setpoints)
        previous = self._state.status_word
        if quick == self._quick and not self._state.health.not_sending:
            return
        self._quick = quick
        if (
            status.word & StatusWord.FAULT
            and not (previous or 0) & StatusWord.FAULT
            and self.model.fault is not None
        ):
            self._read_fault_soon()
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
        """Tell subscribers if "does not send" changed (no answer reports that)."""
        if self.drive.not_sending != self._state.health.not_sending:
            self._changed()

    # -- subscribers -------------------------------------------------------------------------
    def subscribe(self, callback: Callable[[DriveState], object]) -> Callable[[], None]:
        """Call ``callback`` with every changed state (in the master's task: do not block);
        returns a function that removes it."""
        self._callbacks.append(callback)

        def remove() -> None:
            if callback in self._callbacks:
                self._callbacks.remove(callback)

        return remove

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

    async def command(self, name: str) -> DriveState:
        """One of `COMMANDS`: ``on``, ``off1``, ``off2``, ``off3``, ``acknowledge``. Returns
        once a telegram carrying it was answered."""
        if name not in COMMANDS:
            raise UnknownPoint(f"unknown command {name!r} (known: {', '.join(COMMANDS)})")
        method = {
            "on": self.drive.on,
            "off1": self.drive.off1,
            "off2": self.drive.off2,
            "off3": self.drive.off3,
            "acknowledge": self.drive.acknowledge,
        }[name]
        await method()
        self._changed()
        return self._state

    async def set_control_word(self, word: int) -> DriveState:
        if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
            raise ConfigError(f"control word must be 0..65535 (0..FFFFh), not {word!r}")
        await self.drive.control_word(word)
        self._changed()
        return self._state

    async def set_process(
        self, *, control: int | None = None, words: Mapping[int, int] | None = None
    ) -> DriveState:
        """Set the control word and raw PZD words (``{number: word}``, 2..16) together;
        returns once a telegram carrying all of them was answered."""
        if control is not None and (
            isinstance(control, bool) or not isinstance(control, int) or not 0 <= control <= 0xFFFF
        ):
            raise ConfigError(f"control word must be 0..65535 (0..FFFFh), not {control!r}")
        for number, value in (words or {}).items():
            if not 2 <= number <= self.model.layout.pzd:
                raise UnknownPoint(f"{self.key}: PZD{number} is not in layout {self.model.layout}")
            self.drive.set_pzd(number, value)
        await self.drive.control_word(self.drive.control if control is None else control)
        self._changed()
        return self._state

    def setpoint_point(self, key: str = "main") -> tuple[int, bool]:
        for item in self.model.setpoints:
            if item.key == key:
                return item.pzd, item.dword
        raise UnknownPoint(f"{self.key}: no setpoint {key!r}")

    def setpoint_raw(self, value: float, key: str = "main", *, unit: str = "value") -> int:
        """The raw word(s) for a setpoint ``value`` in the point's unit (``unit="value"``;
        percent when no reference is known), ``"percent"`` or ``"raw"``; `ConfigError` if
        it does not fit (16 bits: -200 % .. +199.99 %)."""
        _, dword = self.setpoint_point(key)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"setpoint must be a finite number, not {value!r}")
        if not math.isfinite(value):
            raise ConfigError(f"setpoint must be a finite number, not {value!r}")
        full = FULL_SCALE_32 if dword else FULL_SCALE_16
        bits = 32 if dword else 16
        if unit == "raw":
            raw = value
            if raw != int(raw):
                raise ConfigError(f"a raw setpoint is a whole number, not {value!r}")
            raw = int(raw)
        else:
            if unit == "value" and self.model.unit != "%":
                if self._reference is None:
                    raise ConfigError(
                        f"{self.key}: the reference is not known yet: give the setpoint in percent"
                    )
                percent = value * 100.0 / self._reference
            elif unit in ("value", "percent"):
                percent = float(value)
            else:
                raise ConfigError(f"unit must be value, percent or raw, not {unit!r}")
            raw = round(percent * full / 100)
        low, high = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
        if not low <= raw <= high:
            span = f"{low * 100 / full:g} .. {high * 100 / full:.2f} %"
            raise ConfigError(f"setpoint {value!r} does not fit {bits} bits ({span})")
        return raw

    async def set_setpoint(
        self, value: float, key: str = "main", *, unit: str = "value"
    ) -> DriveState:
        """Set a setpoint (see `setpoint_raw`); returns once a telegram carrying it was
        answered."""
        raw = self.setpoint_raw(value, key, unit=unit)
        pzd, dword = self.setpoint_point(key)
        await self.drive.setpoint(raw=raw, pzd=pzd, dword=dword)
        self._changed()
        return self._state

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
        drive answered."""
        meta = self.meta(pnu, index)
        try:
            answered = await self.parameter_model.write(self.drive, meta, value, eeprom=eeprom)
        except (DriveRefusal, NoWriteAuthority) as exc:
            self._refused(exc)
            raise
        reading = ParamValue(meta, answered, now())
        if meta.key in self._params:
            self._params[meta.key] = reading
            self._changed()
        return reading

    # -- background reads --------------------------------------------------------------------
    async def run(self) -> None:
        """Read the reference, then the polled parameters when due, until cancelled."""
        reference = self.model.reference
        if isinstance(reference, ParamMeta):
            while self._reference is None:
                try:
                    value = await self.parameter_model.read(self.drive, reference)
                except UssError as exc:
                    log.info("%s: reference %s not read: %s", self.key, reference.key, exc)
                    await asyncio.sleep(RETRY_PERIOD)
                    continue
                if value and float(value) > 0:
                    self._reference = float(value)
                    self._changed()
                else:
                    log.warning("%s: reference %s is %r", self.key, reference.key, value)
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
        self._remove()
        if self._fault_task is not None:
            self._fault_task.cancel()


class BusPoints:
    """One bus: its `Master` and the `DrivePoints` of its drives."""

    def __init__(self, model: BusModel, transport: Transport | None = None) -> None:
        config = model.config
        self.model = model
        self.master = Master(
            transport if transport is not None else config.port,
            baud=config.baud,
            profile=config.profile,
            layout=config.layout,
            cycle_time=config.cycle_time,
            job_timeout=config.job_timeout,
        )
        self.drives: dict[int, DrivePoints] = {}
        for drive in model.drives:
            handle = self.master.drive(drive.address, layout=drive.layout, profile=drive.profile)
            self.drives[drive.address] = DrivePoints(drive, handle)
        self._tasks: list[asyncio.Task[None]] = []

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
        for drive in self.drives.values():
            drive.close()
        await self.master.close()


class Plant:
    """Every bus of a `PlantModel`, live. ``transports``: a `Transport` per bus name to use
    instead of the bus's port URL (tests, the simulated plant)."""

    def __init__(
        self, model: PlantModel, *, transports: Mapping[str, Transport] | None = None
    ) -> None:
        transports = transports or {}
        self.model = model
        self.buses: dict[str, BusPoints] = {
            bus.name: BusPoints(bus, transports.get(bus.name)) for bus in model.buses
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
