"""The page's one door to the drives: everything `pyuss.web` reads from or sends to a drive
goes through `Backend`, and nothing else in the package touches the master.

A `Backend` owns one `pyuss.master.Master` in cyclic operation on the port given (or, for
``uss web --demo``, on a virtual bus with simulated drives of `pyuss.master.testing`), the
drive handles, a bounded buffer of process-data samples per drive for the live view and the
trend, and a `pyuss.monitor.Monitor` that decodes the telegrams on the line: the master's own
traffic seen through `pyuss.web.tap.TapTransport`, or, in the demo, a listen-only station of
the virtual bus.

Parameter knowledge (names, units, types, limits, value texts) comes from the drive profile's
parameter file (`pyuss.profiles.Profile.database`); values travel as the words of the
parameter channel and are converted with that file's types.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import re
import tempfile
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyuss.drive.database import Parameter, ParameterDatabase
from pyuss.drive.datatypes import DataType
from pyuss.drive.faults import ParameterFault
from pyuss.errors import ConfigError, UssError
from pyuss.master import Drive, DriveStatus, Master
from pyuss.master.scan import Found, scan
from pyuss.monitor.core import Monitor, default_gap
from pyuss.monitor.infer import LayoutBook
from pyuss.monitor.model import Exchange
from pyuss.monitor.render import exchange_line
from pyuss.profiles import get_profile, profile_names
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pkw import Pkw, RequestId, pwe_dword, pwe_float, pwe_word
from pyuss.protocol.pzd import STATUS_BITS, raw16_to_percent
from pyuss.protocol.telegram import MAX_ADDRESS
from pyuss.transport.base import Chunk, Transport, stamp_tolerance
from pyuss.web.tap import TapTransport

__all__ = [
    "DEMO_BAUD",
    "DEMO_DRIVES",
    "Backend",
    "DriveSpec",
    "Sample",
]

DEMO_BAUD = 38400
SAMPLE_BUFFER = 2000
"""Process-data samples kept per drive between two takes (older ones are dropped)."""
EXCHANGE_BUFFER = 5000
"""Decoded telegrams kept for the monitor view and its pcapng download."""


@dataclass(frozen=True, slots=True)
class DriveSpec:
    """A drive the page works with: its address, profile and telegram layout."""

    address: int
    profile: str = "generic"
    layout: Layout | None = None

    def __post_init__(self) -> None:
        if not 0 <= self.address <= MAX_ADDRESS:
            raise ConfigError(f"address {self.address} is not 0..{MAX_ADDRESS}")
        if self.profile not in profile_names():
            raise ConfigError(
                f"profile {self.profile!r} is not one of {', '.join(profile_names())}"
            )


DEMO_DRIVES: tuple[DriveSpec, ...] = (
    DriveSpec(1, "generic", Layout(PKW_VARIABLE, 2)),
    DriveSpec(4, "baumueller", Layout(3, 2)),
    DriveSpec(7, "micromaster4", Layout(PKW_VARIABLE, 2)),
)
"""The simulated drives of ``uss web --demo`` (the same bus as ``uss demo``)."""


@dataclass(frozen=True, slots=True)
class Sample:
    """The process data of one answer: wall-clock time (Unix seconds), status, actual values."""

    time: float
    status: int
    actual: tuple[int, ...]


@dataclass(slots=True)
class _Unit:
    """How PZD2 (the main actual value, 4000h = 100 %) reads in physical units."""

    reference: float
    unit: str


@dataclass(slots=True)
class _DriveState:
    spec: DriveSpec
    drive: Drive
    database: ParameterDatabase
    samples: deque[Sample] = field(default_factory=lambda: deque(maxlen=SAMPLE_BUFFER))
    reference: _Unit | None = None


def _number(value: float, decimals: int) -> str:
    return f"{value:.{decimals}f}" if decimals else f"{value:g}"


class Backend:
    """The drives of one line for the page (see the module text).

    ``port``: a URL for `pyuss.transport.open_transport`, or None with ``demo=True``.
    ``drives``: the drives to work with (the demo's own when empty in the demo).
    """

    def __init__(
        self,
        *,
        port: str | None = None,
        baud: int = 9600,
        drives: Sequence[DriveSpec] = (),
        demo: bool = False,
        job_timeout: float = 2.0,
        transport: Transport | None = None,
    ) -> None:
        if demo == (port is not None or transport is not None):
            raise ConfigError("give a port, or ask for the demo (simulated drives), not both")
        self.port = "demo (virtual bus, simulated drives)" if demo else (port or "transport")
        self.demo = demo
        self.baud = DEMO_BAUD if demo else baud
        self.job_timeout = job_timeout
        self._specs: list[DriveSpec] = list(drives or (DEMO_DRIVES if demo else ()))
        self._transport = transport
        self._url = port
        self._drives: dict[int, _DriveState] = {}
        self._master: Master | None = None
        self._stack = contextlib.AsyncExitStack()
        self._bus: Any = None
        self.engines: dict[int, Any] = {}
        """The simulated drives' engines (demo only), by address."""
        self._monitor: Monitor | None = None
        self._monitor_task: asyncio.Task[None] | None = None
        self._stop = asyncio.Event()
        self._epoch = 0.0
        self.exchanges: deque[tuple[int, Exchange]] = deque(maxlen=EXCHANGE_BUFFER)
        self._exchange_seq = 0
        self.scan_progress: tuple[int, int] | None = None
        self._lock = asyncio.Lock()

    # -- life cycle ---------------------------------------------------------------------------
    async def start(self) -> None:
        try:
            await self._open()
        except BaseException:
            await self.close()
            raise

    async def _open(self) -> None:
        if self.demo:
            import logging

            from pyuss.bus import VirtualBus
            from pyuss.master.testing import simulated_drives

            # The simulated drives share the event loop with the page; a busy moment makes
            # them complain about their own answer times, which is not the point here.
            logging.getLogger("pyuss.slave").setLevel(logging.ERROR)
            self._bus = VirtualBus(DEMO_BAUD)
            self._stack.push_async_callback(self._bus.close)
            self.engines = await self._stack.enter_async_context(
                simulated_drives(self._bus, [(s.address, s.profile, s.layout) for s in DEMO_DRIVES])
            )
        await self._start_master()

    def _new_transport(self, tap: bool) -> Transport:
        if self.demo:
            station: Transport = self._bus.attach("master")
            return station
        if self._transport is not None:
            inner = self._transport
        else:
            from pyuss.transport.url import open_transport

            assert self._url is not None
            inner = open_transport(self._url, baud=self.baud)
        return TapTransport(inner, self._feed) if tap else inner

    async def _start_master(self) -> None:
        self._stop = asyncio.Event()
        layouts = {s.address: s.layout for s in self._specs if s.layout is not None}
        if self.demo:
            self._monitor = Monitor(
                self.baud,
                layouts=LayoutBook(per_address=layouts),
                gap=default_gap(self.baud),
            )
            listener = self._bus.attach("page-monitor", listen_only=True)
            await listener.open()
            self._monitor_task = asyncio.create_task(self._watch(listener))
            transport = self._new_transport(tap=False)
            options: dict[str, Any] = {}
        else:
            inner = self._new_transport(tap=False)
            exact = inner.exact_timestamps
            self._monitor = Monitor(
                self.baud,
                four_wire=True,
                layouts=LayoutBook(per_address=layouts),
                gap=default_gap(self.baud),
                tolerance=stamp_tolerance(inner),
            )
            transport = TapTransport(inner, self._feed)
            options = {"rx_tolerance": 0.0} if exact else {}
            self._monitor_task = asyncio.create_task(self._tick_monitor(transport))
        self._epoch = time.time() - transport.clock()
        master = Master(
            transport,
            job_timeout=self.job_timeout,
            close_transport=not (self._transport is not None and not self.demo),
            **options,
        )
        self._drives = {}
        for spec in self._specs:
            drive = master.drive(spec.address, layout=spec.layout, profile=spec.profile)
            state = _DriveState(spec, drive, get_profile(spec.profile).database())
            drive.on_update(self._sampler(state))
            self._drives[spec.address] = state
        await master.start()
        self._master = master
        for state in self._drives.values():
            await self._read_reference(state)

    async def _stop_master(self) -> None:
        self._stop.set()
        if self._master is not None:
            await self._master.close()
            self._master = None
        if self._monitor_task is not None:
            self._monitor_task.cancel()
            with contextlib.suppress(asyncio.CancelledError, UssError):
                await self._monitor_task
            self._monitor_task = None
        if self.demo and self._bus is not None:
            for name in ("master", "page-monitor"):
                with contextlib.suppress(KeyError, UssError):
                    self._bus.detach(name)

    async def close(self) -> None:
        await self._stop_master()
        await self._stack.aclose()

    @property
    def master(self) -> Master:
        if self._master is None:
            raise ConfigError("the line is busy (a scan is running)")
        return self._master

    # -- process data -------------------------------------------------------------------------
    def _sampler(self, state: _DriveState) -> Callable[[DriveStatus], None]:
        samples = state.samples

        def take(status: DriveStatus) -> None:
            samples.append(Sample(time.time(), status.word, status.actual))

        return take

    def take_samples(self) -> dict[int, list[Sample]]:
        """The samples of every drive since the last call (at most `SAMPLE_BUFFER` each)."""
        out = {}
        for address, state in self._drives.items():
            if state.samples:
                out[address] = list(state.samples)
                state.samples.clear()
        return out

    async def _read_reference(self, state: _DriveState) -> None:
        """Read the drive's reference value (100 % of PZD2) once, for actual values in units."""
        ref = state.database.roles.get("reference")
        if ref is None:
            return
        param = state.database.parameter(ref.pnu)
        try:
            value = await self._read_value(state, param, ref.index)
        except UssError:
            return
        if isinstance(value, int | float) and param.unit:
            scaled = value * param.scaling if param.scaling else value
            state.reference = _Unit(float(scaled), param.unit)

    def _state(self, address: int) -> _DriveState:
        try:
            return self._drives[address]
        except KeyError:
            raise ConfigError(f"drive {address} is not on the page") from None

    def addresses(self) -> list[int]:
        return sorted(self._drives)

    def drive_info(self, address: int) -> dict[str, Any]:
        """What does not change: profile, layout, the status bits' meanings, the actual
        values' names and units."""
        state = self._state(address)
        profile = get_profile(state.spec.profile)
        drive = state.drive
        actuals = []
        for number in range(2, drive.layout.pzd + 1):
            if number == 2:
                unit = state.reference.unit if state.reference else "%"
                actuals.append({"pzd": 2, "name": "Main actual value", "unit": unit})
                continue
            pnus = state.database.process_actuals
            pnu = pnus[number - 3] if number - 3 < len(pnus) else 0
            if pnu:
                param = state.database.parameter(pnu)
                actuals.append({"pzd": number, "name": param.name, "unit": param.unit})
            else:
                actuals.append({"pzd": number, "name": f"PZD{number}", "unit": ""})
        return {
            "address": address,
            "profile": profile.name,
            "title": profile.title,
            "layout": str(drive.layout),
            "pzd": drive.layout.pzd,
            "reference": (
                {"value": state.reference.reference, "unit": state.reference.unit}
                if state.reference
                else None
            ),
            "actuals": actuals,
            "status_bits": [
                {"bit": bit, "set": texts[0], "clear": texts[1]}
                for bit, texts in sorted(STATUS_BITS.items())
            ],
        }

    def actual_values(self, address: int, actual: Sequence[int]) -> list[float]:
        """The actual values in the units `drive_info` names (PZD2 in % or the reference's
        unit, PZD3... scaled by their parameters)."""
        state = self._state(address)
        out: list[float] = []
        for number, raw in enumerate(actual, start=2):
            if number == 2:
                percent = raw16_to_percent(raw)
                out.append(
                    percent * state.reference.reference / 100 if state.reference else percent
                )
                continue
            pnus = state.database.process_actuals
            pnu = pnus[number - 3] if number - 3 < len(pnus) else 0
            if not pnu:
                out.append(float(raw))
                continue
            param = state.database.parameter(pnu)
            value = raw - 0x10000 if param.dtype is DataType.INT16 and raw & 0x8000 else raw
            out.append(value * param.scaling if param.scaling else float(value))
        return out

    def setpoint_value(self, address: int) -> float | None:
        """The main setpoint sent (PZD2) in the unit of the main actual value."""
        state = self._state(address)
        setpoints = state.drive.setpoints
        if not setpoints:
            return None
        percent = raw16_to_percent(setpoints[0])
        return percent * state.reference.reference / 100 if state.reference else percent

    def summary(self, address: int) -> dict[str, Any]:
        """State, fault, communication health of one drive (A 5.2.3 counters included)."""
        state = self._state(address)
        drive = state.drive
        status = drive.status
        diagnostics = drive.diagnostics()
        counters = diagnostics.counters
        out: dict[str, Any] = {
            "address": address,
            "profile": state.spec.profile,
            "layout": str(drive.layout),
            "not_sending": drive.not_sending,
            "control": drive.control,
            "setpoints": list(drive.setpoints),
            "status": None if status is None else status.word,
            "state": "no answer yet" if status is None else status.state,
            "fault": bool(status and status.fault),
            "warning": bool(status and status.warning),
            "actual": [] if status is None else self.actual_values(address, status.actual),
            "health": {
                "exchanges": diagnostics.exchanges,
                "answers": diagnostics.answers,
                "timeouts": diagnostics.timeouts,
                "late": diagnostics.late,
                "response_ms": round(diagnostics.response_time.median * 1000, 3),
                "jobs": diagnostics.jobs.completed,
                "refused": diagnostics.jobs.refused,
                "counters": {
                    "good": counters.good,
                    "discarded": counters.discarded,
                    "good_per_minute": counters.good_per_minute,
                    "discarded_per_minute": counters.discarded_per_minute,
                    "framing": counters.framing,
                    "overrun": counters.overrun,
                    "parity": counters.parity,
                    "no_stx": counters.no_stx,
                    "residual_time": counters.residual_time,
                    "bcc": counters.bcc,
                    "bad_lge": counters.bad_lge,
                    "timeout": counters.timeout,
                    "error_status": int(counters.error_status),
                },
            },
        }
        return out

    def bus(self) -> dict[str, Any]:
        """The line: port, baud rate, the drives and the line's own counters."""
        line: dict[str, Any] = {}
        cycle_ms = 0.0
        if self._master is not None:
            diag = self._master.diagnostics()
            line = {
                "good": diag.line.good,
                "discarded": diag.line.discarded,
                "stray": diag.stray,
                "cycles": diag.cycles.cycles,
            }
            cycle_ms = round(diag.cycles.achieved.mean * 1000, 2)
        return {
            "port": self.port,
            "baud": self.baud,
            "demo": self.demo,
            "cycle_ms": cycle_ms,
            "line": line,
            "scanning": self.scan_progress is not None,
            "drives": [self.summary(a) for a in self.addresses()] if self._master else [],
        }

    # -- commands -----------------------------------------------------------------------------
    COMMANDS = ("on", "off1", "off2", "off3", "acknowledge", "jog1", "jog2", "jog_off", "setpoint")
    MOVES = frozenset({"on", "jog1", "jog2", "setpoint"})
    """Commands that can set a motor turning: the page asks before it sends them."""

    async def command(self, address: int, name: str, value: Any = None) -> dict[str, Any]:
        """Send control command ``name`` (see `COMMANDS`); ``setpoint`` takes ``value`` in
        percent or, as ``{"value": v, "unit": u}``, in the reference's unit."""
        drive = self._state(address).drive
        timeout = self.job_timeout
        if name == "on":
            status = await drive.on(timeout=timeout)
        elif name == "off1":
            status = await drive.off1(timeout=timeout)
        elif name == "off2":
            status = await drive.off2(timeout=timeout)
        elif name == "off3":
            status = await drive.off3(timeout=timeout)
        elif name == "acknowledge":
            status = await drive.acknowledge(timeout=timeout)
        elif name in ("jog1", "jog2"):
            status = await drive.jog(int(name[-1]), timeout=timeout)
        elif name == "jog_off":
            status = await drive.jog(None, timeout=timeout)
        elif name == "setpoint":
            percent = self.setpoint_percent(address, value)
            status = await drive.setpoint(percent, timeout=timeout)
        else:
            raise ConfigError(f"unknown command {name!r}: one of {', '.join(self.COMMANDS)}")
        return {"status": status.word, "state": status.state}

    def setpoint_percent(self, address: int, value: Any) -> float:
        """A setpoint the page sends, in percent of the reference (4000h = 100 %, C 5.2.2)."""
        state = self._state(address)
        unit = "%"
        if isinstance(value, dict):
            unit = str(value.get("unit", "%"))
            value = value.get("value")
        if isinstance(value, str):
            try:
                value = float(value.strip())
            except ValueError:
                raise ConfigError(f"setpoint {value!r} is not a number") from None
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ConfigError(f"setpoint {value!r} is not a number")
        if unit != "%":
            if state.reference is None or unit != state.reference.unit:
                raise ConfigError(f"setpoint unit {unit!r}: this drive takes % only")
            value = value / state.reference.reference * 100
        if not -200.0 <= value < 200.0:
            raise ConfigError(f"setpoint {value:g} % is outside -200..200 % (C 5.2.2)")
        return float(value)

    # -- parameters ---------------------------------------------------------------------------
    def parameters(self, address: int) -> list[dict[str, Any]]:
        """The expert list: every parameter (every element of an array) the profile's file
        knows, with its name, unit, type, limits and texts; values come from `read`."""
        state = self._state(address)
        base = state.database.profile.index_base
        rows = []
        for param in state.database:
            indexes: list[int | None] = (
                [None] if param.array is None else list(range(base, base + param.array))
            )
            for index in indexes:
                rows.append(self._row(param, index))
        return rows

    def _row(self, param: Parameter, index: int | None) -> dict[str, Any]:
        numeric = param.dtype.is_integer or param.dtype is DataType.FLOAT
        low = high = None
        if numeric:
            low, high = (self._physical(param, param.low), self._physical(param, param.high))
        return {
            "id": f"{param.pnu}" + ("" if index is None else f".{index}"),
            "pnu": param.pnu,
            "index": index,
            "name": param.name,
            "unit": param.unit,
            "type": param.dtype.label,
            "writable": param.writable and numeric,
            "access": param.access.value,
            "min": low,
            "max": high,
            "texts": {str(k): v for k, v in param.texts.items()},
            "doc": param.doc,
        }

    @staticmethod
    def _physical(param: Parameter, raw: float) -> float:
        if param.scaling:
            return round(raw * param.scaling, max(param.decimals, 0) + 6)
        return raw

    def _param(self, address: int, pnu: int, index: int | None) -> tuple[_DriveState, Parameter]:
        state = self._state(address)
        try:
            param = state.database.parameter(pnu)
        except ParameterFault:
            raise ConfigError(f"P{pnu} is not in the parameter list of drive {address}") from None
        if (param.array is None) != (index is None):
            what = "needs an index" if index is None else "is not an array"
            raise ConfigError(f"P{pnu} {what}")
        return state, param

    async def _read_value(
        self, state: _DriveState, param: Parameter, index: int | None
    ) -> int | float | str | bytes:
        drive = state.drive
        bits, high = drive.profile.encode_pnu(param.pnu)
        if index is None:
            request = Pkw(RequestId.READ_VALUE, bits, high)
        else:
            request = Pkw(RequestId.READ_ARRAY, bits, index | high)
        answer = await drive.job(request, pnu=param.pnu, index=index, timeout=self.job_timeout)
        words = answer.values
        count = param.word_count
        if len(words) > count:
            words = words[-count:]  # a word travels in PWE2 with PKW 4 (C 4.2.3)
        try:
            return param.from_words(words)
        except ParameterFault as exc:
            raise ConfigError(f"P{param.pnu}: the drive's answer does not fit: {exc}") from None

    def format(self, param: Parameter, value: int | float | str | bytes) -> str:
        """A value as the page shows it: scaled, with its unit and value text."""
        if isinstance(value, bytes):
            return value.hex(" ").upper()
        if isinstance(value, str):
            return value.rstrip()
        text = param.texts.get(int(value)) if isinstance(value, int) else None
        if param.dtype is DataType.V2 and isinstance(value, int):
            shown = f"{value:04X}h"
        elif param.scaling:
            shown = _number(value * param.scaling, param.decimals)
        elif isinstance(value, float):
            shown = f"{value:g}"
        else:
            shown = str(value)
        if param.unit:
            shown += f" {param.unit}"
        if text:
            shown += f" ({text.strip()})"
        return shown

    @staticmethod
    def _input(param: Parameter, value: int | float | str | bytes) -> str | None:
        """The value as a user would type it to write it again (None: not editable)."""
        if isinstance(value, float):
            return f"{value:g}"
        if isinstance(value, int):
            return _number(value * param.scaling, param.decimals) if param.scaling else str(value)
        return None

    async def read(
        self, address: int, refs: Sequence[tuple[int, int | None]]
    ) -> list[dict[str, Any]]:
        """Read parameters; each result has ``value`` (the page's text) or ``error``."""
        out: list[dict[str, Any]] = []
        for pnu, index in refs:
            item: dict[str, Any] = {"id": f"{pnu}" + ("" if index is None else f".{index}")}
            try:
                state, param = self._param(address, pnu, index)
                value = await self._read_value(state, param, index)
                item["value"] = self.format(param, value)
                item["input"] = self._input(param, value)
            except UssError as exc:
                item["error"] = _words(exc)
            out.append(item)
        return out

    def parse(self, param: Parameter, text: str) -> int | float:
        """A value the user typed, checked against type and limits before anything is sent:
        a number (with or without the unit), ``0x`` hex, or one of the value texts."""
        if not (param.dtype.is_integer or param.dtype is DataType.FLOAT):
            raise ConfigError(f"P{param.pnu} ({param.dtype.label}) cannot be edited here")
        raw_text = str(text).strip()
        for code, name in param.texts.items():
            if raw_text.lower() == name.strip().lower():
                return code
        body = raw_text
        if param.unit and body.lower().endswith(param.unit.lower()):
            body = body[: -len(param.unit)].strip()
        body = body.removesuffix("h") if re.fullmatch(r"[0-9A-Fa-f]+h", body) else body
        number: float
        try:
            if raw_text.lower().endswith("h") and re.fullmatch(r"[0-9A-Fa-f]+h", raw_text):
                number = int(raw_text[:-1], 16)
            elif body.lower().startswith(("0x", "-0x")):
                number = int(body, 16)
            else:
                number = float(body)
        except ValueError:
            texts = ", ".join(f"{v} = {t.strip()}" for v, t in param.texts.items())
            hint = f" (or one of: {texts})" if texts else ""
            raise ConfigError(f"{text!r} is not a number{hint}") from None
        if not math.isfinite(number):
            raise ConfigError(f"{text!r} is not a finite number")
        if param.dtype is DataType.FLOAT:
            value: int | float = float(number)
        else:
            scaled = number / param.scaling if param.scaling else number
            if abs(scaled - round(scaled)) > 1e-6:
                step = _number(param.scaling or 1, param.decimals)
                raise ConfigError(f"{text!r}: P{param.pnu} takes steps of {step} {param.unit}")
            value = round(scaled)
        try:
            return param.check_write(value)  # type: ignore[return-value]
        except ParameterFault as exc:
            if isinstance(value, int | float):
                low = _number(self._physical(param, param.low), param.decimals)
                high = _number(self._physical(param, param.high), param.decimals)
                unit = f" {param.unit}" if param.unit else ""
                raise ConfigError(
                    f"{text!r} is outside {low}..{high}{unit} for P{param.pnu}"
                ) from None
            raise ConfigError(str(exc)) from None

    async def write(
        self, address: int, pnu: int, index: int | None, text: str, *, eeprom: bool = False
    ) -> dict[str, Any]:
        """Write a typed value (see `parse`); the drive's refusal raises `DriveRefusal`.
        Returns the value read back."""
        state, param = self._param(address, pnu, index)
        if not param.writable:
            raise ConfigError(f"P{pnu} is read-only")
        value = self.parse(param, text)
        if param.dtype is DataType.FLOAT:
            words: tuple[int, ...] = pwe_float(float(value))
        else:
            raw = int(value) & (0xFFFF_FFFF if param.word_count == 2 else 0xFFFF)
            words = pwe_dword(raw) if param.word_count == 2 else pwe_word(raw)
        await state.drive.write_raw(
            pnu,
            words,
            index,
            eeprom=eeprom,
            dword=param.word_count == 2,
            timeout=self.job_timeout,
        )
        (result,) = await self.read(address, [(pnu, index)])
        ref = state.database.roles.get("reference")
        if ref is not None and ref.pnu == pnu:
            await self._read_reference(state)
        return result

    backup_available = False
    """Backup, compare and restore from the page: they use the backup files of `uss backup`
    (`pyuss.params`), which the page does not have yet; the page hides them meanwhile."""

    # -- scan ---------------------------------------------------------------------------------
    async def scan(
        self,
        addresses: Sequence[int],
        bauds: Sequence[int] | None = None,
        *,
        profile: str = "generic",
        progress: Callable[[int, int], None] | None = None,
    ) -> list[dict[str, Any]]:
        """Stop the cyclic traffic, probe ``addresses`` (`pyuss.master.scan`), and go on with
        the drives found (or those of before when none answered)."""
        for address in addresses:
            if not 0 <= address <= MAX_ADDRESS:
                raise ConfigError(f"address {address} is not 0..{MAX_ADDRESS}")
        if self.demo or self._transport is not None:
            bauds = [self.baud]
        bauds = list(bauds or [self.baud])
        if self._lock.locked():
            raise ConfigError("a scan is running already")
        async with self._lock:
            self.scan_progress = (0, 1)

            def tick(done: int, total: int) -> None:
                self.scan_progress = (done, total)
                if progress is not None:
                    progress(done, total)

            await self._stop_master()
            found: list[Found] = []
            try:
                found = await scan(
                    lambda baud: self._scan_transport(baud),
                    bauds,
                    addresses,
                    profile=profile,
                    progress=tick,
                )
            finally:
                if found:
                    self.baud = found[0].baud
                    old = {s.address: s for s in self._specs}
                    self._specs = [
                        DriveSpec(
                            f.address,
                            old[f.address].profile if f.address in old else profile,
                            f.layout,
                        )
                        for f in found
                        if f.baud == self.baud
                    ]
                self.scan_progress = None
                await self._start_master()
        return [f.to_dict() for f in found]

    def _scan_transport(self, baud: int) -> Transport:
        if self.demo:
            station: Transport = self._bus.attach("scanner")
            return station
        if self._transport is not None:
            return self._transport
        from pyuss.transport.url import open_transport

        assert self._url is not None
        return open_transport(self._url, baud=baud)

    # -- monitor ------------------------------------------------------------------------------
    def _publish(self, exchanges: list[Exchange]) -> None:
        for exchange in exchanges:
            self._exchange_seq += 1
            self.exchanges.append((self._exchange_seq, exchange))

    def exchange_dict(self, seq: int, exchange: Exchange) -> dict[str, Any]:
        """One decoded telegram for the page: when, address, kind, problems, the line of
        `uss monitor`."""
        return {
            "seq": seq,
            "time": exchange.time + self._epoch,
            "address": exchange.address,
            "kind": exchange.kind,
            "problems": [p.value for p in exchange.problems],
            "line": exchange_line(exchange, origin=self._epoch, absolute=True),
        }

    @property
    def last_exchange(self) -> int:
        """The number of the newest decoded telegram (they are numbered from 1)."""
        return self._exchange_seq

    def exchanges_since(self, seq: int, limit: int) -> tuple[list[dict[str, Any]], int]:
        """Decoded telegrams numbered above ``seq``, the newest ``limit`` of them, and how
        many newer than ``seq`` were left out."""
        newer = [(n, ex) for n, ex in self.exchanges if n > seq]
        left_out = max(self._exchange_seq - seq - len(newer), 0) + max(len(newer) - limit, 0)
        return [self.exchange_dict(n, ex) for n, ex in newer[-limit:]], left_out

    def _feed(self, port: int, chunk: Chunk) -> None:
        if self._monitor is None:
            return
        out = self._monitor.feed(chunk.data, chunk.timestamp, chunk.errors, port=port)
        if out:
            self._publish(out)

    async def _tick_monitor(self, transport: Transport) -> None:
        """Tell the monitor of the tapped line that time passes (for missing answers)."""
        from pyuss.monitor.live import LAG, TICK

        while not self._stop.is_set():
            await asyncio.sleep(TICK)
            if self._monitor is not None:
                now = transport.clock() - LAG
                out = self._monitor.advance(now, port=0) + self._monitor.advance(now, port=1)
                if out:
                    self._publish(out)

    async def _watch(self, listener: Transport) -> None:
        from pyuss.monitor.live import watch

        assert self._monitor is not None
        try:
            await watch(self._monitor, [listener], self._publish, self._stop)
        finally:
            await listener.close()

    def pcapng(self) -> bytes:
        """The telegrams the monitor view holds, as a pcapng capture (Wireshark)."""
        from pyuss.monitor.capture import open_writer, write_all

        assert self._monitor is not None
        with tempfile.TemporaryDirectory(prefix="pyuss-web-") as folder:
            path = Path(folder) / "line.pcapng"
            writer = open_writer(
                path,
                baud=self.baud,
                four_wire=self._monitor.four_wire,
                epoch=self._epoch,
                gap=self._monitor.gap,
            )
            write_all(writer, (ex for _, ex in list(self.exchanges)))
            return path.read_bytes()


def _words(exc: UssError) -> str:
    """An error in words for the page."""
    return str(exc)
