"""The running plant: one `Master` per bus, and per drive its points (`DrivePoints`), live.

`Plant` opens one master per bus (`BusPoints`), takes a `Drive` handle per configured drive
from it and keeps a `pyuss.points.drive.DrivePoints` per drive (whose docstring has the rules
of a face's wishes). The rules of the buses:

- Every drive of a bus goes through the bus's one master, so everything queues in it and
  nothing interleaves on the line.
- A bus is online while its master exchanges on the line; it is offline before `start`,
  while its port is lost and being reopened (`pyuss.transport.reconnect`, unless its URL
  says ``reconnect=0``), and once stopped. Its drives are offline at once with it, and each
  one controlled here is given back (0000h, `DrivePoints`); one log line (WARNING) per bus
  names them, and a line lost for good is an ERROR (`Plant.lost` waits for one).
- "Does not send" (A 5.2.1.1), which no answer reports, is looked at every `HEALTH_PERIOD`
  on every drive of a started bus, and so is whether a drive went too long without an answer.
- A plant that fails to start closes the buses it started.

Subscribers: `BusPoints.subscribe` takes a callback for every changed `BusState`,
`Plant.subscribe` one for every changed state of every drive (``callback(drive, state)``);
neither may block.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Mapping
from types import TracebackType

from pyuss import _callbacks
from pyuss._tasks import cancel_and_wait
from pyuss.errors import UssError
from pyuss.master.scheduler import Master
from pyuss.points.drive import GIVEN_BACK, DrivePoints
from pyuss.points.errors import UnknownPoint
from pyuss.points.model import BusModel, PlantModel
from pyuss.points.state import BusState, DriveState, now
from pyuss.transport.base import Transport
from pyuss.transport.url import open_transport

__all__ = ["HEALTH_PERIOD", "BusPoints", "Plant"]

log = logging.getLogger("pyuss.points")

HEALTH_PERIOD = 0.2
"""How often "does not send" is looked at (seconds)."""


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
        released = [d.name for d in self.drives.values() if d.bus_changed(online)]
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
            await cancel_and_wait(task, ignore=(Exception,))
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
