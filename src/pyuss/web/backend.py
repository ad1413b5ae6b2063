"""The page's one door to the drives: everything `pyuss.web` reads from or sends to a drive
goes through `Backend`, and the drives themselves through the live-drive model `pyuss.points`.

A `Backend` runs one line in cyclic operation on the port given (or, for ``uss web --demo``,
on a virtual bus with the simulated drives of `pyuss.points.simulated_drives`) as a
`pyuss.points.Plant` of one bus: drive states, the samples of every answer for the trend,
commands, setpoints and parameter reads and writes are the points' (`DrivePoints`), checked
there whole before anything goes on the line. What is not live-drive logic stays here: a
`pyuss.monitor.Monitor` that decodes the telegrams on the line (the master's own traffic seen
through `pyuss.web.tap.TapTransport`, or, in the demo, a listen-only station of the virtual
bus), its pcapng capture, the scan (`pyuss.points.scan`), and backups, comparisons and
restores, which are those of ``uss backup``, ``uss diff`` and ``uss restore``
(`pyuss.commission`): one file format, one comparison.

Parameter knowledge (names, units, types, limits, value texts) is each drive's parameter book
(`pyuss.params.ParamBook`); values are parsed, checked and shown through `pyuss.params`.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import tempfile
import time
from collections import deque
from collections.abc import Awaitable, Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pyuss.commission import backup as backups
from pyuss.commission.compare import (
    Outcome,
    Skip,
    Write,
    another_drive,
    compare,
    plan,
    restore,
)
from pyuss.commission.sources import check as check_sources
from pyuss.errors import ConfigError, UssError, cut
from pyuss.monitor.core import Monitor, default_gap
from pyuss.monitor.infer import LayoutBook
from pyuss.monitor.model import Exchange
from pyuss.monitor.render import exchange_line
from pyuss.params import ParamBook, ParamInfo, format_value
from pyuss.params.model import Reading
from pyuss.params.values import physical
from pyuss.params.words import WordKind, format_word
from pyuss.points import (
    COMMAND_TABLE,
    MOVES,
    Drive,
    DrivePoints,
    DriveState,
    Found,
    Plant,
    ProcessValue,
    Sample,
    line_model,
    scan,
    simulated_drives,
)
from pyuss.points.view import (
    command_outcome,
    fault_panel,
    key_actuals,
    motion,
    read_key_actuals,
    setpoint_refusal,
)
from pyuss.profiles import Profile, get_profile, profile_names
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pzd import STATUS_BITS
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
LINE = "page"
"""The name of the page's one bus in its `pyuss.points.Plant`."""

Progress = Callable[[int, int, str], object]
Approve = Callable[[list[dict[str, Any]]], object]
"""Told the writes a restore is about to make (as a comparison lists them), before the
first: it raises to write nothing (the person said yes to another list)."""
"""``progress(done, total, label)`` of a backup, compare or restore."""


@dataclass(frozen=True, slots=True)
class DriveSpec:
    """A drive the page works with: its address, profile (None: of unknown kind, no family's
    facts) and telegram layout."""

    address: int
    profile: str | None = None
    layout: Layout | None = None

    def __post_init__(self) -> None:
        if not 0 <= self.address <= MAX_ADDRESS:
            raise ConfigError(f"address {self.address} is not 0..{MAX_ADDRESS}")
        if self.profile is not None and self.profile not in profile_names():
            try:
                get_profile(self.profile)  # NAME@EDITION
            except ConfigError:
                raise ConfigError(
                    f"profile {self.profile!r} is not one of {', '.join(profile_names())}"
                ) from None


DEMO_DRIVES: tuple[DriveSpec, ...] = (
    DriveSpec(1, "generic", Layout(PKW_VARIABLE, 2)),
    DriveSpec(4, "baumueller", Layout(3, 2)),
    DriveSpec(7, "micromaster440", Layout(PKW_VARIABLE, 2)),
    DriveSpec(9, "sinamics-v20", Layout(PKW_VARIABLE, 2)),
)
"""The simulated drives of ``uss web --demo``: a generic drive, a Baumueller drive with the
fixed layout 3,2 (PKW 3), a MICROMASTER 440 and a SINAMICS V20."""


class Backend:
    """The drives of one line for the page (see the module text).

    ``port``: a URL for `pyuss.transport.open_transport`, or None with ``demo=True``.
    ``drives``: the drives to work with (the demo's own when empty in the demo).
    """

    COMMANDS = (*COMMAND_TABLE, "setpoint")
    """The page's commands: the points' table and a new main setpoint."""
    MOVES = MOVES | {"setpoint"}
    """Commands that can set a motor turning: the page asks before it sends them."""

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
        self._drives: dict[int, DrivePoints] = {}
        self._plant: Plant | None = None
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
        self._sent: dict[int, dict[str, Any]] = {}
        self.lost = asyncio.Event()
        """Set when the line is lost for good: its port failed and is not reopened
        (``reconnect=0`` in its URL); `uss web` then stops."""

    # -- life cycle ---------------------------------------------------------------------------
    async def start(self) -> None:
        try:
            await self._open()
        except BaseException:
            await self.close()
            raise

    async def _open(self) -> None:
        if self.demo:
            from pyuss.bus import VirtualBus

            # The simulated drives share the event loop with the page; a busy moment makes
            # them complain about their own answer times, which is not the point here.
            logging.getLogger("pyuss.slave").setLevel(logging.ERROR)
            self._bus = VirtualBus(DEMO_BAUD)
            self._stack.push_async_callback(self._bus.close)
            self.engines = await self._stack.enter_async_context(
                simulated_drives(
                    self._bus, [(s.address, s.profile or "generic", s.layout) for s in DEMO_DRIVES]
                )
            )
        await self._start_master()

    def _new_transport(self) -> Transport:
        if self.demo:
            station: Transport = self._bus.attach("master")
            return station
        if self._transport is not None:
            return self._transport
        from pyuss.transport.url import open_transport

        assert self._url is not None
        return open_transport(self._url, baud=self.baud, reconnect=True)

    async def _start_master(self) -> None:
        self._stop = asyncio.Event()
        layouts = {s.address: s.layout for s in self._specs if s.layout is not None}
        rx_tolerance: float | None = None
        if self.demo:
            self._monitor = Monitor(
                self.baud,
                layouts=LayoutBook(per_address=layouts),
                gap=default_gap(self.baud),
            )
            listener = self._bus.attach("page-monitor", listen_only=True)
            await listener.open()
            self._monitor_task = asyncio.create_task(self._watch(listener))
            transport = self._new_transport()
        else:
            inner = self._new_transport()
            self._monitor = Monitor(
                self.baud,
                four_wire=True,
                layouts=LayoutBook(per_address=layouts),
                gap=default_gap(self.baud),
                tolerance=stamp_tolerance(inner),
            )
            transport = TapTransport(inner, self._feed)
            rx_tolerance = 0.0 if inner.exact_timestamps else None
            self._monitor_task = asyncio.create_task(self._tick_monitor(transport))
        self._epoch = time.time() - transport.clock()
        model = line_model(
            LINE,
            [(s.address, s.profile, s.layout) for s in self._specs],
            baud=transport.baud,
            job_timeout=self.job_timeout,
        )
        plant = Plant(
            model,
            transports={LINE: transport},
            close_transports=not (self._transport is not None and not self.demo),
            rx_tolerance=rx_tolerance,
        )
        for points in plant.drives:
            points.keep_samples(SAMPLE_BUFFER)
        plant.bus(LINE).subscribe(lambda state: self.lost.set() if state.lost else None)
        await plant.start()
        self._plant = plant
        self._drives = {points.address: points for points in plant.drives}
        for points in self._drives.values():
            # the reference (100 % of PZD2) for values in units, before the page asks
            with contextlib.suppress(UssError):
                await points.read_reference()

    async def _stop_master(self) -> None:
        self._stop.set()
        if self._plant is not None:
            await self._plant.close()
            self._plant = None
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

    def _line(self) -> Plant:
        if self._plant is None or self.scan_progress is not None:
            raise ConfigError("the line is busy (a scan is running)")
        return self._plant

    # -- the drives' points -------------------------------------------------------------------
    def points(self, address: int) -> DrivePoints:
        """The live points of drive ``address`` (`pyuss.points.DrivePoints`)."""
        self._line()
        try:
            return self._drives[address]
        except KeyError:
            raise ConfigError(f"drive {cut(address)} is not on the page") from None

    def take_samples(self) -> dict[int, list[Sample]]:
        """The samples of every drive since the last call (at most `SAMPLE_BUFFER` each):
        the process data of every answer, actual values in the units `drive_info` names."""
        out = {}
        for address, points in self._drives.items():
            taken = points.take_samples()
            if taken:
                out[address] = taken
        return out

    def addresses(self) -> list[int]:
        return sorted(self._drives)

    def drive_info(self, address: int) -> dict[str, Any]:
        """What does not change: profile, layout, the status bits' meanings, the actual
        values' names and units."""
        points = self.points(address)
        named = points.model.profile is not None
        profile = get_profile(points.model.profile or "generic")  # the telegram rules
        layout = points.model.layout
        reference = points.reference
        return {
            "address": address,
            "profile": profile.name if named else backups.UNKNOWN_KIND,
            "title": profile.title if named else "a drive of unknown kind",
            "layout": str(layout),
            "pzd": layout.pzd,
            "reference": (
                {"value": reference, "unit": points.model.unit} if reference is not None else None
            ),
            "actuals": points.actual_columns(),
            "key_actuals": key_actuals(points),
            "status_bits": _status_bits(profile.status_bits if named else {}),
        }

    def summary(self, address: int) -> dict[str, Any]:
        """State, fault, communication health of one drive (A 5.2.3 counters included). A
        drive that does not send (A 5.2.1.1) shows no status word, state, fault or actual
        value: its last answer is not what it is now."""
        points = self.points(address)
        state = points.snapshot()
        failed = self._line_failed()
        live = state.online and failed is None
        diagnostics = points.drive.diagnostics()
        counters = diagnostics.counters
        return {
            "address": address,
            "profile": points.model.profile or backups.UNKNOWN_KIND,
            "layout": str(points.model.layout),
            "not_sending": state.health.not_sending or failed is not None,
            "offline": failed,
            "control": state.control_word,
            "control_in_force": _control_in_force(points) if live else None,
            "setpoints": list(state.setpoint_words),
            "status": state.status_word if live else None,
            "state": failed
            or (state.state if live else motion(state) if state.answered else "no answer yet"),
            "motion": failed or motion(state),
            "setpoint": _setpoint_in_force(state),
            "sent_setpoint": self._sent.get(address),
            "fault": live and state.fault,
            "warning": live and state.warning,
            "actual": list(points.actual_row(state.actual_words)) if live else [],
            "actual_unit": points.model.unit if points.reference is not None else "%",
            **_word_texts(
                state.control_word,
                _control_in_force(points) if live else None,
                state.status_word if live else None,
                get_profile(points.model.profile) if points.model.profile is not None else None,
            ),
            "health": {
                "exchanges": diagnostics.exchanges,
                "answers": diagnostics.answers,
                "timeouts": diagnostics.timeouts,
                "late": diagnostics.late,
                "response_ms": round(diagnostics.response_time.median * 1000, 3),
                "jobs": diagnostics.jobs.completed,
                "refused": diagnostics.jobs.refused,
                "counters": {
                    **counters.counts(),
                    "error_status": int(counters.error_status),
                },
            },
        }

    def _line_failed(self) -> str | None:
        """Why no drive of the line answers: its master stopped (the port failed, a TCP
        adapter went away with ``reconnect=0``) or its port is lost and being reopened; None
        while the master exchanges on the line."""
        plant = self._plant
        if plant is None:
            return None
        bus = plant.bus(LINE)
        if not bus.master.running:
            return f"the line failed: {self.port} is closed or gone (the log says why)"
        if not bus.online:
            return f"the line is down: {self.port} is being reopened"
        return None

    def setpoint_value(self, address: int) -> float | None:
        """The main setpoint sent to drive ``address`` now, in the unit of its main actual
        value (`pyuss.points.DrivePoints.setpoint_value`)."""
        return self.points(address).setpoint_value()

    def motion(self, address: int) -> str:
        """The ramp state of drive ``address`` now (`pyuss.points.view.motion`)."""
        return motion(self.points(address).snapshot())

    def bus(self) -> dict[str, Any]:
        """The line: port, baud rate, the drives and the line's own counters."""
        line: dict[str, Any] = {}
        cycle_ms = 0.0
        if self._plant is not None:
            diag = self._plant.bus(LINE).master.diagnostics()
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
            "drives": [self.summary(a) for a in self.addresses()] if self._plant else [],
        }

    # -- commands -----------------------------------------------------------------------------
    def check(self, address: int, name: object, value: object = None) -> dict[str, Any]:
        """Command ``name`` checked whole as `command` would send it, with the words a page
        asks a person with (``text``); nothing is sent. `ConfigError` if it would be refused."""
        points = self.points(address)
        if name == "setpoint":
            checked = self._setpoint(points, value)
            return {
                "name": name,
                "setpoint": checked.to_dict(),
                "text": f"set the setpoint to {_setpoint_text(checked, _unit_given(value))}",
            }
        if not isinstance(name, str) or name not in COMMAND_TABLE:
            raise ConfigError(f"unknown command {cut(name)}: one of {', '.join(self.COMMANDS)}")
        return {"name": name, "text": name}

    @staticmethod
    def _setpoint(points: DrivePoints, value: object) -> ProcessValue:
        """A setpoint the page sends: a number in percent, or ``{"value": v, "unit": u}``
        with ``u`` ``%`` or the reference's unit; checked by the points."""
        unit: object = "%"
        if isinstance(value, dict):
            if set(value) - {"value", "unit"}:
                raise ConfigError('a setpoint is a number or {"value": v, "unit": u}')
            unit = value.get("unit", "%")
            value = value.get("value")
        unit_text = unit if isinstance(unit, str) else repr(unit)
        refusal = setpoint_refusal(points, value, unit_text)
        if refusal is not None:
            raise ConfigError(refusal)
        return points.check_setpoint(value, unit=unit_text)

    async def command(self, address: int, name: object, value: object = None) -> dict[str, Any]:
        """Send control command ``name`` (see `COMMANDS`); ``setpoint`` takes ``value`` in
        percent or, as ``{"value": v, "unit": u}``, in the reference's unit. Checked whole
        first (`check`): a refused command sends nothing."""
        points = self.points(address)
        self.check(address, name, value)
        before = points.snapshot()
        if name == "setpoint":
            checked = self._setpoint(points, value)
            state = await points.set_setpoint(checked.raw, unit="raw", timeout=self.job_timeout)
            shown = _setpoint_text(checked, _unit_given(value))
            self._sent[address] = {"value": _number_given(value), "unit": _unit_given(value)}
            return {
                "command": name,
                "taken": True,
                "text": f"Setpoint {shown} is in force (the drive answered the telegram).",
                "status": state.status_word,
                "state": state.state,
                "motion": motion(state),
                "setpoint": _setpoint_in_force(state),
            }
        assert isinstance(name, str)
        await points.command(name, timeout=self.job_timeout)
        outcome = await command_outcome(points, name, before)
        return outcome.to_dict()

    def sent_setpoint(self, address: int) -> dict[str, Any] | None:
        """The setpoint this page last sent to drive ``address`` as it was typed (None: none
        sent yet)."""
        self.points(address)
        return self._sent.get(address)

    async def key_actuals(self, address: int) -> dict[str, Any]:
        """The family's key actual values of drive ``address`` read now through the parameter
        channel (`pyuss.points.view.read_key_actuals`), with the time of the reading."""
        points = self.points(address)
        values = await read_key_actuals(points, timeout=self.job_timeout)
        return {"time": time.time(), "values": values}

    async def faults(self, address: int) -> dict[str, Any]:
        """The fault and warning panel of drive ``address`` (`pyuss.points.view.fault_panel`):
        the active fault and warning, the fault history and the warning numbers with the
        family's texts, where its parameter file has them."""
        return await fault_panel(self.points(address), timeout=self.job_timeout)

    async def sources(self, address: int) -> dict[str, Any]:
        """Whether drive ``address`` follows the control word and setpoint of USS (its command
        and setpoint sources, P0700/P1000, read now; `pyuss.commission.sources`)."""
        drive = self.points(address).drive
        return (await check_sources(drive, timeout=self.job_timeout)).to_dict()

    # -- parameters ---------------------------------------------------------------------------
    def parameters(self, address: int) -> list[dict[str, Any]]:
        """The expert list: every parameter (every element of an array) the drive's parameter
        book knows (`pyuss.params.ParamBook`: the user's file, the drive's descriptions, the
        profile's file), with its name, unit, type, limits and texts; values come from `read`."""
        drive = self.points(address).drive
        book = drive.params
        rows = []
        for info in book:
            indexes: list[int | None] = [None] if info.array is None else list(book.indices(info))
            needs = backups.beyond_layout(drive.layout, info)
            for index in indexes:
                row = _row(info, index)
                if needs is not None:
                    row.update(needs=needs, writable=False)
                rows.append(row)
        return rows

    async def read(
        self, address: int, refs: Sequence[tuple[int, int | None]]
    ) -> list[dict[str, Any]]:
        """Read parameters, typed by the drive's book; each result has ``value`` (the value as
        printed: ``10.00 s``, ``1 [READY]``) and ``input`` (as a user types it), or
        ``error``."""
        points = self.points(address)

        async def read(pnu: int, index: int | None) -> Reading:
            return await points.read_value(pnu, index, timeout=self.job_timeout)

        return await read_rows(refs, points.drive.layout, points.drive.params, read)

    async def write(
        self, address: int, pnu: int, index: int | None, text: str, *, eeprom: bool = False
    ) -> dict[str, Any]:
        """Write a value as the user typed it (``2.5``, ``2.5 s``, ``0x7000``, a value text):
        checked by the points against the parameter's type, limits and access before anything
        is sent (`DrivePoints.write_value`); the drive's refusal raises `DriveRefusal`.
        Returns the value the drive answered with, as `read` does, and ``written``, the value
        written, where the drive answered another (it limits or rounds)."""
        drive = self.points(address).drive
        needs = backups.beyond_layout(drive.layout, drive.params.get(pnu))
        if needs is not None:
            raise ConfigError(f"{_label(pnu, index)} cannot be written: {needs}")
        reading = await self.points(address).write_value(
            pnu, index, text, eeprom=eeprom, timeout=self.job_timeout
        )
        shown = {"id": _id(pnu, index), **_shown_reading(reading)}
        if reading.differs:  # the drive limited or rounded it: it holds what it answered
            shown["written"] = reading.written_text()
        return shown

    # -- backup, compare, restore -------------------------------------------------------------
    async def backup(
        self, address: int, fmt: str = "toml", progress: Progress | None = None
    ) -> tuple[str, str]:
        """A backup of the drive's parameter set (`pyuss.commission.take`) as the text of a
        backup file (TOML, JSON or the CSV export, `pyuss.commission.backup.dumps`) and the
        file's name: ``drive1-generic-20250314-092653.toml``."""
        drive = self.points(address).drive
        if fmt not in backups.FORMATS:
            raise ConfigError(f"backup format {fmt!r}: one of {', '.join(backups.FORMATS)}")
        taken = await backups.take(drive, port=self.port, progress=progress)
        text = backups.dumps(taken, fmt)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        return f"drive{address}-{taken.profile}-{stamp}.{fmt}", text

    async def _wanted_and_now(
        self, address: int, data: bytes, name: str, progress: Progress | None
    ) -> tuple[Drive, backups.Backup, backups.Backup]:
        drive = self.points(address).drive
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            raise ConfigError(f"{name}: not a text file (a backup is TOML or JSON)") from None
        wanted = backups.loads(text, name)
        wanted_refs = [(e.pnu, e.index) for e in wanted.entries]
        entries = await backups.read_parameters(drive, wanted_refs, progress=progress)
        now = backups.Backup(address, backups.kind_of(drive), entries, source=f"drive {address}")
        return drive, wanted, now

    async def _stranger(self, wanted: backups.Backup, drive: Drive) -> str | None:
        if wanted.profile != backups.kind_of(drive):
            return (
                f"{wanted.source} is a backup of a {wanted.profile} drive, drive "
                f"{drive.address} is {backups.kind_of(drive)}"
            )
        return await another_drive(wanted, drive)

    async def compare(
        self, address: int, data: bytes, name: str, progress: Progress | None = None
    ) -> dict[str, Any]:
        """The drive compared with an uploaded backup file (`pyuss.commission.compare`): what
        differs, with names and units, what a restore would write and leave out, and why the
        file may be another drive's (``stranger``) or cannot be restored (``refused``)."""
        drive, wanted, now = await self._wanted_and_now(address, data, name, progress)
        stranger = await self._stranger(wanted, drive)
        return compared(name, wanted, now, drive.params, _named(drive), stranger)

    async def restore(
        self,
        address: int,
        data: bytes,
        name: str,
        *,
        force: bool = False,
        eeprom: bool = False,
        progress: Progress | None = None,
        approve: Approve | None = None,
    ) -> dict[str, Any]:
        """Write an uploaded backup file back (`pyuss.commission.plan` and ``restore``): only
        the writable parameters that differ, in the profile's order, each value checked first
        (a value the parameter cannot take refuses the whole file before anything is
        written). A file of another profile or drive needs ``force``. Each refusal of the
        drive comes back with its number and meaning; the others are still written."""
        drive, wanted, now = await self._wanted_and_now(address, data, name, progress)
        stranger = await self._stranger(wanted, drive)
        if stranger is not None and not force:
            raise ConfigError(stranger)
        writes, skips = plan(wanted, now, drive.params, _named(drive))
        if approve is not None:
            approve(planned(writes))
        outcomes = await restore(drive, writes, eeprom=eeprom, progress=progress)
        points = self.points(address)
        if any(o.ok and points.is_reference(o.write.pnu, o.write.index) for o in outcomes):
            with contextlib.suppress(UssError):
                await points.read_reference()
        return restored(f"drive {address}", name, writes, skips, outcomes, eeprom=eeprom)

    # -- scan ---------------------------------------------------------------------------------
    async def scan(
        self,
        addresses: Sequence[int],
        bauds: Sequence[int] | None = None,
        *,
        profile: str | None = None,
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
            self.scan_progress = (0, 1)  # the line is busy: nothing new is sent from here on
            try:
                self._check_all_off()
            except ConfigError:
                self.scan_progress = None
                raise

            def tick(done: int, total: int) -> None:
                self.scan_progress = (done, total)
                if progress is not None:
                    progress(done, total)

            await self._stop_master()
            found: list[Found] = []
            cut_off = False
            try:
                found = await scan(
                    lambda baud: self._scan_transport(baud),
                    bauds,
                    addresses,
                    profile=profile,
                    progress=tick,
                )
            except asyncio.CancelledError:
                cut_off = True  # the page stops (Ctrl+C): nothing more goes on the line
                raise
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
                if not cut_off:
                    await self._start_master()
        return [f.to_dict() for f in found]

    def _check_all_off(self) -> None:
        """A scan stops the cyclic telegrams, and with them every way of stopping a drive from
        the page, and its drives start again switched off: refused while a drive is told to
        run or, answering, runs (`DriveState.told_to_run`)."""
        for address, points in sorted(self._drives.items()):
            if points.snapshot().told_to_run:
                raise ConfigError(
                    f"drive {address} is switched on: switch it off before a scan (the scan "
                    "stops the telegrams to every drive, and with them the page's control)"
                )

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
        item: dict[str, Any] = {"id": _id(pnu, index)}
        needs = backups.beyond_layout(layout, book.get(pnu))
        if needs is not None:
            out.append({**item, "needs": needs})
            continue
        try:
            reading = await read(pnu, index)
        except UssError as exc:
            item["error"] = str(exc)
        else:
            item.update(_shown_reading(reading))
        out.append(item)
    return out


def compared(
    name: str,
    wanted: backups.Backup,
    now: backups.Backup,
    book: ParamBook,
    profile: Profile | None,
    stranger: str | None,
) -> dict[str, Any]:
    """A comparison as the page shows it: the differences of the drive (``now``) and the
    file ``name`` (``wanted``) with names and units, what a restore would write and leave out,
    why the file may be another drive's (``stranger``) or cannot be restored (``refused``)."""
    differences = []
    for diff in compare(now, wanted):
        info = book.get(diff.pnu)
        differences.append(
            {
                "id": _id(diff.pnu, diff.index),
                "label": diff.label,
                "name": diff.name,
                "drive": None if diff.left is None else diff.left.text(info),
                "file": None if diff.right is None else diff.right.text(info),
            }
        )
    reply: dict[str, Any] = {
        "file": name,
        "address": wanted.address,
        "profile": wanted.profile,
        "date": wanted.date,
        "differences": differences,
        "writes": [],
        "skipped": [],
        "stranger": stranger,
        "refused": None,
    }
    try:
        writes, skips = plan(wanted, now, book, profile)
    except ConfigError as exc:
        reply["refused"] = str(exc)
    else:
        reply["writes"] = planned(writes)
        reply["skipped"] = [_skip_dict(s) for s in skips]
    return reply


def restored(
    drive: str,
    name: str,
    writes: Sequence[Write],
    skips: Sequence[Skip],
    outcomes: Sequence[Outcome],
    *,
    eeprom: bool,
) -> dict[str, Any]:
    """A restore of file ``name`` to ``drive`` (``drive 5``) as the page shows it: how many
    were written and refused, each write's result, what was left out."""
    failed = [o for o in outcomes if not o.ok]
    stored = " and stored in EEPROM" if eeprom else ""
    message = f"{drive}: {len(outcomes) - len(failed)} of {len(outcomes)} written{stored}" + (
        f", {len(failed)} refused" if failed else ""
    )
    if not writes:
        message = f"{drive} already holds {name}: nothing to write"
    return {
        "message": message,
        "written": len(outcomes) - len(failed),
        "refused": len(failed),
        "results": [
            {
                **_write_dict(o.write),
                "ok": o.ok,
                "answer": o.answer,
                "error": o.error_text() or None,
            }
            for o in outcomes
        ],
        "skipped": [_skip_dict(s) for s in skips],
    }


def _skip_dict(skip: Skip) -> dict[str, Any]:
    return {"label": skip.entry.label, "name": skip.entry.name, "reason": skip.reason}


def _unit_given(value: object) -> object:
    return value.get("unit", "%") if isinstance(value, dict) else "%"


def _setpoint_text(checked: ProcessValue, given: object) -> str:
    """A checked setpoint as a page asks about it, first in the unit it was ``given`` in:
    ``10 Hz (20 % of the reference)``, ``40 % (20 Hz)``."""
    percent = f"{round(checked.percent, 2):g} %"
    if checked.unit == "%" or checked.value is None:
        return percent
    value = f"{round(checked.value, 2):g} {checked.unit}"
    if given == checked.unit:
        return f"{value} ({percent} of the reference)"
    return f"{percent} ({value})"


def _named(drive: Drive) -> Profile | None:
    """The drive's profile where one is named; None for a drive of unknown kind."""
    return drive.profile if drive.profile_named else None


def _status_bits(family: Mapping[int, str]) -> list[dict[str, Any]]:
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


def _word_texts(
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


def _control_in_force(points: DrivePoints) -> int | None:
    """The control word of the request the drive's last answer answered."""
    status = points.drive.status
    return None if status is None else status.control


def _number_given(value: object) -> object:
    return value.get("value") if isinstance(value, dict) else value


def _setpoint_in_force(state: DriveState) -> dict[str, Any] | None:
    """The main setpoint the drive is sent now (percent, and in units where known)."""
    value = state.setpoints.get("main") or next(iter(state.setpoints.values()), None)
    return None if value is None else value.to_dict()


def _label(pnu: int, index: int | None) -> str:
    return f"P{_id(pnu, index)}"


def _id(pnu: int, index: int | None) -> str:
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


def _row(info: ParamInfo, index: int | None) -> dict[str, Any]:
    """One row of the expert list."""
    low, high = _limits(info)
    numeric = info.is_numeric and not info.is_bit_field
    allowed = [_shown_raw(info, a) for a in info.allowed or ()] if numeric else []
    return {
        "id": _id(info.pnu, index),
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


def _shown_reading(reading: Reading) -> dict[str, Any]:
    """``value`` as printed (``10.00 s``, ``1 [READY]``) and ``input`` (see `_input`)."""
    return {
        "value": format_value(reading.info, reading.value),
        "input": _input(reading),
    }


def planned(writes: Sequence[Write]) -> list[dict[str, Any]]:
    """The writes of a restore as a comparison lists them and a person says yes to."""
    return [_write_dict(w) for w in writes]


def _write_dict(write: Write) -> dict[str, Any]:
    return {
        "id": _id(write.pnu, write.index),
        "label": write.label,
        "name": write.info.name if write.info is not None else "",
        "change": write.text(),
    }
