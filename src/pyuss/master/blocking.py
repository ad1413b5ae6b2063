"""A master with no thread and no event loop, for scripts: `Master` runs the master's core
(`pyuss.master.core`) in the calling thread, over a serial port (any pyserial URL: ``COM3``,
``/dev/ttyUSB0``, ``socket://HOST:PORT``), for as long as a call needs the line.

Where it fits: a script that asks its drives something now and then, or polls them in a loop of
its own, as vendor examples and small libraries do. The traffic is acyclic (USS specification
A 2.2): a telegram goes out only while a call needs one - a parameter job's telegrams until it
is answered, one telegram for `Master.exchange` or a drive's ``next_update``, the telegrams
of a command until a telegram carrying it is answered. Nothing is sent between calls: a drive
whose telegram monitoring is on (P2040, P2014, P687.1...) faults when the script is quiet for
longer than that time. For a drive that runs, use `pyuss.master.sync` (its background loop
polls the drives cyclically) or the asyncio `pyuss.master.Master`.

- The drive handles are those of `pyuss.master.sync` (the methods of `pyuss.master.Drive`
  without ``await``), run here in the caller's thread: the rules of the core hold alike (the
  start pause, the response window, an old answer never taken for a new job).
- Calls from several threads take turns (a lock); callbacks (``on_update``...) are called in
  the calling thread during a call.
- The port is read as the other serial transports read it: bytes stamped when read
  (``rx_tolerance``, 20 ms by default); a slave of fixed layout is read a whole answer at a
  time. ``rs485=rts`` direction control, line-error marking and low-latency mode are the
  serial transport's (`pyuss.transport.serialport`); ``echo=1`` is not needed: a request heard
  back is never taken for an answer (`pyuss.master.core.MasterCore.own`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Coroutine, Sequence
from types import TracebackType
from typing import Any, Generic, TypeVar

from pyuss.errors import ConfigError, TransportError, UssTimeout
from pyuss.master import sync_drive
from pyuss.master.core import (
    _NORMAL,
    ACYCLIC,
    DEFAULT_JOB_TIMEOUT,
    Exchange,
    MasterCore,
    MirrorResult,
    Reply,
    Result,
    Slave,
    Special,
)
from pyuss.master.drive import Drive as AsyncDrive
from pyuss.master.errors import MasterClosed, NotSending
from pyuss.master.jobs import SpontaneousMessage
from pyuss.master.process import DriveStatus
from pyuss.master.profile import Profile
from pyuss.master.stats import BusDiagnostics
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.system import clock
from pyuss.transport.base import STAMP_TOLERANCE
from pyuss.transport.serialport import SerialTransport

__all__ = ["Master"]

T = TypeVar("T")


class _Box(Generic[T]):
    """A `pyuss.master.core.Pending` the calling thread looks at."""

    __slots__ = ("error", "is_done", "value")

    def __init__(self) -> None:
        self.is_done = False
        self.value: T | None = None
        self.error: BaseException | None = None

    def done(self) -> bool:
        return self.is_done

    def set_result(self, result: T, /) -> None:
        self.value, self.is_done = result, True

    def set_exception(self, exception: BaseException, /) -> None:
        self.error, self.is_done = exception, True


class _Line:
    """The core's loop over the port, in the calling thread (as `pyuss.master.loop` and
    `pyuss.master.wire` are over an asyncio transport)."""

    def __init__(self, core: MasterCore, transport: SerialTransport) -> None:
        self.core = core
        self.transport = transport
        self._read = transport.read_now

    def _drain(self) -> None:
        core = self.core
        while (chunk := self._read(None, 0.0)) is not None:
            core.between(core.feed(chunk))
        if core.receiver.busy:
            core.settle(clock())

    def run(self, done: Callable[[], bool], deadline: float) -> None:
        """Turns until ``done()``, nothing is left to do or ``deadline`` passed."""
        core = self.core
        while not done() and clock() < deadline:
            action = core.next_action(clock())
            if isinstance(action, Slave):
                self._turn(action)
            elif isinstance(action, Special):
                self._special(action)
            else:
                core.expire_jobs(clock())
                return

    def _send(self, frame: bytes | Callable[[], bytes], pause_chars: float) -> tuple[float, float]:
        core = self.core
        while True:
            self._drain()
            left = core.send_due(pause_chars) - clock()
            if left <= 0:
                break
            time.sleep(left)
        core.sending(clock() if core.receiver.busy else 0.0)
        if callable(frame):
            frame = frame()
        start = clock()
        try:
            self.transport.write_now(frame)
        except Exception as exc:
            raise TransportError(f"{self.transport.describe()}: write failed: {exc}") from None
        core.sent(frame, start, core.timing.transmit(len(frame)), clock())
        return start, core.line_free

    def _transact(
        self,
        frame: bytes | Callable[[], bytes],
        address: int,
        modes: frozenset[AddressMode],
        limit: float,
        pause_chars: float,
        slave: Slave | None,
    ) -> Result:
        start, end = self._send(frame, pause_chars)
        exchange = Exchange(self.core, address, modes, limit, slave, start, end)
        lge = slave.layout.lge if slave is not None else None
        count = None if lge is None else lge + 2
        while True:
            wait = exchange.step(clock())
            if isinstance(wait, Result):
                return wait
            if wait is None:  # the window is over: what is in is the last look
                chunk = self._read(None, 0.0)
                if chunk is None:
                    return exchange.give_up(clock())
            else:
                chunk = self._read(count, wait)
            if chunk is not None:
                exchange.feed(chunk)
                count = None

    def _turn(self, slave: Slave) -> None:
        sent = [slave.version, slave.control]

        def build() -> bytes:
            sent[:] = [slave.version, slave.control]
            return slave.request(clock())

        pause = slave.profile.start_pause_chars
        result = self._transact(build, slave.address, _NORMAL, slave.response_delay, pause, slave)
        self.core.end_turn(slave, result, sent[0], sent[1], clock())

    def _special(self, special: Special) -> None:
        core = self.core
        try:
            if special.kind == "broadcast":
                self._send(special.frame, core.broadcast_pause())
                until, before = core.broadcast_sent()
                while (wait := core.listen_done(until, clock())) is not None:
                    if (chunk := self._read(None, wait)) is not None:
                        core.between(core.feed(chunk))
                result: object = core.answered_broadcasts - before
            else:
                slave, pause, limit, modes = core.special_setup(special)
                answer = self._transact(special.frame, special.address, modes, limit, pause, slave)
                result = core.special_result(special, slave, answer)
        except TransportError:
            raise
        except Exception as exc:
            special.pending.set_exception(exc)
        else:
            special.pending.set_result(result)
        core.expire_jobs(clock())


class _Bus:
    """The calls a `pyuss.master.Drive` makes of its master (`pyuss.master.drive.Bus`),
    carried out at once in the calling thread: none of them waits for anything."""

    def __init__(self, master: Master) -> None:
        self._master = master
        self.core = master.core

    def ensure_usable(self, *, line: bool = True) -> None:
        self._master._ensure_open()

    def clock(self) -> float:
        return clock()

    def set_process_data(
        self, slave: Slave, control: int | None = None, setpoints: dict[int, int] | None = None
    ) -> int:
        return self.core.set_process_data(slave, control, setpoints)

    def _wait(self, slave: Slave, box: _Box[T], timeout: float | None) -> T:
        wait = self.core.job_timeout_for(timeout)
        self._master._line_run(box.done, clock() + wait)
        if box.error is not None:
            raise box.error
        if not box.is_done:
            if slave.not_sending:
                raise NotSending(slave.address, f"no answer within {wait:g} s")
            raise UssTimeout(f"slave {slave.address}: no answer within {wait:g} s")
        return box.value  # type: ignore[return-value]

    async def parameter_job(
        self, slave: Slave, request: Pkw, pnu: int, index: int | None, timeout: float | None
    ) -> Pkw:
        self.ensure_usable()
        box: _Box[Pkw] = _Box()
        job = self.core.start_job(slave, request, pnu, index, timeout, box, clock())
        # a job ends by itself (its answer, a refusal, its deadline): the wait only bounds it
        return self._wait(slave, box, 2 * job.timeout + 1.0)

    async def delivered(self, slave: Slave, version: int, timeout: float | None) -> DriveStatus:
        self.ensure_usable()
        box: _Box[DriveStatus] = _Box()
        status = self.core.wait_version(slave, version, box)
        return status if status is not None else self._wait(slave, box, timeout)

    async def next_update(self, slave: Slave, timeout: float | None = None) -> DriveStatus:
        self.ensure_usable()
        box: _Box[DriveStatus] = _Box()
        self.core.wait_update(slave, box)
        return self._wait(slave, box, timeout)

    async def mirror(self, address: int, data: bytes | None = None) -> MirrorResult:
        return self._master.mirror(address, data)


class Master:
    """A master for scripts, in the calling thread (see the module docstring)::

        with Master("COM3", baud=19200, profile="sinamics-v20") as bus:
            drive = bus.drive(5)
            print(drive.read(1082))

    ``port``: a serial port or any pyserial URL, with the line options of
    `pyuss.transport.open_transport` (``?rs485=rts``, ``low_latency=0``); ``baud``; the rest
    as for `pyuss.master.Master` (the traffic is always acyclic).
    """

    def __init__(
        self,
        port: str,
        *,
        baud: int = 9600,
        profile: Profile | str | None = None,
        layout: Layout | str | None = None,
        response_delay: float | None = None,
        job_timeout: float = DEFAULT_JOB_TIMEOUT,
        rx_tolerance: float | None = None,
        latency: float | None = None,
        silence: float | None = None,
        parity: str = "E",
    ) -> None:
        from pyuss.transport.url import open_transport

        transport = open_transport(port, baud=baud, parity=parity)
        if not isinstance(transport, SerialTransport):
            raise ConfigError(
                f"{port!r}: the blocking master drives a serial port (any pyserial URL, "
                "socket://HOST:PORT for a TCP converter); for tcp:// and bus:// use "
                "pyuss.master.sync.Master"
            )
        self.transport = transport
        self.core = MasterCore(
            transport.baud,
            profile=profile,
            layout=layout,
            mode=ACYCLIC,
            response_delay=response_delay,
            job_timeout=job_timeout,
            rx_tolerance=STAMP_TOLERANCE if rx_tolerance is None else rx_tolerance,
            latency=latency,
            silence=silence,
            loopback=transport.url.startswith("loop://"),
        )
        self.baud = self.core.baud
        self._line = _Line(self.core, transport)
        self._bus = _Bus(self)
        self._lock = threading.RLock()
        self._open = False
        self._drives: dict[int, sync_drive.Drive] = {}

    # -- life cycle ------------------------------------------------------------------------
    def open(self) -> None:
        """Open the port."""
        with self._lock:
            if not self._open:
                self.transport.open_port()
                self._open = True

    def close(self) -> None:
        """Close the port; what a drive handle asks afterwards is refused."""
        with self._lock:
            if self._open:
                self._open = False
                self.transport.close_port()

    def __enter__(self) -> Master:
        self.open()
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    @property
    def running(self) -> bool:
        return self._open

    def _ensure_open(self) -> None:
        if not self._open:
            raise MasterClosed("the master is not open: use 'with Master(...)'")

    def _line_run(self, done: Callable[[], bool], deadline: float) -> None:
        try:
            self._line.run(done, deadline)
        except BaseException:  # Ctrl+C, the port lost: what this call asked for is not sent later
            self.core.abandon()
            raise

    # what `pyuss.master.sync_drive.Drive` hands its calls to
    def _call(self, coro: Coroutine[Any, Any, T]) -> T:
        with self._lock:
            try:
                coro.send(None)
            except StopIteration as stop:
                return stop.value  # type: ignore[no-any-return]
            coro.close()
        raise RuntimeError("a call of the blocking master waited for something")  # a bug

    def _run(self, func: Callable[[], T]) -> T:
        with self._lock:
            return func()

    # -- drives ----------------------------------------------------------------------------
    def drive(
        self,
        address: int,
        *,
        layout: Layout | str | None = None,
        profile: Profile | str | None = None,
        response_delay: float | None = None,
    ) -> sync_drive.Drive:
        """The handle of the slave at ``address`` (the same object on every call); the first
        call fixes its ``layout``, ``profile`` and ``response_delay`` limit."""
        with self._lock:
            slave = self.core.add_slave(
                address, layout=layout, profile=profile, response_delay=response_delay
            )
            handle = self._drives.get(address)
            if handle is None:
                handle = sync_drive.Drive(self, AsyncDrive(self._bus, slave))
                self._drives[address] = handle
            return handle

    @property
    def drives(self) -> tuple[sync_drive.Drive, ...]:
        return tuple(self._drives[a] for a in sorted(self._drives))

    def exchange(self, address: int, *, timeout: float | None = None) -> DriveStatus:
        """One telegram to ``address`` now, with the process data in force; its answer."""
        return self.drive(address).next_update(timeout=timeout)

    def _special(self, kind: str, frame: bytes, address: int) -> object:
        with self._lock:
            self._ensure_open()
            box: _Box[object] = _Box()
            self.core.add_special(kind, frame, address, box)
            self._line_run(box.done, clock() + 60.0)
            if box.error is not None:
                raise box.error
            return box.value

    def mirror(self, address: int, data: bytes | None = None) -> MirrorResult:
        """A mirror telegram (A 5.3), as `pyuss.master.Master.mirror`."""
        result = self._special("mirror", self.core.mirror_frame(address, data), address)
        assert isinstance(result, MirrorResult)
        return result

    def request(self, telegram: Telegram) -> Reply | None:
        """Any telegram and the answer of its address, as `pyuss.master.Master.request`."""
        if not isinstance(telegram, Telegram):
            raise ConfigError(f"request needs a Telegram, not {telegram!r}")
        if telegram.mode.is_broadcast:
            self._special("broadcast", telegram.encode(), 0)
            return None
        result = self._special("request", telegram.encode(), telegram.address)
        assert result is None or isinstance(result, Reply)
        return result

    def broadcast(self, pzd: Sequence[int], *, layout: Layout | None = None) -> int:
        """A broadcast of process data (A 3); how many answered it (0 unless one breaks A 3)."""
        data = self.core.broadcast_data(list(pzd), None, None, layout)
        answered = self._special("broadcast", Telegram(0, AddressMode.BROADCAST, data).encode(), 0)
        return answered if isinstance(answered, int) else 0

    def on_spontaneous(self, callback: Callable[[SpontaneousMessage], object]) -> None:
        """Call ``callback`` for every new spontaneous message of any slave (C 4.2.1.2)."""
        self.core.on_spontaneous(callback)

    def diagnostics(self) -> BusDiagnostics:
        """A snapshot of the line and of every slave."""
        return self.core.snapshot(clock())
