"""The page's one door to the drives of a line: everything `pyuss.web` reads from or sends to
a drive goes through `Backend`, and the drives themselves through the live-drive model
`pyuss.points`.

A `Backend` runs one line in cyclic operation on the port given (or, for ``uss web --demo``,
on a virtual bus with the simulated drives of `pyuss.points.simulated_drives`) as a
`pyuss.points.Plant` of one bus: drive states, the samples of every answer for the trend,
commands, setpoints and parameter reads and writes are the points' (`DrivePoints`), checked
there whole before anything goes on the line. What is not live-drive logic stays here:
the master's life cycle on the line, the scan (`pyuss.points.scan`), which stops it and goes
on with the drives found, and the wiring of the page's other rooms: the monitor view
(`pyuss.web.telegrams`: the telegrams on the line, decoded, and their pcapng capture),
backups, comparisons and restores (`pyuss.web.files`, those of ``uss backup``, ``uss diff``
and ``uss restore``) and how values and parameters are shown (`pyuss.web.shown`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pyuss.commission import backup as backups
from pyuss.commission.compare import (
    plan,
    restore,
)
from pyuss.commission.sources import check as check_sources
from pyuss.errors import ConfigError, UssError, cut
from pyuss.params.model import Reading
from pyuss.points import (
    COMMAND_TABLE,
    MOVES,
    Drive,
    DrivePoints,
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
from pyuss.protocol.telegram import MAX_ADDRESS
from pyuss.transport.base import Transport
from pyuss.web.files import Approve, Progress, compared, planned, restored, stranger, wanted_and_now
from pyuss.web.shown import (
    control_in_force,
    expert_row,
    number_given,
    param_id,
    param_label,
    read_rows,
    setpoint_in_force,
    setpoint_text,
    shown_reading,
    status_bits,
    unit_given,
    word_texts,
)
from pyuss.web.telegrams import LineTelegrams

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
LINE = "page"
"""The name of the page's one bus in its `pyuss.points.Plant`."""


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
        self.telegrams = LineTelegrams()
        """The monitor view: the line's telegrams, decoded."""
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

    def _new_transport(self, station: str = "master", baud: int | None = None) -> Transport:
        """The master's transport (reopened when lost), or the scan's at ``baud`` (not)."""
        if self.demo:
            attached: Transport = self._bus.attach(station)
            return attached
        if self._transport is not None:
            return self._transport
        from pyuss.transport.url import open_transport

        assert self._url is not None
        return open_transport(self._url, baud=baud or self.baud, reconnect=baud is None)

    async def _start_master(self) -> None:
        layouts = {s.address: s.layout for s in self._specs if s.layout is not None}
        rx_tolerance: float | None = None
        if self.demo:
            listener = self._bus.attach("page-monitor", listen_only=True)
            await self.telegrams.listen(listener, self.baud, layouts)
            transport = self._new_transport()
        else:
            inner = self._new_transport()
            transport = self.telegrams.tap(inner, self.baud, layouts)
            rx_tolerance = 0.0 if inner.exact_timestamps else None
        self.telegrams.epoch = time.time() - transport.clock()
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
        self.telegrams.stop.set()
        if self._plant is not None:
            await self._plant.close()
            self._plant = None
        await self.telegrams.close()
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
            "status_bits": status_bits(profile.status_bits if named else {}),
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
            "control_in_force": control_in_force(points) if live else None,
            "setpoints": list(state.setpoint_words),
            "status": state.status_word if live else None,
            "state": failed
            or (state.state if live else motion(state) if state.answered else "no answer yet"),
            "motion": failed or motion(state),
            "setpoint": setpoint_in_force(state),
            "sent_setpoint": self._sent.get(address),
            "fault": live and state.fault,
            "warning": live and state.warning,
            "actual": list(points.actual_row(state.actual_words)) if live else [],
            "actual_unit": points.model.unit if points.reference is not None else "%",
            **word_texts(
                state.control_word,
                control_in_force(points) if live else None,
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
                "text": f"set the setpoint to {setpoint_text(checked, unit_given(value))}",
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
            shown = setpoint_text(checked, unit_given(value))
            self._sent[address] = {"value": number_given(value), "unit": unit_given(value)}
            return {
                "command": name,
                "taken": True,
                "text": f"Setpoint {shown} is in force (the drive answered the telegram).",
                "status": state.status_word,
                "state": state.state,
                "motion": motion(state),
                "setpoint": setpoint_in_force(state),
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
                row = expert_row(info, index)
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
            raise ConfigError(f"{param_label(pnu, index)} cannot be written: {needs}")
        reading = await self.points(address).write_value(
            pnu, index, text, eeprom=eeprom, timeout=self.job_timeout
        )
        shown = {"id": param_id(pnu, index), **shown_reading(reading)}
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
    ) -> tuple[Drive, backups.Backup, backups.Backup, str | None]:
        """The drive, the uploaded file, the drive's values of its parameters, and why the
        file may be another drive's (`pyuss.web.files.stranger`)."""
        drive = self.points(address).drive
        kind = backups.kind_of(drive)
        wanted, now = await wanted_and_now(
            drive, data, name, address=address, kind=kind, source=f"drive {address}",
            progress=progress,
        )  # fmt: skip
        return drive, wanted, now, await stranger(wanted, drive, kind=kind, who=str(address))

    async def compare(
        self, address: int, data: bytes, name: str, progress: Progress | None = None
    ) -> dict[str, Any]:
        """The drive compared with an uploaded backup file (`pyuss.commission.compare`): what
        differs, with names and units, what a restore would write and leave out, and why the
        file may be another drive's (``stranger``) or cannot be restored (``refused``)."""
        drive, wanted, now, other = await self._wanted_and_now(address, data, name, progress)
        return compared(name, wanted, now, drive.params, _named(drive), other)

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
        drive, wanted, now, other = await self._wanted_and_now(address, data, name, progress)
        if other is not None and not force:
            raise ConfigError(other)
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
                    lambda baud: self._new_transport("scanner", baud),
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

    # -- monitor ------------------------------------------------------------------------------
    @property
    def last_exchange(self) -> int:
        """The number of the newest decoded telegram (they are numbered from 1)."""
        return self.telegrams.newest

    def exchanges_since(self, seq: int, limit: int) -> tuple[list[dict[str, Any]], int]:
        """Decoded telegrams numbered above ``seq``, the newest ``limit`` of them, and how
        many newer than ``seq`` were left out (`LineTelegrams.since`)."""
        return self.telegrams.since(seq, limit)

    def pcapng(self) -> bytes:
        """The telegrams the monitor view holds, as a pcapng capture (Wireshark)."""
        return self.telegrams.pcapng(self.baud)


def _named(drive: Drive) -> Profile | None:
    """The drive's profile where one is named; None for a drive of unknown kind."""
    return drive.profile if drive.profile_named else None
