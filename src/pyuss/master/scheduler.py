"""The asyncio bus master: `Master`, the loop around `pyuss.master.core.MasterCore`.

One `Master` runs one bus with one task, which alone talks to the transport: every telegram on
the line is one "turn", so nothing interleaves however many tasks (or threads, through
`pyuss.master.sync`) use the bus at once. What is sent when and what an answer is, the core
decides (its rules: `pyuss.master.core`); this loop sleeps, writes and reads, and turns the
users' requests into futures the core completes.

The line's timing (start pauses, timestamps, the virtual bus's timed hand-over): see
`pyuss.master.wire`.

A lost line
    On a transport that reopens a lost link (`pyuss.transport.reconnect`) a write while it is
    down raises `LinkDown`: the master sends nothing until the link is back
    (`pyuss.master.loop`), takes every slave for not sending, fails what waits for the line
    with `LinkDown` and refuses new requests at once (a wait for a slave's next answer waits
    on, within its time); `online` and `on_line` tell. After the link is back it sends the
    process data in force to the poll list, nothing asked for while the link was down. A
    transport that fails for good stops the master (`lost`).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterable, Sequence
from types import TracebackType
from typing import TYPE_CHECKING

from pyuss._tasks import cancel_and_wait
from pyuss.errors import ConfigError, TransportError, UssTimeout
from pyuss.master.core import (
    ACYCLIC,
    CYCLIC,
    DEFAULT_JOB_TIMEOUT,
    MasterCore,
    MirrorResult,
    Mode,
    Reply,
    Slave,
)
from pyuss.master.drive import Drive
from pyuss.master.errors import MasterClosed, NotSending
from pyuss.master.jobs import SpontaneousMessage
from pyuss.master.loop import Loop
from pyuss.master.process import DriveStatus
from pyuss.master.stats import BusDiagnostics, CycleStats
from pyuss.master.wire import Wire, line_down, line_transport
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.transport.base import Transport, stamp_tolerance
from pyuss.transport.reconnect import LinkDown

if TYPE_CHECKING:
    from pyuss.master.profile import Profile

__all__ = ["ACYCLIC", "CYCLIC", "Master", "MirrorResult", "Mode", "Reply"]


class Master:
    """A USS bus master (see the module docstring). Use it as an async context manager::

        async with Master("/dev/ttyUSB0", baud=19200) as bus:
            drive = bus.drive(5, layout=Layout(3, 2))
            print(await drive.read(52))

    ``transport``: a `Transport` or a URL for `pyuss.transport.open_transport`; ``baud`` is
    taken from the transport when not given (and must match it when given), 9600 for a URL
    by default. ``profile``: the default profile of the drives (a name or a
    `pyuss.profiles.Profile`; None: drives of unknown kind, spoken to by the USS
    specification's rules with no family's parameter facts); ``layout``: their default
    layout, a `Layout` or ``"PKW,PZD"`` (else the profile's).
    ``cycle_time``: a fixed cycle time in seconds (A 5.1.1), None to cycle as fast as the line
    allows. ``mode``: `CYCLIC` or `ACYCLIC`. ``response_delay``: the default response delay
    limit in seconds (else the profile's, 20 ms). ``job_timeout``: seconds a parameter job may
    take from its first telegram. ``rx_tolerance``, ``latency`` and ``silence`` (the wait for a
    silent slave beyond its window, default ``latency``): "Time bases" in `pyuss.master.wire`
    (None picks by transport). ``close_transport``: close the transport on exit.

    Nothing is opened and no event loop is touched until `start` (or ``async with``).
    """

    def __init__(
        self,
        transport: Transport | str,
        *,
        baud: int | None = None,
        profile: Profile | str | None = None,
        layout: Layout | str | None = None,
        cycle_time: float | None = None,
        mode: Mode = Mode.CYCLIC,
        response_delay: float | None = None,
        job_timeout: float = DEFAULT_JOB_TIMEOUT,
        rx_tolerance: float | None = None,
        latency: float | None = None,
        silence: float | None = None,
        close_transport: bool = True,
    ) -> None:
        transport = line_transport(transport, baud)
        self.core = core = MasterCore(
            transport.baud,
            profile=profile,
            layout=layout,
            cycle_time=cycle_time,
            mode=mode,
            response_delay=response_delay,
            job_timeout=job_timeout,
            rx_tolerance=stamp_tolerance(transport) if rx_tolerance is None else rx_tolerance,
            latency=latency,
            silence=silence,
            exact=transport.exact_timestamps,
            loopback=str(getattr(transport, "url", "")).startswith("loop://"),
        )
        """The master's state and decisions (`pyuss.master.core`); this is the loop."""
        self.transport = transport
        self.baud, self.timing, self.profile = core.baud, core.timing, core.profile
        self.mode, self.cycle_time = core.mode, core.cycle_time
        self.response_delay = core.response_delay
        self.job_timeout, self.rx_tolerance = core.job_timeout, core.rx_tolerance
        self.latency, self.silence = core.latency, core.silence
        self.close_transport = close_transport
        self._drives: dict[int, Drive] = {}
        self._task: asyncio.Task[None] | None = None
        self._loop = Loop(core, Wire(core, transport))
        self.wire = self._loop.wire
        """Its line: the start pause, the writes, the wait for an answer (`pyuss.master.wire`)."""

    # -- life cycle ------------------------------------------------------------------------
    async def __aenter__(self) -> Master:
        await self.start()
        return self

    async def __aexit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.close()

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    @property
    def online(self) -> bool:
        """Whether the master exchanges telegrams on the line: started, not stopped or
        closing, and the link up (see "A lost line" in the module docstring)."""
        connected = getattr(self.transport, "connected", True)
        return self.running and self.core.down is None and not self.core.closing and connected

    @property
    def lost(self) -> TransportError | None:
        """What stopped the master on its own - its port failed and was not reopened -; None
        while it runs, and for a master that only was closed."""
        return self._loop.lost

    async def start(self) -> None:
        """Open the transport and start the scheduler."""
        if self._task is not None:
            raise ConfigError("the master was started already")
        await self.transport.open()
        self._loop.start()
        self._task = asyncio.create_task(self._loop.run(), name=f"uss master {self.baud} baud")

    async def close(self) -> None:
        """Stop after the current telegram, fail what waits, close the transport."""
        self.core.closing = True
        self._loop.poke()
        if self._task is not None:
            task = self._task
            try:
                async with asyncio.timeout(self.core.stop_time()):
                    await asyncio.shield(task)
            except TimeoutError:
                await cancel_and_wait(task)
        self.core.fail(self.core.failure or MasterClosed("the master was closed"))
        if self.close_transport:
            await self.transport.close()

    def ensure_usable(self, *, line: bool = True) -> None:
        """Refuse a request the master cannot carry out: stopped, closing, not started, or
        (``line``: one that needs the line now) the link down."""
        if self.core.failure is not None:
            raise self.core.failure
        if self.core.closing:
            raise MasterClosed("the master is closing")
        if self._task is None:
            raise MasterClosed("the master is not started: use 'async with Master(...)'")
        if line and self.core.down is None and not getattr(self.transport, "connected", True):
            line_down(self.core, LinkDown("the link is down"))  # (a loss no read noticed yet)
        if line and self.core.down is not None:
            raise LinkDown(str(self.core.down))

    def clock(self) -> float:
        return self.transport.clock()

    # -- drives ----------------------------------------------------------------------------
    def drive(
        self,
        address: int,
        *,
        layout: Layout | str | None = None,
        profile: Profile | str | None = None,
        response_delay: float | None = None,
        poll: bool = True,
    ) -> Drive:
        """The handle of the slave at ``address`` (the same object on every call).

        The first call fixes its ``layout`` (a `Layout` or ``"PKW,PZD"``; default: the
        master's), ``profile`` and ``response_delay`` limit; later calls may repeat them but
        not change them. ``poll``: add the address to the poll list if it is not in it yet.
        """
        slave = self.core.add_slave(
            address, layout=layout, profile=profile, response_delay=response_delay, poll=poll
        )
        return self._handle(slave)

    def _handle(self, slave: Slave) -> Drive:
        drive = self._drives.get(slave.address)
        if drive is None:
            drive = self._drives[slave.address] = Drive(self, slave)
        return drive

    @property
    def drives(self) -> tuple[Drive, ...]:
        """Every drive handle made so far, by address (also of the poll list's addresses)."""
        return tuple(self._handle(self.core.slaves[a]) for a in sorted(self.core.slaves))

    # -- what drives and users ask ---------------------------------------------------------
    async def parameter_job(
        self, slave: Slave, request: Pkw, pnu: int, index: int | None, timeout: float | None
    ) -> Pkw:
        """Run one PKW job for ``slave``; ``pnu``/``index`` word its errors."""
        self.ensure_usable()
        future: asyncio.Future[Pkw] = asyncio.get_running_loop().create_future()
        job = self.core.start_job(slave, request, pnu, index, timeout, future, self.clock())
        try:
            return await future
        except asyncio.CancelledError:
            slave.channel.cancel(job)
            raise

    def set_process_data(
        self, slave: Slave, control: int | None = None, setpoints: dict[int, int] | None = None
    ) -> int:
        """Send a new control word and setpoints to ``slave`` from the next telegram on;
        returns the version `delivered` waits for."""
        return self.core.set_process_data(slave, control, setpoints)

    async def delivered(self, slave: Slave, version: int, timeout: float | None) -> DriveStatus:
        """Wait for the answer to a telegram that carried process data ``version``."""
        self.ensure_usable()
        self.core.check_polled(slave)
        future: asyncio.Future[DriveStatus] = asyncio.get_running_loop().create_future()
        status = self.core.wait_version(slave, version, future)
        return status if status is not None else await self._status(slave, future, timeout)

    async def next_update(self, slave: Slave, timeout: float | None = None) -> DriveStatus:
        """Wait for the slave's next answer (acyclic mode: one telegram to it now)."""
        self.ensure_usable(line=False)  # the answer may come once the link is back
        future: asyncio.Future[DriveStatus] = asyncio.get_running_loop().create_future()
        self.core.wait_update(slave, future)
        return await self._status(slave, future, timeout)

    async def _status(
        self, slave: Slave, future: asyncio.Future[DriveStatus], timeout: float | None
    ) -> DriveStatus:
        wait = self.core.job_timeout_for(timeout)
        try:
            async with asyncio.timeout(wait):
                return await future
        except TimeoutError:
            if slave.not_sending:
                raise NotSending(slave.address, f"no answer within {wait:g} s") from None
            raise UssTimeout(f"slave {slave.address}: no answer within {wait:g} s") from None

    async def exchange(self, address: int, *, timeout: float | None = None) -> DriveStatus:
        """One telegram to ``address`` now (acyclic mode) or its next answer (cyclic)."""
        slave = self.core.slaves.get(address)
        if slave is None:
            raise ConfigError(f"no drive at address {address}: call bus.drive({address}) first")
        return await self.next_update(slave, timeout)

    async def mirror(self, address: int, data: bytes | None = None) -> MirrorResult:
        """Send a mirror telegram (A 5.3) to ``address`` and check that it comes back unchanged.

        ``data``: the net data (default: a test pattern of the length of the slave's telegrams -
        its fixed length, or the shortest variable one - so that the slave accepts it; 5 words
        for an address without a drive handle). Raises `MirrorMismatch` or `NotSending`.
        """
        self.ensure_usable()
        result = await self._special("mirror", self.core.mirror_frame(address, data), address)
        assert isinstance(result, MirrorResult)
        return result

    async def request(self, telegram: Telegram) -> Reply | None:
        """Send any telegram between the turns of the poll list and return the answer of its
        address (of the same type; a special telegram may be answered by a normal one), or
        None when none came within the response delay limit. Broadcasts return None at once
        after the listening time. For probing, special telegrams (A 5.4) and tools; the
        slave's process data and parameter channel are not touched.
        """
        self.ensure_usable()
        if not isinstance(telegram, Telegram):
            raise ConfigError(f"request needs a Telegram, not {telegram!r}")
        if telegram.mode.is_broadcast:
            await self._broadcast(telegram.data, telegram.mode)
            return None
        result = await self._special("request", telegram.encode(), telegram.address)
        assert result is None or isinstance(result, Reply)
        return result

    async def broadcast(
        self,
        pzd: Sequence[int],
        *,
        enable: BroadcastEnableArray | None = None,
        pkw: Sequence[int] | Pkw | None = None,
        layout: Layout | None = None,
    ) -> int:
        """Send a broadcast telegram (A 3): nobody answers. Returns how many telegrams arrived
        within one response delay after it: 0 unless a slave breaks A 3.

        ``pzd``: the process data words. ``enable``: a Broadcast Enable Array (appendix,
        `pyuss.master.broadcast.enable_array_data`); or ``pkw``: any PKW area (its words or a
        `Pkw`); neither: no PKW area. ``layout``: the common layout (default: PKW 4 with an
        array or PKW words, 0 without, and ``len(pzd)`` PZD words).
        """
        words = pkw if pkw is None or isinstance(pkw, Pkw) else list(pkw)
        return await self._broadcast(self.core.broadcast_data(list(pzd), enable, words, layout))

    async def broadcast_control(
        self,
        control: int,
        *,
        mask: int = 0xFFFF,
        layout: Layout,
        addresses: Iterable[int] | None = None,
    ) -> int:
        """Baumueller's broadcast (Baumueller manual 2.2, reading 9): ``control`` merged into the
        control word of every drive (or of ``addresses`` with broadcast coding) through
        ``mask``; see `pyuss.master.broadcast.masked_control_data`. Returns as `broadcast`."""
        from pyuss.master.broadcast import masked_control_data

        data = masked_control_data(control, mask, layout=layout, addresses=addresses)
        return await self._broadcast(data)

    async def _broadcast(self, data: bytes, mode: AddressMode = AddressMode.BROADCAST) -> int:
        answered = await self._special("broadcast", Telegram(0, mode, data).encode(), 0)
        return answered if isinstance(answered, int) else 0

    async def _special(self, kind: str, frame: bytes, address: int) -> object:
        self.ensure_usable()
        future: asyncio.Future[object] = asyncio.get_running_loop().create_future()
        self.core.add_special(kind, frame, address, future)
        return await future

    # -- the poll list and figures ---------------------------------------------------------
    @property
    def poll_list(self) -> tuple[int, ...]:
        """The addresses of the poll list in order (A 5.1)."""
        return self.core.poll_list

    def set_poll_list(self, addresses: Iterable[int]) -> None:
        """Set the poll list; an address may appear several times (A 5.1). Addresses without a
        drive handle get one with the master's defaults."""
        self.core.set_poll_list(addresses)

    def on_spontaneous(self, callback: Callable[[SpontaneousMessage], object]) -> None:
        """Call ``callback`` for every new spontaneous message of any slave (C 4.2.1.2)."""
        self.core.on_spontaneous(callback)

    def on_line(self, callback: Callable[[TransportError | None], object]) -> Callable[[], None]:
        """See `MasterCore.on_line`: told when the line is lost (the error) and back (None);
        returns a function that removes it."""
        return self.core.on_line(callback)

    def cycle_stats(self) -> CycleStats:
        """Achieved cycle times (A 5.1.1)."""
        return self.core.cycle_stats()

    def diagnostics(self) -> BusDiagnostics:
        """A snapshot of the line and of every slave."""
        return self.core.snapshot(self.clock())
