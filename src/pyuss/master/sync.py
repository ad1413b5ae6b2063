"""The master for scripts without asyncio: the same core, run in a background thread.

::

    from pyuss.master.sync import Master

    with Master("/dev/ttyUSB0", baud=19200) as bus:
        drive = bus.drive(5, layout="3,2")
        print(drive.read(52))
        drive.on()
        drive.setpoint(50.0)

`Master` starts one thread with its own event loop on `open` (or ``with``) and runs the
asyncio `pyuss.master.Master` there; every method hands its call to that loop and waits for
the result, so the logic exists once. Calls from several threads at once are safe: they queue
in the scheduler like the jobs of several tasks. Callbacks (`Drive.on_update`,
`Drive.on_missed`, `Drive.on_spontaneous`, `Master.on_spontaneous`, `Master.on_line`) run in
the background thread and must not block it. Errors are the same exceptions as in the
asyncio API. ``call_timeout`` bounds how long a call may wait for the loop (default: no bound
beyond the operation's own timeouts).
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable, Coroutine, Iterable, Sequence
from types import TracebackType
from typing import Any, TypeVar

from pyuss.errors import TransportError
from pyuss.loop import new_event_loop
from pyuss.master import scheduler
from pyuss.master.drive import Drive as AsyncDrive
from pyuss.master.errors import MasterClosed
from pyuss.master.jobs import SpontaneousMessage
from pyuss.master.process import DriveStatus
from pyuss.master.profile import Profile
from pyuss.master.stats import BusDiagnostics, CycleStats
from pyuss.master.sync_drive import Drive
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import Telegram
from pyuss.transport.base import Transport

__all__ = ["Drive", "Master"]

T = TypeVar("T")


class Master:
    """A bus master for synchronous code; takes the arguments of `pyuss.master.Master`."""

    def __init__(
        self,
        transport: Transport | str,
        *,
        call_timeout: float | None = None,
        **options: Any,
    ) -> None:
        self._transport = transport
        self._options = options
        self._call_timeout = call_timeout
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._master: scheduler.Master | None = None
        self._drives: dict[int, Drive] = {}

    # -- the background loop ---------------------------------------------------------------
    def _call(self, coro: Coroutine[Any, Any, T]) -> T:
        loop = self._loop
        if loop is None:
            coro.close()
            raise MasterClosed("the master is not open: use 'with Master(...)' or open()")
        future = asyncio.run_coroutine_threadsafe(coro, loop)
        try:
            return future.result(self._call_timeout)
        except TimeoutError:
            future.cancel()
            raise

    def _run(self, func: Callable[[], T]) -> T:
        """Run a plain function on the loop thread (the core is not thread-safe)."""

        async def call() -> T:
            return func()

        return self._call(call())

    @property
    def core(self) -> scheduler.Master:
        """The asyncio master running in the background thread."""
        if self._master is None:
            raise MasterClosed("the master is not open")
        return self._master

    def open(self) -> None:
        """Start the background thread, open the transport and start the scheduler."""
        if self._loop is not None:
            return
        loop = new_event_loop(least_slack=False)  # microsecond timers (pyuss.loop)
        thread = threading.Thread(target=loop.run_forever, name="uss master", daemon=True)
        thread.start()
        self._loop, self._thread = loop, thread

        async def start() -> scheduler.Master:
            master = scheduler.Master(self._transport, **self._options)
            await master.start()
            return master

        try:
            self._master = self._call(start())
        except BaseException:
            self._stop_loop()
            raise

    def close(self) -> None:
        """Stop the scheduler, close the transport, end the thread."""
        if self._loop is None:
            return
        try:
            if self._master is not None:
                self._call(self._master.close())
        finally:
            self._master = None
            self._stop_loop()

    def _stop_loop(self) -> None:
        loop, thread = self._loop, self._thread
        self._loop = self._thread = None
        if loop is None:
            return
        loop.call_soon_threadsafe(loop.stop)
        if thread is not None:
            thread.join(5.0)
        loop.close()

    def __enter__(self) -> Master:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- the bus ---------------------------------------------------------------------------
    def drive(
        self,
        address: int,
        *,
        layout: Layout | str | None = None,
        profile: Profile | str | None = None,
        response_delay: float | None = None,
        poll: bool = True,
    ) -> Drive:
        """The handle of the slave at ``address`` (see `pyuss.master.Master.drive`)."""
        core = self.core
        return self._run(
            lambda: self._wrap(
                core.drive(
                    address,
                    layout=layout,
                    profile=profile,
                    response_delay=response_delay,
                    poll=poll,
                )
            )
        )

    def _wrap(self, handle: AsyncDrive) -> Drive:
        """The one sync handle of ``handle`` (called on the loop thread, so never twice)."""
        if handle.address not in self._drives:
            self._drives[handle.address] = Drive(self, handle)
        return self._drives[handle.address]

    @property
    def drives(self) -> tuple[Drive, ...]:
        """Every drive handle made so far, by address."""
        core = self.core
        return self._run(lambda: tuple(self._wrap(handle) for handle in core.drives))

    @property
    def running(self) -> bool:
        """True while the scheduler runs (between `open` and `close`)."""
        return self._master is not None and self._master.running

    @property
    def online(self) -> bool:
        """Whether the master exchanges on the line (`pyuss.master.Master.online`)."""
        return self._master is not None and self._master.online

    @property
    def lost(self) -> TransportError | None:
        return None if self._master is None else self._master.lost

    def on_line(self, callback: Callable[[TransportError | None], object]) -> Callable[[], None]:
        core = self.core
        return self._run(lambda: core.on_line(callback))

    @property
    def poll_list(self) -> tuple[int, ...]:
        return self.core.poll_list

    def set_poll_list(self, addresses: Iterable[int]) -> None:
        entries = list(addresses)
        core = self.core
        self._run(lambda: core.set_poll_list(entries))

    def broadcast(
        self,
        pzd: Sequence[int],
        *,
        enable: BroadcastEnableArray | None = None,
        pkw: Sequence[int] | Pkw | None = None,
        layout: Layout | None = None,
    ) -> int:
        return self._call(self.core.broadcast(pzd, enable=enable, pkw=pkw, layout=layout))

    def broadcast_control(
        self,
        control: int,
        *,
        mask: int = 0xFFFF,
        layout: Layout,
        addresses: Iterable[int] | None = None,
    ) -> int:
        return self._call(
            self.core.broadcast_control(control, mask=mask, layout=layout, addresses=addresses)
        )

    def mirror(self, address: int, data: bytes | None = None) -> scheduler.MirrorResult:
        return self._call(self.core.mirror(address, data))

    def request(self, telegram: Telegram) -> scheduler.Reply | None:
        return self._call(self.core.request(telegram))

    def exchange(self, address: int, *, timeout: float | None = None) -> DriveStatus:
        return self._call(self.core.exchange(address, timeout=timeout))

    def diagnostics(self) -> BusDiagnostics:
        core = self.core
        return self._run(core.diagnostics)

    def cycle_stats(self) -> CycleStats:
        core = self.core
        return self._run(core.cycle_stats)

    def on_spontaneous(self, callback: Callable[[SpontaneousMessage], object]) -> None:
        core = self.core
        self._run(lambda: core.on_spontaneous(callback))
