"""The page over the broker (``uss web --mqtt``): every bus and drive that ``uss gateway``
processes publish on one MQTT broker, with the surface of `pyuss.web.backend.Backend` that
the server uses, so that one page and one server serve a line or a plant.

Drives are named ``BUS.ADDRESS`` (``line2.5``) in the page and its URLs
(``/api/drive/line2.5``); a local page's ``/api/drive/5`` is the local `Backend`'s. What the
page shows comes from the gateways' messages (`pyuss.plant.remote.RemotePlant`): the bus view
groups the drives by gateway with availability and latency; the drive view, its trend and
status come from the drives' states. Commands, parameters, backups, comparisons and restores
go to the gateways as requests with a reply (`RemotePlant.request`, `RemoteParams`), checked
here first with the local page's own checks - the command table, the setpoint check and its
refusal texts (`Backend.check`, `pyuss.points.view.setpoint_refusal`), the parameter's type,
limits and access (`pyuss.params.parse`) - and again by the gateway. A drive whose gateway is
offline shows no live value and takes no command; a read-only gateway's drives take none and
the page says why. The scan and the telegram monitor need the line itself: they are not
available over the broker.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Sequence
from typing import Any, cast

from pyuss.commission import backup as backups
from pyuss.commission.compare import plan, restore
from pyuss.commission.sources import check as check_sources
from pyuss.errors import ConfigError, UssError
from pyuss.params import parse
from pyuss.plant.remote import GatewayRefusal, RemoteDrive, RemoteParams, RemotePlant
from pyuss.points import COMMAND_TABLE, Sample
from pyuss.points.checks import checked_setpoint
from pyuss.points.state import ProcessValue, state_name
from pyuss.points.view import KEY_ACTUALS, TAKE_TIME, fault_history, key_actual, motion_of
from pyuss.protocol.pzd import StatusWord
from pyuss.web.backend import Backend
from pyuss.web.files import Approve, Progress, compared, planned, restored, stranger, wanted_and_now
from pyuss.web.shown import (
    expert_row,
    param_id,
    param_label,
    read_rows,
    setpoint_text,
    shown_reading,
    status_bits,
    unit_given,
    word_texts,
)

__all__ = ["PlantBackend"]

GATEWAY_COMMANDS = frozenset({"on", "off1", "off2", "off3", "acknowledge"})
"""The drive commands of the gateway's MQTT contract (the page's jog commands are not)."""
NOT_OVER_MQTT = "not available over the broker: it needs the line itself (uss web --port)"


def _running(state: dict[str, Any]) -> bool:
    word = state.get("status_word")
    return isinstance(word, int) and bool(word & StatusWord.OPERATION_ENABLED)


def _cleared(bit: StatusWord) -> Callable[[dict[str, Any]], bool]:
    def goal(state: dict[str, Any]) -> bool:
        word = state.get("status_word")
        return isinstance(word, int) and (not word & bit or not _running(state))

    return goal


def _off1(state: dict[str, Any]) -> bool:
    control = state.get("control_word")
    return not _running(state) or (isinstance(control, int) and not control & 1)


_GOALS: dict[str, Callable[[dict[str, Any]], bool]] = {
    "on": _running,
    "off1": _off1,
    "off2": _cleared(StatusWord.NO_OFF2),
    "off3": _cleared(StatusWord.NO_OFF3),
    "acknowledge": lambda state: (
        isinstance(state.get("status_word"), int) and not state["status_word"] & StatusWord.FAULT
    ),
}
"""The state a drive command leads to, as the drive's states show it (for a drive on the
page's own line: `pyuss.points.view.GOALS`)."""


class _Setpoint:
    """A remote drive's setpoint as `pyuss.points.view.setpoint_refusal` and `Backend.check`
    ask about it (the members of `pyuss.points.DrivePoints` they use): checked with the
    points' own `checked_setpoint`, against the reference of the drive's last state."""

    def __init__(self, drive: RemoteDrive) -> None:
        self.drive = drive
        self.key = f"{drive.bus}/{drive.name}"
        self.model = drive
        state = drive.state or {}
        reference = state.get("reference") or {}
        value = reference.get("value") if isinstance(reference, dict) else None
        self.reference = float(value) if isinstance(value, int | float) and value > 0 else None

    def setpoint_point(self, key: str = "main") -> tuple[int, bool]:
        for name, pzd, dword in self.drive.setpoints:
            if name == key:
                return pzd, dword
        raise ConfigError(f"{self.key}: no setpoint {key!r:.40}")

    def check_setpoint(self, value: object, key: str = "main", *, unit: str = "value") -> Any:
        pzd, dword = self.setpoint_point(key)
        own = self.drive.unit
        if unit in ("percent", "%"):
            kind = "percent"
        elif unit == "raw" or (unit == "value") or (unit == own and own):
            kind = "raw" if unit == "raw" else "value"
        else:
            units = ("%",) if own == "%" or self.reference is None else ("%", own)
            takes = " or ".join(repr(u) for u in (*units, "raw"))
            raise ConfigError(f"setpoint unit {unit!r:.40}: {self.key} takes {takes}")
        return checked_setpoint(
            value, kind, reference=self.reference, unit=own, key=key, pzd=pzd, dword=dword,
            where=self.key,
        )  # fmt: skip


class PlantBackend:
    """The plant on ``plant``'s broker for the page (see the module text)."""

    COMMANDS = Backend.COMMANDS
    MOVES = Backend.MOVES

    def __init__(self, plant: RemotePlant) -> None:
        self.plant = plant
        self.port = f"MQTT broker {plant.broker}"
        self.demo = False
        self.scan_progress: tuple[int, int] | None = None
        self.last_exchange = 0
        self._sent: dict[str, dict[str, Any]] = {}
        self._remote: dict[str, RemoteParams] = {}

    async def start(self) -> None:
        await self.plant.start()

    async def close(self) -> None:
        await self.plant.close()

    # -- the drives ---------------------------------------------------------------------------
    def _drive(self, key: object) -> RemoteDrive:
        return self.plant.drive(str(key))

    def _params_of(self, drive: RemoteDrive) -> RemoteParams:
        """The drive's parameter jobs and book, made once per drive as its gateway message
        names it (again when a new gateway message replaces the drive)."""
        params = self._remote.get(drive.key)
        if params is None or params.remote is not drive:
            params = self._remote[drive.key] = RemoteParams(self.plant, drive)
        return params

    def addresses(self) -> list[str]:
        return sorted(
            self.plant.drives, key=lambda k: (k.rpartition(".")[0], int(k.split(".")[-1]))
        )

    def take_samples(self) -> dict[str, list[Sample]]:
        """The samples of every live drive since the last call; those of a drive whose
        gateway or drive is offline are dropped, never shown as live."""
        out = {}
        for key, drive in self.plant.drives.items():
            taken = list(drive.samples)
            drive.samples.clear()
            if taken and self.plant.live(drive):
                out[key] = taken
        return out

    def _state(self, drive: RemoteDrive) -> dict[str, Any]:
        return drive.state or {}

    @staticmethod
    def _main(values: object) -> dict[str, Any] | None:
        if not isinstance(values, dict) or not values:
            return None
        main = values.get("main") or next(iter(values.values()))
        return main if isinstance(main, dict) else None

    def motion(self, key: object) -> str:
        drive = self._drive(key)
        if not self.plant.live(drive):
            return "offline"
        state = self._state(drive)
        actual, setpoint = self._main(state.get("actual")), self._main(state.get("setpoint"))
        word = state.get("status_word")
        control = state.get("control_word")
        return motion_of(
            word if isinstance(word, int) else None,
            control if isinstance(control, int) else 0,
            None if actual is None else actual.get("percent"),
            None if setpoint is None else setpoint.get("percent"),
        )

    def setpoint_value(self, key: object) -> float | None:
        main = self._main(self._state(self._drive(key)).get("setpoint"))
        if main is None:
            return None
        value = main.get("value")
        number = value if isinstance(value, int | float) else main.get("percent")
        return float(number) if isinstance(number, int | float) else None

    def _columns(self, drive: RemoteDrive) -> list[dict[str, Any]]:
        unit = drive.unit if _Setpoint(drive).reference is not None else "%"
        return [
            {
                "pzd": pzd,
                "name": "Main actual value" if name == "main" else f"Actual value {name}",
                "unit": unit,
            }
            for name, pzd, _dword in drive.actual
        ]

    def drive_info(self, key: object) -> dict[str, Any]:
        drive = self._drive(key)
        reference = _Setpoint(drive).reference
        params = self._params_of(drive)
        profile = params.profile  # the telegram rules; its facts only where it is named
        title = profile.title if params.profile_named else "a drive of unknown kind"
        return {
            "address": drive.key,
            "bus": drive.bus,
            "name": drive.name,
            "profile": params.kind,
            "title": f"{title} · {drive.name} on gateway {drive.bus}",
            "layout": drive.layout,
            "pzd": params.layout.pzd,
            "reference": None if reference is None else {"value": reference, "unit": drive.unit},
            "actuals": self._columns(drive),
            "key_actuals": self._key_actuals(params),
            "status_bits": status_bits(profile.status_bits if params.profile_named else {}),
            "read_only": self.plant.buses[drive.bus].read_only,
        }

    @staticmethod
    def _key_actuals(params: RemoteParams) -> list[dict[str, Any]]:
        out = []
        for pnu in KEY_ACTUALS:
            info = params.params.get(pnu)
            if info is not None and info.array is None and info.is_numeric:
                out.append({"pnu": pnu, "name": info.name, "unit": info.unit})
        return out

    def summary(self, key: object) -> dict[str, Any]:
        drive = self._drive(key)
        bus = self.plant.buses[drive.bus]
        why = self.plant.why_not_live(drive)
        live = why is None
        state = self._state(drive) if live else {}
        health = state.get("health") or {}
        counters = dict(health.get("counters") or {})
        word = state.get("status_word")
        control = state.get("control_word") if live else None
        params = self._params_of(drive)
        return {
            "address": drive.key,
            "bus": drive.bus,
            "name": drive.name,
            "number": drive.address,
            "profile": drive.profile,
            "layout": drive.layout,
            "online": live,
            "offline": why,
            "read_only": bus.read_only,
            "not_sending": not live,
            "control": state.get("control_word") if live else None,
            "control_in_force": None,
            "setpoints": [],
            "status": word if live else None,
            "state": why or (state_name(word) if isinstance(word, int) else "no answer yet"),
            "motion": self.motion(key),
            "setpoint": self._main(state.get("setpoint")) if live else None,
            "sent_setpoint": self._sent.get(drive.key),
            "fault": bool(state.get("bits", {}).get("fault")) if live else False,
            "warning": bool(state.get("bits", {}).get("warning")) if live else False,
            "actual": [v for v in drive.actual_row(state)] if live and state else [],
            "actual_unit": self._columns(drive)[0]["unit"] if drive.actual else "%",
            **word_texts(
                control if isinstance(control, int) else None,
                None,
                word if live and isinstance(word, int) else None,
                params.profile if params.profile_named else None,
            ),
            "health": {
                "exchanges": health.get("exchanges", 0),
                "answers": health.get("answers", 0),
                "timeouts": health.get("timeouts", 0),
                # not in the gateway's state: shown as not known, never as 0
                "late": None,
                "response_ms": None,
                "jobs": None,
                "refused": None,
                "counters": {name: counters.get(name, 0) for name in _COUNTERS},
            },
        }

    def bus(self) -> dict[str, Any]:
        """The plant: every gateway with its bus, availability, read-only, latency, drives."""
        gateways = []
        for name in sorted(self.plant.buses):
            bus = self.plant.buses[name]
            if bus.gateway is None:
                continue  # no gateway message (yet): nothing is known of its drives
            message = bus.gateway
            gateways.append(
                {
                    "bus": name,
                    "online": bus.online,
                    "read_only": bus.read_only,
                    "version": message.get("version"),
                    "keepalive": message.get("keepalive"),
                    "latency": bus.latency.to_dict(),
                    "drives": [k for k in self.addresses() if self.plant.drives[k].bus == name],
                }
            )
        return {
            "plant": True,
            "port": self.port,
            "broker": self.plant.broker,
            "connected": self.plant.connected.is_set(),
            "client_id": self.plant.client_id,
            "baud": None,
            "demo": False,
            "cycle_ms": 0.0,
            "line": {},
            "scanning": False,
            "gateways": gateways,
            "drives": [self.summary(k) for k in self.addresses()],
        }

    # -- commands -----------------------------------------------------------------------------
    def _may(self, drive: RemoteDrive, *, change: bool) -> None:
        why = self.plant.why_not(drive, change=change)
        if why is not None:
            raise GatewayRefusal(why)
        if change and not drive.available:
            raise GatewayRefusal(f"drive {drive.key} does not answer its gateway: nothing sent")

    def check(self, key: object, name: object, value: object = None) -> dict[str, Any]:
        """`Backend.check` for a drive of a gateway: the same table, setpoint check and
        texts, and besides its gateway online, not read-only, and the command one of the
        gateway's. Nothing is sent."""
        drive = self._drive(key)
        if name == "setpoint":
            checked = self._setpoint(drive, value)
            result = {
                "name": name,
                "setpoint": checked.to_dict(),
                "text": f"set the setpoint to {setpoint_text(checked, unit_given(value))}",
            }
        elif not isinstance(name, str) or name not in COMMAND_TABLE:
            shown = repr(name)[:40]
            raise ConfigError(f"unknown command {shown}: one of {', '.join(self.COMMANDS)}")
        elif name not in GATEWAY_COMMANDS:
            raise ConfigError(f"{name} is not a command of the gateway: {NOT_OVER_MQTT}")
        else:
            result = {"name": name, "text": name}
        self._may(drive, change=True)
        return result

    @staticmethod
    def _setpoint(drive: RemoteDrive, value: object) -> ProcessValue:
        # the local page's own check, on the remote drive's setpoint (`_Setpoint`)
        return Backend._setpoint(cast(Any, _Setpoint(drive)), value)

    async def command(self, key: object, name: object, value: object = None) -> dict[str, Any]:
        """Checked whole (`check`), then one request to the drive's gateway; the reply's
        state, and for a drive command the states that follow it for `TAKE_TIME` seconds,
        tell whether the drive took it."""
        self.check(key, name, value)
        drive = self._drive(key)
        if name == "setpoint":
            checked = self._setpoint(drive, value)
            result = await self.plant.request(
                drive, "setpoint_percent", {"value": checked.percent, "key": checked.key}
            )
            shown = setpoint_text(checked, unit_given(value))
            self._sent[drive.key] = {
                "value": value.get("value") if isinstance(value, dict) else value,
                "unit": unit_given(value),
            }
            return {
                "command": name,
                "taken": True,
                "text": f"Setpoint {shown} is in force (gateway {drive.bus} answered).",
                "status": result.get("status_word"),
                "state": result.get("state"),
                "motion": self.motion(key),
                "setpoint": self._main(result.get("setpoint")),
            }
        assert isinstance(name, str)
        await self.plant.request(drive, name)
        goal = _GOALS[name]
        deadline = time.monotonic() + TAKE_TIME
        while (
            self.plant.live(drive) and not goal(self._state(drive)) and time.monotonic() < deadline
        ):
            await asyncio.sleep(0.05)
        why = self.plant.why_not_live(drive)
        if why is not None:
            # the last state is no news of the drive: its gateway (or the broker, or the
            # drive) went away meanwhile
            return {
                "command": name,
                "taken": False,
                "text": f"{name}: sent, but whether the drive took it is not known: {why}.",
                "state": "not known",
                "status": None,
                "motion": self.motion(key),
            }
        taken = goal(self._state(drive))
        word = self._state(drive).get("status_word")
        shown = "no answer" if not isinstance(word, int) else f"{state_name(word)} ({word:04X}h)"
        text = (
            f"{name}: done, the drive is {shown}."
            if taken
            else f"{name}: the drive did not take it: it shows {shown}."
        )
        return {
            "command": name,
            "taken": taken,
            "text": text,
            "state": state_name(word) if isinstance(word, int) else "no answer",
            "status": word,
            "motion": self.motion(key),
        }

    def sent_setpoint(self, key: object) -> dict[str, Any] | None:
        return self._sent.get(self._drive(key).key)

    async def key_actuals(self, key: object) -> dict[str, Any]:
        drive = self._drive(key)
        self._may(drive, change=False)
        params = self._params_of(drive)
        values = []
        for item in self._key_actuals(params):
            try:
                reading = await params.read_param(item["pnu"])
            except UssError as exc:
                values.append({**item, "error": str(exc)})
                continue
            values.append(key_actual(item, reading))
        return {"time": time.time(), "values": values}

    async def faults(self, key: object) -> dict[str, Any]:
        """The active fault and warning from the drive's state, the fault history and warning
        numbers read through the gateway (``cmd/read``) where the family keeps them: the local
        page's panel (`pyuss.points.view.fault_history`)."""
        drive = self._drive(key)
        bits = self._state(drive).get("bits") or {}
        return await fault_history(
            self._params_of(drive),
            fault=bool(bits.get("fault")),
            warning=bool(bits.get("warning")),
        )

    async def sources(self, key: object) -> dict[str, Any]:
        """Whether the drive follows the control word and setpoint of USS, its source
        parameters read through the gateway (``cmd/read``), as the local page reads them."""
        drive = self._drive(key)
        self._may(drive, change=False)
        return (await check_sources(self._params_of(drive))).to_dict()

    # -- parameters ---------------------------------------------------------------------------
    def parameters(self, key: object) -> list[dict[str, Any]]:
        """The expert list of the drive's profile (its parameter file): names, units, limits,
        texts; over the broker a parameter is read and written as a number."""
        params = self._params_of(self._drive(key))
        book = params.params
        rows = []
        for info in book:
            indexes: list[int | None] = [None] if info.array is None else list(book.indices(info))
            needs = backups.beyond_layout(params.layout, info)
            numeric = info.is_numeric and not info.is_bit_field
            for index in indexes:
                row = expert_row(info, index)
                if needs is not None:
                    row.update(needs=needs, writable=False)
                elif not numeric:
                    row.update(needs="a number: the gateway carries numbers only", writable=False)
                rows.append(row)
        return rows

    async def read(
        self, key: object, refs: Sequence[tuple[int, int | None]]
    ) -> list[dict[str, Any]]:
        drive = self._drive(key)
        self._may(drive, change=False)
        params = self._params_of(drive)
        return await read_rows(refs, params.layout, params.params, params.read_param)

    async def write(
        self, key: object, pnu: int, index: int | None, text: str, *, eeprom: bool = False
    ) -> dict[str, Any]:
        """Write a value as typed: parsed and checked against the parameter's type, limits and
        access (`pyuss.params.parse`) before anything is sent, then by the gateway."""
        drive = self._drive(key)
        params = self._params_of(drive)
        info = params.params.get(pnu)
        if info is None:
            raise ConfigError(
                f"{param_label(pnu, index)}: nothing is known of it (no parameter file has it), so "
                "its value cannot be checked: the page does not write it"
            )
        needs = backups.beyond_layout(params.layout, info)
        if needs is not None:
            raise ConfigError(f"{param_label(pnu, index)} cannot be written: {needs}")
        if info.read_only:
            raise ConfigError(f"{info.label(index)} ({info.name}) is read-only")
        value = parse(info, text, index)
        self._may(drive, change=True)
        reading = await params.write_param(pnu, value, index, eeprom=eeprom)
        return {"id": param_id(pnu, index), **shown_reading(reading)}

    # -- backup, compare, restore: those of pyuss.commission over RemoteParams ------------------
    def _params(self, key: object, *, change: bool) -> RemoteParams:
        drive = self._drive(key)
        self._may(drive, change=change)
        return self._params_of(drive)

    async def backup(
        self, key: object, fmt: str = "toml", progress: Progress | None = None
    ) -> tuple[str, str]:
        params = self._params(key, change=False)
        if fmt not in backups.FORMATS:
            raise ConfigError(f"backup format {fmt!r}: one of {', '.join(backups.FORMATS)}")
        drive: Any = params
        taken = await backups.take(drive, port=self.port, progress=progress)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        name = f"{params.remote.bus}-drive{params.address}-{params.kind}-{stamp}.{fmt}"
        return name, backups.dumps(taken, fmt)

    async def _wanted_and_now(
        self, params: RemoteParams, data: bytes, name: str, progress: Progress | None
    ) -> tuple[backups.Backup, backups.Backup, str | None]:
        """The uploaded file, the drive's values of its parameters, and why the file may be
        another drive's (`pyuss.web.files.stranger`)."""
        drive: Any = params
        wanted, now = await wanted_and_now(
            drive, data, name, address=params.address, kind=params.kind,
            source=f"drive {params.remote.key}", progress=progress,
        )  # fmt: skip
        other = await stranger(wanted, drive, kind=params.kind, who=params.remote.key)
        return wanted, now, other

    async def compare(
        self, key: object, data: bytes, name: str, progress: Progress | None = None
    ) -> dict[str, Any]:
        """`Backend.compare` over the broker."""
        params = self._params(key, change=False)
        wanted, now, other = await self._wanted_and_now(params, data, name, progress)
        return compared(name, wanted, now, params.params, params.named_profile, other)

    async def restore(
        self,
        key: object,
        data: bytes,
        name: str,
        *,
        force: bool = False,
        eeprom: bool = False,
        progress: Progress | None = None,
        approve: Approve | None = None,
    ) -> dict[str, Any]:
        """`Backend.restore` over the broker: every value checked first (`plan`), then written
        one request at a time; each refusal comes back with its number and meaning."""
        params = self._params(key, change=True)
        wanted, now, other = await self._wanted_and_now(params, data, name, progress)
        if other is not None and not force:
            raise ConfigError(other)
        writes, skips = plan(wanted, now, params.params, params.named_profile)
        if approve is not None:
            approve(planned(writes))
        drive: Any = params
        outcomes = await restore(drive, writes, eeprom=eeprom, progress=progress)
        where = f"drive {params.remote.key}"
        return restored(where, name, writes, skips, outcomes, eeprom=eeprom)

    # -- what needs the line itself -------------------------------------------------------------
    async def scan(self, *args: Any, **kwargs: Any) -> list[dict[str, Any]]:
        raise ConfigError(f"the scan is {NOT_OVER_MQTT}")

    def exchanges_since(self, seq: int, limit: int) -> tuple[list[dict[str, Any]], int]:
        return [], 0

    def pcapng(self) -> bytes:
        raise ConfigError(f"the telegram monitor is {NOT_OVER_MQTT}")


_COUNTERS = (
    "good",
    "discarded",
    "framing",
    "overrun",
    "parity",
    "no_stx",
    "residual_time",
    "bcc",
    "bad_lge",
    "timeout",
)
"""The A 5.2.3 counters the bus view shows."""
