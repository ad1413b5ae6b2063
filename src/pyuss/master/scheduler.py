"""The bus master: poll list, cycle, line timing, answers, process data and job turns.

One `Master` runs one bus with one task, the scheduler, which alone talks to the transport:
every telegram on the line is one "turn" of the scheduler, so nothing interleaves however many
tasks (or threads, through `pyuss.master.sync`) use the bus at once.

Telegram traffic (A 2, A 5.1)
    - Cyclic mode (the default, A 2.1): the master goes round the poll list ("Umlaufliste",
      A 5.1) again and again; an address may appear several times to be served more often; a
      one-entry list is a point-to-point link. With ``cycle_time`` the master waits after the
      last entry for the rest of the cycle (A 5.1.1); `Master.cycle_stats` gives the achieved
      cycle time, its jitter and the overruns.
    - Acyclic mode (A 2.2): telegrams only on demand - a slave gets turns while it has a
      parameter job, new process data to deliver, or a `Master.exchange` asks for one.
    - Between turns the scheduler sends what was asked of it: broadcasts (`Master.broadcast`)
      and mirror telegrams (`Master.mirror`).

Timing (A 5.1.2, A 5.2.1)
    - Before every telegram the master keeps a start pause after the end of the last byte on
      the line, its own or received (chunk timestamps): 2 character times, or more where the
      slave's profile asks for more (reading 2).
    - The answer must begin within the slave's response delay limit (20 ms by default, never
      below the start pause; a profile or the caller may set another) after the end of the
      request, and the core `Receiver` checks its residual time and BCC. Otherwise the master
      marks "slave x does not send" (`Drive.not_sending`), counts the timeout (A 5.2.3 bit 7
      and counter 16) and goes on with the next entry; the mark is cleared only by the next
      good telegram from that slave, which stays in the poll list. A slave that answers late
      is treated the same and its answer is not used. `Drive.missed` counts the telegrams
      in a row without a usable answer (silent, late or garbled), `Drive.on_missed` is told
      of each.
    - Answers from another address or of another type, and answers that do not fit the
      slave's layout, are discarded and counted (A 5.2, A 5.2.2). Telegrams that arrive when no
      answer is awaited are counted as stray; after a broadcast the master listens for one
      response delay: nobody may answer (A 3), and whoever does is counted.

Time bases
    All times are the transport's ``clock()``. Transports with exact timestamps (the virtual
    bus in-process and ``bus://``) are judged exactly by the rules above. Other transports
    (serial ports, ptys, TCP) stamp bytes when the program reads them, which USB adapters do in
    bursts every 1..16 ms; for them ``rx_tolerance`` (default 20 ms,
    `pyuss.transport.base.stamp_tolerance`) widens the receive side only: the receiver takes
    it as the tolerance of the stamps (`Receiver(tolerance=...)`, shared with the monitor: a
    gap inside a telegram shorter than the tolerance is the stamps' and closed, so the
    residual-time check of A 5.2.1.2 is not fooled by a late stamp, and the idle gap that ends
    an incomplete telegram is at least the tolerance), and the answer may begin up to the
    tolerance after the response delay limit. The master's own
    sending keeps at least the specification's start pause always. ``latency`` (default 20 ms)
    is how long after a deadline the master still waits for bytes that were on the line in
    time but not yet delivered: before it takes a telegram for broken off, and, as
    ``silence`` unless that is given, after the response window (and the end of a first
    character that began at its end) before it takes a slave for silent; that only costs
    time when a slave is silent. `pyuss.master.scan` waits `EXACT_LATENCY` there on the
    virtual bus, which hands characters over within microseconds.

    On the virtual bus the master hands each telegram over a moment before its start pause
    ends, with the time it is to start (`pyuss.bus.timed`), so the pause is kept to the
    microsecond; elsewhere it sleeps until shortly before and yields to the event loop for
    the rest (`pyuss.loop`), which is as exact as the machine allows on any event loop.
    There, for a slave of fixed layout, it also waits for the whole answer at once
    (`QueuedTransport.wait_bytes`) instead of waking for each of the bus's three hand-overs
    of a telegram: the chunks keep their end times on the line, so the answer is judged
    exactly as before, and only an answer that is not all in by the end of the response
    window is followed chunk by chunk.

    The end of a request is taken as the time the write began plus its characters' time on the
    line (or the time the write returned, if later). Over a bare pty or TCP link the answer's
    start is estimated from when its last byte was read: a peer that writes faster than a real
    line reads as answering sooner (down to 0; `uss simulate` paces its answers).

Process data (C 5.1)
    Every telegram to a slave carries its latest control word and setpoints, as the user set
    them at the moment the telegram is built - once the start pause before it is over, so
    nothing set earlier is left for the next turn; every answer updates the slave's status first,
    before the parameter channel looks at it, and wakes `Drive.next_update` waiters and
    `Drive.on_update` callbacks.

Parameter jobs (C 4.2.1.1, C 4.2.1.2): see `pyuss.master.jobs`.

A lost line
    On a transport that reopens a lost link (`pyuss.transport.reconnect`) a write while it
    is down raises `LinkDown`: the master then sends nothing until the link is back
    (`LINK_POLL`), takes every slave for not sending (nothing is heard of any), fails the
    parameter jobs, process data and special telegrams waiting for the line with `LinkDown`
    and refuses new ones at once (a wait for a slave's next answer waits on, within its
    time). `Master.online` says whether it exchanges on the line, `Master.on_line` tells
    of each change. After the link is back it sends what it sent before - the process data
    in force, the poll list -, nothing it was asked for while the link was down. A transport
    that fails for good stops the master (`Master.lost`).
"""

from __future__ import annotations

import asyncio
import contextlib
import enum
import logging
import math
from collections import deque
from collections.abc import Awaitable, Callable, Collection, Iterable, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING

from pyuss import _callbacks
from pyuss._tasks import cancel_and_wait
from pyuss.errors import ConfigError, TelegramError, TransportError, UssError, UssTimeout
from pyuss.log import log_frame
from pyuss.loop import COARSE_MARGIN
from pyuss.loop import margin as loop_margin
from pyuss.master.drive import Drive
from pyuss.master.errors import MasterClosed, MirrorMismatch, NotSending
from pyuss.master.jobs import Job, ParameterChannel, SpontaneousMessage
from pyuss.master.process import DriveStatus
from pyuss.master.profile import Profile, resolve_profile, response_limit
from pyuss.master.stats import (
    BusDiagnostics,
    CycleStats,
    Samples,
    SlaveCounts,
    SlaveDiagnostics,
)
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.diagnostics import Diagnostics, FaultKind
from pyuss.protocol.frozen import builder
from pyuss.protocol.layout import Layout, NetData
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.receiver import Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import MAX_ADDRESS, AddressMode, Telegram
from pyuss.protocol.timing import LineTiming
from pyuss.transport.base import STAMP_TOLERANCE, Chunk, Transport, stamp_tolerance
from pyuss.transport.queued import check_baud
from pyuss.transport.reconnect import LinkDown, ReconnectingTransport

if TYPE_CHECKING:
    from pyuss.bus.timed import TimedWrite

__all__ = ["ACYCLIC", "CYCLIC", "Master", "MirrorResult", "Mode", "Reply"]

log = logging.getLogger("pyuss.master")

DEFAULT_TOLERANCE = STAMP_TOLERANCE
"""Receive tolerance for transports that stamp bytes when read (USB adapters: 1..16 ms)."""
DEFAULT_LATENCY = 0.020
"""How long past a deadline the master still waits for bytes that were on the line in time."""
EXACT_LATENCY = 0.004
"""How long the master waits for the first character of an answer beyond the response window
on a virtual bus, which hands each character over within microseconds of its end
(milliseconds on a loaded machine): what a silent address costs beyond its window."""
DEFAULT_JOB_TIMEOUT = 2.0
_JOB_CHECK = 0.05
"""Longest wait for the line during an exchange before the jobs of other slaves are looked at
(only a long response delay limit waits longer than this at once)."""
STRAY_ALARM = 10
"""Telegrams nobody asked for that, within `STRAY_WINDOW` seconds, are told of (once)."""
STRAY_WINDOW = 10.0
LINK_POLL = 0.05
"""How often the master looks whether a lost link is back (seconds); it sends nothing
meanwhile."""
_MIRROR_BIT = int(AddressMode.MIRROR)
"""ADR bit 6: a mirror telegram (A 5.3), byte 2 of a telegram."""


class Mode(enum.Enum):
    """Telegram traffic (A 2)."""

    CYCLIC = "cyclic"
    """Go round the poll list continuously (A 2.1); what drives need."""
    ACYCLIC = "acyclic"
    """Telegrams only on demand (A 2.2); slaves cannot watch for telegram failures."""


CYCLIC = Mode.CYCLIC
ACYCLIC = Mode.ACYCLIC


def _timed_writer(transport: Transport) -> TimedWrite | None:
    """`pyuss.bus.timed.timed_writer` (imported only here: the bus is loaded for its stations),
    also through a reconnecting ``bus://`` station."""
    from pyuss.bus.timed import timed_writer

    if isinstance(transport, ReconnectingTransport):
        return transport.timed_writer()
    return timed_writer(transport)


class _LineDown(Exception):
    """A telegram could not be sent: the link is down (`Master._line_down`)."""


@dataclass(frozen=True, slots=True)
class Reply:
    """The answer to `Master.request`."""

    telegram: Telegram
    raw: bytes
    response_time: float
    """From the end of the request to the start of the answer (seconds)."""


@dataclass(frozen=True, slots=True)
class MirrorResult:
    """A mirror test that passed (A 5.3): the slave returned the telegram unchanged."""

    address: int
    sent: bytes
    response_time: float
    """From the end of the request to the start of the answer (seconds)."""
    round_trip: float
    """From the start of the request to the end of the answer (seconds)."""


_NORMAL = frozenset({AddressMode.NORMAL})

_drive_status = builder(DriveStatus)
_slave_counts = builder(SlaveCounts)
"""`DriveStatus` of an answer and `SlaveCounts` of a slave, made at every answer
(`pyuss.protocol.frozen.builder`)."""

WaitBytes = Callable[[int, float], Awaitable[None]]
"""``wait_bytes(count, timeout)`` of `pyuss.transport.queued.QueuedTransport`."""


class _Outcome(enum.Enum):
    ANSWER = "answer"
    SILENT = "silent"
    FAULT = "fault"
    LATE = "late"


@dataclass(slots=True)
class _Result:
    outcome: _Outcome
    received: Received | None
    request_start: float
    request_end: float


class _Link:
    """Everything the master keeps about one slave."""

    def __init__(
        self,
        address: int,
        layout: Layout,
        profile: Profile,
        response_delay: float,
        named: bool = True,
    ) -> None:
        self.address = address
        self.layout = layout
        self.profile = profile
        self.named = named
        """The profile was named (by the caller or the drive): its parameter facts apply."""
        self.response_delay = response_delay
        self.channel = ParameterChannel(address, profile)
        self.control = 0
        self.setpoints = [0] * max(layout.pzd - 1, 0)
        self.version = 0
        self.answered_version = 0
        self.status: DriveStatus | None = None
        self.diagnostics = Diagnostics()
        self.not_sending = False
        self.exchanges = 0
        self.answers = 0
        self.timeouts = 0
        self.late = 0
        self.wrong_address = 0
        self.unusable = 0
        self.response_times = Samples()
        self.missed = 0
        """Telegrams in a row without a usable answer (0 after an answer)."""
        self.miss_callbacks: list[Callable[[int], object]] = []
        self.polls_wanted = 0
        self.update_waiters: list[asyncio.Future[DriveStatus]] = []
        self.version_waiters: list[tuple[int, asyncio.Future[DriveStatus]]] = []
        self.update_callbacks: list[Callable[[DriveStatus], object]] = []
        self.spontaneous_callbacks: list[Callable[[SpontaneousMessage], object]] = []
        self.drive: Drive | None = None
        self._request_key: tuple[object, ...] | None = None
        self._request = b""
        """The last telegram made without a job, and what it was made from."""

    def pzd(self) -> list[int]:
        if not self.layout.pzd:
            return []
        return [self.control, *self.setpoints]

    def request(self, now: float) -> bytes:
        """The telegram to this slave at ``now``: the PKW area of its job (or "no job") and
        the newest process data. Without a job open or queued the PKW area is "no job"
        whatever the time, so the telegram is made once for the same process data (and
        spontaneous-message toggle bit) and sent again as it is, as a cyclic master does."""
        channel = self.channel
        layout = self.layout
        key: tuple[object, ...] | None = None
        if not layout.pkw or (channel.current is None and not channel.queue):
            key = (layout, channel.toggle, self.control, *self.setpoints)
            if key == self._request_key:
                return self._request
        pkw = channel.request(now) if layout.pkw else None
        data = layout.pack(pkw, self.pzd())
        frame = Telegram(self.address, AddressMode.NORMAL, data).encode()
        self._request_key, self._request = key, frame
        return frame

    @property
    def wants_turn(self) -> bool:
        """Acyclic mode: a job, process data not yet answered, or an exchange asked for."""
        return self.channel.busy or self.answered_version < self.version or self.polls_wanted > 0

    def counts(self, now: float) -> SlaveCounts:
        return _slave_counts(
            self.diagnostics.snapshot(now), self.exchanges, self.answers, self.timeouts
        )

    def snapshot(self, now: float) -> SlaveDiagnostics:
        return SlaveDiagnostics(
            address=self.address,
            not_sending=self.not_sending,
            counters=self.diagnostics.snapshot(now),
            exchanges=self.exchanges,
            answers=self.answers,
            timeouts=self.timeouts,
            late=self.late,
            wrong_address=self.wrong_address,
            unusable=self.unusable,
            response_time=self.response_times.summary(),
            jobs=self.channel.stats(),
        )


@dataclass(slots=True)
class _Special:
    kind: str
    frame: bytes
    address: int
    future: asyncio.Future[object]


MAX_CYCLE_TIME = 60.0
"""The longest fixed cycle time (seconds): every drive goes that long without a telegram, and a
drive's telegram monitoring is set to seconds, not minutes."""


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
    allows. ``mode``: `CYCLIC` or `ACYCLIC`. ``response_delay``: the default response delay limit in
    seconds (else the profile's, 20 ms). ``job_timeout``: seconds a parameter job may take
    from its first telegram. ``rx_tolerance`` and ``latency``: see "Time bases" in the module
    docstring (None picks by transport); ``silence``: the wait for a silent slave beyond its
    response window (default ``latency``). ``close_transport``: close the transport on exit.

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
        if isinstance(transport, str):
            from pyuss.transport.url import open_transport

            transport = open_transport(transport, baud=check_baud(baud or 9600))
        elif not isinstance(transport, Transport):
            raise ConfigError(f"transport must be a Transport or a URL, not {transport!r}")
        if baud is not None and check_baud(baud) != transport.baud:
            raise ConfigError(f"baud {baud} given, but the transport runs at {transport.baud}")
        if not isinstance(mode, Mode):
            raise ConfigError(f"mode must be CYCLIC or ACYCLIC, not {mode!r}")
        if cycle_time is not None and not (
            isinstance(cycle_time, int | float)
            and not isinstance(cycle_time, bool)
            and 0 < cycle_time <= MAX_CYCLE_TIME
        ):
            raise ConfigError(
                f"cycle time must be a number of seconds above 0 and at most {MAX_CYCLE_TIME:g} "
                f"(a drive's telegram monitoring waits seconds), not {cycle_time!r}"
            )
        for name, value in (("job_timeout", job_timeout), ("response_delay", response_delay)):
            if value is not None and (isinstance(value, bool) or not value > 0):
                raise ConfigError(f"{name} must be a positive number of seconds, not {value!r}")
        for name, value in (
            ("rx_tolerance", rx_tolerance),
            ("latency", latency),
            ("silence", silence),
        ):
            if value is not None and (isinstance(value, bool) or not value >= 0):
                raise ConfigError(f"{name} must be >= 0 seconds, not {value!r}")
        self.transport = transport
        self.baud = transport.baud
        self.timing = LineTiming(self.baud)
        self.profile = resolve_profile(profile)
        self.profile_named = profile is not None
        """A profile was given; without one the drives are of unknown kind: the telegrams
        follow the USS specification (the ``generic`` profile's rules), but no family's
        parameter facts are applied to them (`pyuss.master.drive.Drive.params`)."""
        if isinstance(layout, str):
            layout = Layout.parse(layout)
        self.default_layout = self.profile.check_layout(layout or self.profile.default_layout)
        self.cycle_time = float(cycle_time) if cycle_time is not None else None
        self.mode = mode
        self.response_delay = response_delay
        self.job_timeout = float(job_timeout)
        self.rx_tolerance = stamp_tolerance(transport) if rx_tolerance is None else rx_tolerance
        self.latency = DEFAULT_LATENCY if latency is None else latency
        self.silence = self.latency if silence is None else silence
        self.close_transport = close_transport
        self._links: dict[int, _Link] = {}
        self._poll: list[int] = []
        self._specials: list[_Special] = []
        self._spontaneous_callbacks: list[Callable[[SpontaneousMessage], object]] = []
        self._line = Diagnostics()
        self._receiver = Receiver(
            self.baud,
            tolerance=self.rx_tolerance,
            diagnostics=self._line,
            residual_extra_chars=self.profile.residual_extra_chars,
        )
        self._line_free = -math.inf
        self._after_broadcast = False
        self._broadcasts = 0
        self._answered_broadcasts = 0
        self._stray = 0
        self._stray_times: deque[float] = deque(maxlen=STRAY_ALARM)
        self._stray_told = False
        self._own_heard = 0
        self._exact = self.transport.exact_timestamps
        self._sent_frame = b""
        self._sent_end = -math.inf
        self._echo_in = False
        """The echo of the latest request was heard (a line that echoes gives back one copy)."""
        self._loopback = str(getattr(self.transport, "url", "")).startswith("loop://")
        """pyserial's loopback: every copy of a request is its echo."""
        self._cycles = Samples()
        self._cycle_count = 0
        self._overruns = 0
        self._last_cycle_start: float | None = None
        self._wake: asyncio.Event | None = None
        self._task: asyncio.Task[None] | None = None
        self._failure: TransportError | None = None
        self._lost: TransportError | None = None
        """What stopped the master on its own (the port failed for good)."""
        self._down: LinkDown | None = None
        """While the link is down (being reopened): what requests are refused with."""
        self._line_callbacks: list[Callable[[TransportError | None], object]] = []
        self._closing = False
        self._rotation = 0
        self._submitted = 0
        self._idle_at: int | None = None
        """`_submitted` when no slave had a job open or queued: until the next job is
        submitted none has (jobs only end meanwhile), and the slaves need not be looked at."""
        self._read_nowait: Callable[[], Chunk | None] | None = getattr(
            transport, "read_nowait", None
        )
        """`QueuedTransport.read_nowait`, where the transport has it: a look for chunks
        without a coroutine (the master looks several times per telegram)."""
        self._wait_bytes: WaitBytes | None = getattr(transport, "wait_bytes", None)
        """`QueuedTransport.wait_bytes`, where the transport has it (`_whole_answer`)."""
        self._margin = COARSE_MARGIN
        self._write_at = _timed_writer(transport)
        self._woken: _Link | None = None
        """The slave whose last answer woke tasks waiting for it (`_send`'s early
        hand-over)."""

    # -- life cycle ------------------------------------------------------------------------
    async def __aenter__(self) -> Master:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    @property
    def online(self) -> bool:
        """Whether the master exchanges telegrams on the line: started, not stopped or
        closing, and the link up (see "A lost line" in the module docstring)."""
        return (
            self.running
            and self._down is None
            and not self._closing
            and getattr(self.transport, "connected", True)
        )

    @property
    def lost(self) -> TransportError | None:
        """What stopped the master on its own - its port failed and was not reopened -; None
        while it runs, and for a master that only was closed."""
        return self._lost

    def on_line(self, callback: Callable[[TransportError | None], object]) -> Callable[[], None]:
        """Call ``callback`` when the line is lost (with the error: the link is down and
        being reopened, or the master stopped - then `lost` is set) and when it is back
        (None). Returns a function that removes it. Whoever follows the line reports its
        loss for good; while nobody does, the master logs it itself (ERROR)."""
        return _callbacks.add(self._line_callbacks, callback)

    def _tell_line(self, error: TransportError | None) -> None:
        _callbacks.call_each(self._line_callbacks, error, log, "line callback failed")

    async def start(self) -> None:
        """Open the transport and start the scheduler."""
        if self._task is not None:
            raise ConfigError("the master was started already")
        await self.transport.open()
        self._wake = asyncio.Event()
        self._margin = loop_margin()
        self._task = asyncio.create_task(self._run(), name=f"uss master {self.baud} baud")

    async def close(self) -> None:
        """Stop after the current telegram, fail what waits, close the transport."""
        self._closing = True
        if self._wake is not None:
            self._wake.set()
        if self._task is not None:
            task = self._task
            try:
                async with asyncio.timeout(self._stop_time()):
                    await asyncio.shield(task)
            except TimeoutError:
                await cancel_and_wait(task)
        self._fail(self._failure or MasterClosed("the master was closed"))
        if self.close_transport:
            await self.transport.close()

    def _stop_time(self) -> float:
        longest = max((link.response_delay for link in self._links.values()), default=0.02)
        return 1.0 + longest + self.latency + self.timing.transmit(512)

    def _fail(self, error: TransportError) -> None:
        if self._failure is None:
            self._failure = error
        self._fail_waiting(error, updates=True)

    def _fail_waiting(self, error: TransportError, *, updates: bool) -> None:
        """Fail the jobs, process data and special telegrams waiting for the line (and, with
        ``updates``, the waits for a slave's next answer) with ``error``."""
        for link in self._links.values():
            link.channel.fail_all(error)
            if updates:
                for future in link.update_waiters:
                    if not future.done():
                        future.set_exception(error)
                link.update_waiters.clear()
            for _, future in link.version_waiters:
                if not future.done():
                    future.set_exception(error)
            link.version_waiters.clear()
        for special in self._specials:
            if not special.future.done():
                special.future.set_exception(error)
        self._specials.clear()

    def _check_usable(self, *, line: bool = True) -> None:
        """Refuse a request the master cannot carry out: stopped, closing, not started, or
        (``line``: one that needs the line now) the link down."""
        if self._failure is not None:
            raise self._failure
        if self._closing:
            raise MasterClosed("the master is closing")
        if self._task is None:
            raise MasterClosed("the master is not started: use 'async with Master(...)'")
        if line and self._down is None and not getattr(self.transport, "connected", True):
            self._line_down(LinkDown("the link is down"))  # (a loss no read noticed yet)
        if line and self._down is not None:
            raise LinkDown(str(self._down))

    def _poke(self) -> None:
        if self._wake is not None:
            self._wake.set()

    # -- drives and the poll list ----------------------------------------------------------
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
        if isinstance(address, bool) or not isinstance(address, int):
            raise ConfigError(f"slave address must be an integer 0..{MAX_ADDRESS}, not {address!r}")
        if not 0 <= address <= MAX_ADDRESS:
            raise ConfigError(f"slave address must be 0..{MAX_ADDRESS}, not {address}")
        if isinstance(layout, str):
            layout = Layout.parse(layout)
        prof = resolve_profile(profile) if profile is not None else None
        link = self._links.get(address)
        if link is not None:
            if layout is not None and layout != link.layout:
                raise ConfigError(f"slave {address} uses layout {link.layout}, not {layout}")
            if prof is not None and prof.name != link.profile.name:
                raise ConfigError(
                    f"slave {address} uses profile {link.profile.name}, not {prof.name}"
                )
            if response_delay is not None and response_delay != link.response_delay:
                raise ConfigError(
                    f"slave {address} has response delay limit {link.response_delay:g} s"
                )
        else:
            named = prof is not None or self.profile_named
            prof = prof or self.profile
            if layout is None:
                layout = self.default_layout if prof is self.profile else prof.default_layout
            prof.check_layout(layout)
            if response_delay is not None and (
                isinstance(response_delay, bool) or not response_delay > 0
            ):
                raise ConfigError(f"response delay must be > 0 seconds, not {response_delay!r}")
            limit = response_limit(prof, self.baud, response_delay or self.response_delay)
            link = _Link(address, layout, prof, limit, named)
            link.drive = Drive(self, link)
            self._links[address] = link
            if layout.lge is not None:
                self._receiver.fixed_lengths[address] = layout.lge
        if poll and address not in self._poll:
            self._poll.append(address)
            self._poke()
        assert link.drive is not None
        return link.drive

    @property
    def drives(self) -> tuple[Drive, ...]:
        """Every drive handle made so far, by address."""
        return tuple(self._links[a].drive for a in sorted(self._links))  # type: ignore[misc]

    @property
    def poll_list(self) -> tuple[int, ...]:
        """The addresses of the poll list in order (A 5.1)."""
        return tuple(self._poll)

    def set_poll_list(self, addresses: Iterable[int]) -> None:
        """Set the poll list; an address may appear several times (A 5.1). Addresses without a
        drive handle get one with the master's defaults."""
        entries = list(addresses)
        for address in entries:
            self.drive(address, poll=False)
        self._poll = entries
        self._poke()

    def on_spontaneous(self, callback: Callable[[SpontaneousMessage], object]) -> None:
        """Call ``callback`` for every new spontaneous message of any slave (C 4.2.1.2)."""
        self._spontaneous_callbacks.append(callback)

    # -- what drives and users ask ---------------------------------------------------------
    def _clock(self) -> float:
        return self.transport.clock()

    async def _job(
        self, link: _Link, request: Pkw, pnu: int, index: int | None, timeout: float | None
    ) -> Pkw:
        self._check_usable()
        if not link.layout.pkw:
            raise ConfigError(
                f"slave {link.address} has layout {link.layout}: without a PKW area no "
                "parameter can be read or written (C 4.1)"
            )
        if self.mode is Mode.CYCLIC and link.address not in self._poll:
            raise ConfigError(
                f"slave {link.address} is not in the poll list: it gets no telegrams in cyclic mode"
            )
        loop = asyncio.get_running_loop()
        future: asyncio.Future[Pkw] = loop.create_future()

        def done(job: Job) -> None:
            if future.done():
                return
            if job.error is not None:
                future.set_exception(job.error)
            else:
                assert job.answer is not None
                future.set_result(job.answer)

        job = Job(request, pnu, index, self.job_timeout if timeout is None else timeout, done)
        link.channel.submit(job, self._clock())
        self._submitted += 1
        self._poke()
        try:
            return await future
        except asyncio.CancelledError:
            link.channel.cancel(job)
            raise

    def _set_pzd(
        self, link: _Link, control: int | None = None, setpoints: dict[int, int] | None = None
    ) -> int:
        """Change process data; returns the version to wait for."""
        if control is not None:
            link.control = int(control) & 0xFFFF
        for number, value in (setpoints or {}).items():
            link.setpoints[number - 2] = value & 0xFFFF
        link.version += 1
        self._poke()
        return link.version

    async def _delivered(self, link: _Link, version: int, timeout: float | None) -> DriveStatus:
        """Wait for the answer to a telegram that carried process data ``version``."""
        self._check_usable()
        if self.mode is Mode.CYCLIC and link.address not in self._poll:
            raise ConfigError(f"slave {link.address} is not in the poll list")
        if link.answered_version >= version and link.status is not None:
            return link.status
        future: asyncio.Future[DriveStatus] = asyncio.get_running_loop().create_future()
        link.version_waiters.append((version, future))
        self._poke()
        return await self._await_status(link, future, timeout)

    async def _next_update(self, link: _Link, timeout: float | None) -> DriveStatus:
        self._check_usable(line=False)  # the answer may come once the link is back
        future: asyncio.Future[DriveStatus] = asyncio.get_running_loop().create_future()
        link.update_waiters.append(future)
        if self.mode is Mode.ACYCLIC:
            link.polls_wanted += 1
            self._poke()
        return await self._await_status(link, future, timeout)

    async def _await_status(
        self, link: _Link, future: asyncio.Future[DriveStatus], timeout: float | None
    ) -> DriveStatus:
        wait = self.job_timeout if timeout is None else timeout
        try:
            async with asyncio.timeout(wait):
                return await future
        except TimeoutError:
            if link.not_sending:
                raise NotSending(link.address, f"no answer within {wait:g} s") from None
            raise UssTimeout(f"slave {link.address}: no answer within {wait:g} s") from None

    async def exchange(self, address: int, *, timeout: float | None = None) -> DriveStatus:
        """One telegram to ``address`` now (acyclic mode) or its next answer (cyclic)."""
        link = self._links.get(address)
        if link is None:
            raise ConfigError(f"no drive at address {address}: call bus.drive({address}) first")
        return await self._next_update(link, timeout)

    async def mirror(self, address: int, data: bytes | None = None) -> MirrorResult:
        """Send a mirror telegram (A 5.3) to ``address`` and check that it comes back unchanged.

        ``data``: the net data (default: a test pattern of the length of the slave's telegrams -
        its fixed length, or the shortest variable one - so that the slave accepts it; 5 words
        for an address without a drive handle). Raises `MirrorMismatch` or `NotSending`.
        """
        self._check_usable()
        link = self._links.get(address)
        if data is None:
            if link is None:
                count = 5
            else:
                words = link.layout.words
                count = 3 + link.layout.pzd if words is None else words
            data = bytes((0x55 + 0x11 * i) & 0xFF for i in range(2 * count))
        try:
            frame = Telegram(address, AddressMode.MIRROR, bytes(data)).encode()
        except (TelegramError, TypeError) as exc:
            raise ConfigError(f"mirror telegram to {address!r}: {exc}") from None
        result = await self._special("mirror", frame, address)
        assert isinstance(result, MirrorResult)
        return result

    async def request(self, telegram: Telegram) -> Reply | None:
        """Send any telegram between the turns of the poll list and return the answer of its
        address (of the same type; a special telegram may be answered by a normal one), or
        None when none came within the response delay limit. Broadcasts return None at once
        after the listening time. For probing, special telegrams (A 5.4) and tools; the
        slave's process data and parameter channel are not touched.
        """
        self._check_usable()
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
        if enable is not None:
            if pkw is not None:
                raise ConfigError("give a Broadcast Enable Array or PKW words, not both")
            from pyuss.master.broadcast import enable_array_data

            return await self._broadcast(enable_array_data(pzd, enable, layout))
        if layout is None:
            layout = Layout(4 if pkw is not None else 0, len(pzd))
        area = pkw if pkw is None or isinstance(pkw, Pkw) else Pkw.from_words(list(pkw))
        return await self._broadcast(layout.pack(area, list(pzd)))

    async def broadcast_control(
        self,
        control: int,
        *,
        mask: int = 0xFFFF,
        layout: Layout,
        addresses: Iterable[int] | None = None,
    ) -> int:
        """Baumueller's broadcast (Baumueller manual 2.2, reading 9): ``control`` merged into the
        control
        word of every drive (or of ``addresses`` with broadcast coding) through ``mask``; see
        `pyuss.master.broadcast.masked_control_data`. Returns as `broadcast`."""
        from pyuss.master.broadcast import masked_control_data

        return await self._broadcast(
            masked_control_data(control, mask, layout=layout, addresses=addresses)
        )

    async def _broadcast(self, data: bytes, mode: AddressMode = AddressMode.BROADCAST) -> int:
        self._check_usable()
        frame = Telegram(0, mode, data).encode()
        answered = await self._special("broadcast", frame, 0)
        assert isinstance(answered, int)
        return answered

    async def _special(self, kind: str, frame: bytes, address: int) -> object:
        self._check_usable()
        future: asyncio.Future[object] = asyncio.get_running_loop().create_future()
        self._specials.append(_Special(kind, frame, address, future))
        self._poke()
        return await future

    # -- figures ---------------------------------------------------------------------------
    def cycle_stats(self) -> CycleStats:
        """Achieved cycle times (A 5.1.1)."""
        return CycleStats(
            cycles=self._cycle_count,
            cycle_time=self.cycle_time,
            achieved=self._cycles.summary(),
            overruns=self._overruns,
        )

    def diagnostics(self) -> BusDiagnostics:
        """A snapshot of the line and of every slave."""
        now = self._clock()
        return BusDiagnostics(
            baud=self.baud,
            line=self._line.snapshot(now),
            cycles=self.cycle_stats(),
            broadcasts=self._broadcasts,
            answered_broadcasts=self._answered_broadcasts,
            stray=self._stray,
            own_heard=self._own_heard,
            slaves=tuple(self._links[a].snapshot(now) for a in sorted(self._links)),
        )

    def _slave_diagnostics(self, link: _Link) -> SlaveDiagnostics:
        return link.snapshot(self._clock())

    def _slave_counts(self, link: _Link) -> SlaveCounts:
        return link.counts(self._clock())

    # -- the scheduler ---------------------------------------------------------------------
    async def _run(self) -> None:
        try:
            while not self._closing:
                if self._down is not None:
                    await self._ride_out()  # then the next telegram tries the line
                    if self._closing:
                        break
                try:
                    if self._specials and await self._do_specials():
                        continue
                    if self.mode is Mode.CYCLIC:
                        await self._cycle()
                    else:
                        link = self._next_demand()
                        if link is None:
                            await self._sleep(None)
                        else:
                            await self._turn(link)
                except _LineDown:
                    continue
        except TransportError as exc:
            if not self._line_callbacks:
                log.error("master stopped: %s", exc)
            self._stopped(exc)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a bug must not leave waiters hanging
            log.exception("master stopped by an internal error")
            self._stopped(MasterClosed(f"the master stopped: {exc!r}"))

    def _stopped(self, error: TransportError) -> None:
        """The master stopped on its own: nothing is heard any more, nothing waits on."""
        self._stopped_hearing()
        self._fail(error)
        self._lost = error
        self._tell_line(error)

    def _line_down(self, error: LinkDown) -> None:
        """A telegram could not be sent, the link is down (and being reopened): nothing is
        heard of any slave, what waits for the line fails, and nothing is sent until the
        link is back (`_ride_out`)."""
        if self._down is not None:
            return
        self._down = LinkDown(f"the line is down, being reopened ({error}): not sent")
        self._stopped_hearing()
        for link in self._links.values():
            link.missed = 0  # nothing was missed by the slaves: nothing was sent to them
        self._fail_waiting(self._down, updates=False)
        self._tell_line(self._down)
        self._poke()  # an idle scheduler waits for the link instead (`_ride_out`)

    async def _ride_out(self) -> None:
        """Wait, sending nothing, until the link is back (the transport's ``connected``) or
        the master closes. A transport that does not say is tried by the next telegram: the
        first that goes out ends the outage (`_send`)."""
        while not self._closing:
            await self._sleep(LINK_POLL)
            connected = getattr(self.transport, "connected", None)
            if connected is None:
                return
            if connected:
                self._line_back()
                return

    def _line_back(self) -> None:
        self._down = None
        self._tell_line(None)

    def _stopped_hearing(self) -> None:
        """The master stopped on its own (the port failed): nothing is heard of any slave any
        more, so each does not send (A 5.2.1.1) and no face shows its last answer as now."""
        for link in self._links.values():
            link.not_sending = True
            link.channel.not_sending = True

    async def _sleep(self, timeout: float | None) -> None:
        assert self._wake is not None
        self._wake.clear()
        if self._closing or self._specials:
            return
        if timeout is None:
            await self._wake.wait()
            return
        if timeout > 0:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(timeout):
                    await self._wake.wait()

    async def _cycle(self) -> None:
        entries = tuple(self._poll)
        if not entries:
            self._last_cycle_start = None  # the time without a poll list is no cycle
            await self._sleep(None)
            return
        start = self._clock()
        if self._last_cycle_start is not None:
            self._cycles.add(start - self._last_cycle_start)
        self._last_cycle_start = start
        for address in entries:
            if self._closing:
                return
            if self._specials:  # (a coroutine per poll-list entry spared when none waits)
                await self._do_specials()
            link = self._links.get(address)
            if link is not None:
                await self._turn(link)
        self._cycle_count += 1
        if self.cycle_time is None:
            return
        end = start + self.cycle_time
        if self._clock() > end:
            self._overruns += 1
            return
        while not self._closing:
            now = self._clock()
            left = end - now
            if left <= 0:
                return
            if not await self._do_specials():
                deadline = self._next_deadline()
                if deadline is not None:  # a job running out meanwhile ends on time
                    left = min(left, max(deadline - now, 0.0) + self.timing.char_time)
                await self._sleep(left)
                self._expire_jobs()

    def _next_demand(self) -> _Link | None:
        addresses = sorted(self._links)
        if not addresses:
            return None
        for step in range(len(addresses)):
            address = addresses[(self._rotation + step) % len(addresses)]
            link = self._links[address]
            if link.wants_turn:
                self._rotation = (self._rotation + step + 1) % len(addresses)
                return link
        return None

    async def _do_specials(self) -> bool:
        if not self._specials:
            return False
        while self._specials and not self._closing:
            special = self._specials.pop(0)
            try:
                result = await self._run_special(special)
            except _LineDown:
                if not special.future.done() and self._down is not None:
                    special.future.set_exception(self._down)
                raise
            except TransportError:
                raise
            except UssError as exc:
                if not special.future.done():
                    special.future.set_exception(exc)
            else:
                if not special.future.done():
                    special.future.set_result(result)
            self._expire_jobs()
        return True

    async def _run_special(self, special: _Special) -> object:
        if special.kind == "broadcast":
            self._broadcasts += 1
            pause = max((ln.profile.start_pause_chars for ln in self._links.values()), default=2)
            await self._send(special.frame, pause)
            self._after_broadcast = True
            before = self._answered_broadcasts
            limit = response_limit(self.profile, self.baud, self.response_delay)
            await self._listen(self._line_free + limit + self.rx_tolerance)
            return self._answered_broadcasts - before
        link = self._links.get(special.address)
        pause = (
            link.profile.start_pause_chars if link is not None else self.profile.start_pause_chars
        )
        limit = (
            link.response_delay
            if link is not None
            else response_limit(self.profile, self.baud, self.response_delay)
        )
        mode = Telegram.decode(special.frame).mode
        modes = {mode, AddressMode.NORMAL} if mode is AddressMode.SPECIAL else {mode}
        result = await self._transact(special.frame, special.address, modes, limit, pause, link)
        received = result.received
        if result.outcome is not _Outcome.ANSWER or received is None:
            if special.kind == "request":
                return None
            raise NotSending(special.address, "no answer to the mirror telegram (A 5.3)")
        if link is not None:
            self._good_answer(link, received, result)
        response_time = max(0.0, received.start - result.request_end)
        if special.kind == "request":
            return Reply(received.telegram, received.raw, response_time)
        if received.raw != special.frame:
            raise MirrorMismatch(special.address, special.frame, received.raw)
        return MirrorResult(
            address=special.address,
            sent=special.frame,
            response_time=response_time,
            round_trip=max(0.0, received.end - result.request_start),
        )

    async def _turn(self, link: _Link) -> None:
        """One telegram to ``link`` and its answer. The telegram is built at the last moment,
        once the start pause is over, so that it carries the newest process data (C 5.1) and
        a job submitted meanwhile."""
        sent = [link.version, link.control]

        def build() -> bytes:
            sent[:] = [link.version, link.control]
            return link.request(self._clock())

        if link.polls_wanted > 0:
            link.polls_wanted -= 1
        result = await self._transact(
            build,
            link.address,
            _NORMAL,
            link.response_delay,
            link.profile.start_pause_chars,
            link,
            early=link is not self._woken,
        )
        link.exchanges += 1
        if result.outcome is _Outcome.ANSWER and result.received is not None:
            self._answer(link, result, sent[0], sent[1])
        elif not self._closing:
            link.missed += 1
            _callbacks.call_each(
                link.miss_callbacks,
                link.missed,
                log,
                "slave %d: missed answer callback failed",
                link.address,
            )
        self._expire_jobs()

    def _expire_jobs(self, exclude: _Link | None = None) -> None:
        """End the jobs whose time is up, of every slave but ``exclude`` (whose telegram is
        on the line). Called after every exchange and at the deadlines during one, so a job
        ends at its deadline - or, when a telegram carrying it is on the line then, once that
        exchange is over - never a cycle later."""
        busy = self._busy(exclude)
        if not busy:
            return
        now = self._clock()
        for link in busy:
            deadline = link.channel.deadline
            if deadline is not None and now > deadline:
                link.channel.expire(now)

    def _next_deadline(self, exclude: _Link | None = None) -> float | None:
        """The earliest deadline of a job of any slave but ``exclude``."""
        busy = self._busy(exclude)
        if not busy:
            return None
        deadlines = [link.channel.deadline for link in busy]
        return min((d for d in deadlines if d is not None), default=None)

    def _busy(self, exclude: _Link | None) -> list[_Link]:
        """The slaves but ``exclude`` with a job open or queued (looked at after every
        exchange: plain attributes, as most slaves have none; none at all while no job was
        submitted since they were last all found without one)."""
        if self._idle_at == self._submitted:
            return []
        busy = [
            link
            for link in self._links.values()
            if link.channel.current is not None or link.channel.queue
        ]
        if not busy:
            self._idle_at = self._submitted
        return [link for link in busy if link is not exclude]

    def _answer(self, link: _Link, result: _Result, version: int, control: int) -> None:
        received = result.received
        assert received is not None
        try:
            net = link.layout.unpack(received.telegram.data)
        except TelegramError as exc:
            link.unusable += 1
            link.diagnostics.record_fault(FaultKind.BAD_LGE, received.end)
            log.warning(
                "slave %d: answer does not fit layout %s: %s", link.address, link.layout, exc
            )
            return
        self._good_answer(link, received, result)
        self._process_data(link, net, received.end, version, control)
        if net.pkw is not None:
            message = link.channel.answer(net.pkw, received.end)
            if message is not None:
                self._deliver_spontaneous(link, message)

    def _good_answer(self, link: _Link, received: Received, result: _Result) -> None:
        link.answers += 1
        link.missed = 0
        link.diagnostics.record_received(received.end)
        link.response_times.add(max(0.0, received.start - result.request_end))
        if link.not_sending:
            link.not_sending = False
            link.channel.not_sending = False
            log.info("slave %d sends again", link.address)

    def _process_data(
        self, link: _Link, net: NetData, when: float, version: int, control: int
    ) -> None:
        if not net.pzd:
            status = _drive_status(link.address, 0, (), when, control)
        else:
            status = _drive_status(link.address, net.pzd[0], net.pzd[1:], when, control)
        link.status = status
        if version > link.answered_version:
            link.answered_version = version
        self._woken = link if link.update_waiters or link.version_waiters else None
        # the subscribers first: what they leave for later (`call_soon`) is done before the
        # tasks woken below look at it
        for callback in list(link.update_callbacks):
            try:
                callback(status)
            except Exception:
                log.exception("slave %d: process data callback failed", link.address)
        if link.update_waiters:
            waiters, link.update_waiters = link.update_waiters, []
            for future in waiters:
                if not future.done():
                    future.set_result(status)
        if link.version_waiters:
            keep = []
            for wanted, future in link.version_waiters:
                if wanted <= version:
                    if not future.done():
                        future.set_result(status)
                else:
                    keep.append((wanted, future))
            link.version_waiters = keep

    def _deliver_spontaneous(self, link: _Link, message: SpontaneousMessage) -> None:
        log.info(
            "slave %d: spontaneous message P%d %s %s",
            link.address,
            message.pnu,
            message.response.text,
            message.values,
        )
        for callback in (*link.spontaneous_callbacks, *self._spontaneous_callbacks):
            try:
                callback(message)
            except Exception:
                log.exception("slave %d: spontaneous message callback failed", link.address)

    def _silent(self, link: _Link, when: float) -> None:
        link.timeouts += 1
        link.diagnostics.record_timeout(when)
        if not link.not_sending:
            link.not_sending = True
            link.channel.not_sending = True
            # INFO: one lost answer on a noisy line is no news; who shows the drive decides
            # when it is gone (`pyuss.points`: after several, "offline")
            log.info(
                "slave %d does not send (no answer within %.1f ms)",
                link.address,
                link.response_delay * 1000,
            )

    # -- the line --------------------------------------------------------------------------
    async def _send(
        self,
        frame: bytes | Callable[[], bytes],
        pause_chars: float,
        answer_within: float | None = None,
        early: bool = False,
    ) -> tuple[float, float]:
        """Keep the start pause, send ``frame`` (or what ``frame()`` builds then); returns the
        telegram's start and end time. ``answer_within``: the time after its end in which an
        answer must begin (response window and tolerance): on a virtual bus the answer may
        then be handed over whole, as long as its first character comes by the time it
        would be handed over at the latest anyway (`TimedWrite`).

        ``early`` (a telegram to another slave than the one whose last answer woke tasks
        waiting for it): on a virtual bus it is handed over at once, the start pause still
        ahead, before what the last answer's subscribers left for later runs - the faces'
        work is done while the telegram is on the line, not before it. Else the woken tasks
        run first: one may have a job for this very telegram."""
        pause = max(2.0, pause_chars) * self.timing.char_time
        # On a virtual bus the telegram is handed over a moment early with its start time
        # (`timed_writer`); elsewhere the last moments of the pause pass yielding to the loop.
        early = early and self._write_at is not None
        ahead = 0.0
        if self._write_at is not None:
            ahead = max(self._margin, self.timing.char_time, pause if early else 0.0)
        if not early:
            await asyncio.sleep(0)  # let tasks woken by the last answer queue their jobs first
        clock = self.transport.clock
        receiver = self._receiver
        while True:
            await self._drain()
            due = max(self._line_free, receiver.last_byte_end) + pause + 1e-9
            left = due - clock()
            if left <= ahead:
                break
            sleep = left - max(ahead, self._margin)
            if sleep > 0:  # sleep while the loop's timers are precise enough
                chunk = await self.transport.read(sleep)
                if chunk is not None:
                    self._stray_events(self._feed(chunk))
            else:
                await asyncio.sleep(0)
        if receiver.busy:
            self._stray_events(receiver.poll(clock()))
        receiver.reset()
        self._after_broadcast = False
        if callable(frame):
            frame = frame()
        on_line = self.timing.transmit(len(frame))
        start = clock()
        try:
            if self._write_at is not None:
                # late for the pause (the last answer took longer than it): at once, and the
                # answer's moment counted from now, so that it is still handed over whole
                start = max(due, start)
                hold = None
                if answer_within is not None:
                    # the first character of an answer that begins at the deadline ends one
                    # character time after it: that is when it must be here at the latest
                    hold = start + on_line + answer_within + self.timing.char_time
                await self._write_at(frame, start, hold)
            else:
                await self.transport.write(frame)
        except LinkDown as exc:
            self._line_down(exc)
            raise _LineDown from exc
        if self._down is not None:  # the first telegram after an outage went out
            self._line_back()
        end = max(start + on_line, clock())
        self._line_free = end
        # the model's end, not the clock's: a master woken late must not take an answer
        # that began after its request for one that began before
        self._sent_frame, self._sent_end = frame, start + on_line
        self._echo_in = False
        log_frame("tx", frame, end)
        return start, end

    def _feed(self, chunk: Chunk) -> list[Received | ReceiveFault]:
        """Feed a chunk to the receiver (which allows for coarse stamps, ``rx_tolerance``)."""
        return self._receiver.feed(chunk.data, chunk.timestamp, chunk.errors)

    async def _drain(self) -> None:
        if self._read_nowait is not None:
            self._drain_nowait(self._read_nowait)
            return
        while True:
            chunk = await self.transport.read(0)
            if chunk is None:
                break
            self._stray_events(self._feed(chunk))
        self._stray_events(self._receiver.poll(self._clock() - self.latency))

    def _drain_nowait(self, read_nowait: Callable[[], Chunk | None]) -> None:
        """`_drain` on a transport with `QueuedTransport.read_nowait`: without awaiting."""
        while (chunk := read_nowait()) is not None:
            self._stray_events(self._feed(chunk))
        if self._receiver.busy:
            self._stray_events(self._receiver.poll(self._clock() - self.latency))

    def _overlaps(self, start: float) -> bool:
        """Whether what began at ``start`` was on the line while the request just sent was:
        known on a line that stamps characters exactly (the virtual bus, ``bus://``) only.
        No answer begins before its request ended."""
        return self._exact and start < self._sent_end - 1e-6

    def _own(self, event: Received, process_data: bool = False) -> bool:
        """Whether ``event`` is the master's own telegram heard back (a line that echoes: a
        2-wire adapter without echo suppression, ``loop://``), never an answer; counted and
        told once (`BusDiagnostics.own_heard`).

        On a line that stamps characters exactly the time tells (`_overlaps`). Elsewhere (a
        serial port, a pty, a TCP converter: no wire time, or stamps as late as the driver
        hands characters over; a peer behind a pty answers at its own rate, sooner than the
        master's line would bring it) the bytes do: the request's very bytes are its echo
        where the answer carries ``process_data`` (a drive's status word is not the control
        word it was sent). A mirror telegram, a request whose net data are all zero, and a
        request without process data (a PKW-only layout: the read of a zero value; a scan's
        probe) are answered with their very bytes too: their copy is the echo on pyserial's
        ``loop://`` (a loopback: no drive is on it), or when the line has been heard echoing
        and it is the first copy since the request (the echo is on the line while the
        request is sent, the answer only after it). Whether the request was a mirror
        telegram its ADR byte says (bit 6), also for a copy that comes after the exchange (a
        late answer)."""
        sent = self._sent_frame
        if event.raw != sent:
            return False
        if self._exact:
            if not self._overlaps(event.start):
                return False
        elif (
            (bool(sent[2] & _MIRROR_BIT) or not process_data or not any(event.telegram.data))
            and not self._loopback
            and (self._own_heard == 0 or self._echo_in)
        ):
            return False
        self._echo_in = True
        self._heard_own(event)
        return True

    def _heard_own(self, event: Received) -> None:
        self._own_heard += 1
        log_frame("rx", event.raw, event.end, "the master's own telegram heard back")
        if self._own_heard == 1:
            log.warning(
                "the master hears its own telegrams back (the line echoes: a 2-wire adapter "
                "without echo suppression?): they are not taken as answers; add echo=1 to "
                "the port URL to have the echo checked and removed"
            )

    def _stray_events(self, events: list[Received | ReceiveFault]) -> None:
        for event in events:
            if isinstance(event, Received):
                # a copy of the request: its echo where time tells, or where nothing else
                # could send it (a loopback; a broadcast, which no slave answers, and an
                # answer would carry the slave's address); else a late answer (a mirror)
                if event.raw == self._sent_frame and (
                    self._overlaps(event.start)
                    if self._exact
                    else self._loopback or event.telegram.mode.is_broadcast
                ):
                    self._heard_own(event)
                    continue
                log_frame("rx", event.raw, event.end, "stray")
                if self._after_broadcast:
                    self._answered_broadcasts += 1
                    log.warning(
                        "a telegram from address %d answered a broadcast (A 3 forbids it)",
                        event.telegram.address,
                    )
                else:
                    self._stray += 1
                    self._stray_seen(event.end)
            else:
                log_frame("rx", event.raw, event.end, f"fault {event.kind.name}")

    def _stray_seen(self, when: float) -> None:
        """Tell once when what nobody asked for keeps coming (`STRAY_ALARM` within
        `STRAY_WINDOW` seconds): telegrams between exchanges or from another address than the
        one awaited, and - where time tells - characters sent while the master sent. Another
        master on the line - USS has one (A 2), and two make their telegrams collide - or a
        drive answering after its window."""
        times = self._stray_times
        times.append(when)
        if (
            not self._stray_told
            and len(times) == STRAY_ALARM
            and times[-1] - times[0] <= STRAY_WINDOW
        ):
            self._stray_told = True
            log.warning(
                "telegrams this master did not ask for, or sent while it sent, keep coming (%d "
                "in %.1f s): is another master on the line? USS has one master (A 2); two "
                "make their telegrams collide. Or a drive answers after its response window.",
                STRAY_ALARM,
                times[-1] - times[0],
            )

    async def _listen(self, until: float) -> None:
        """Take in what arrives until ``until`` (plus latency) and the line is quiet."""
        while True:
            await self._drain()
            left = until + self.latency - self._clock()
            if left <= 0 and not self._receiver.busy:
                return
            chunk = await self.transport.read(max(left, self.timing.start_pause))
            if chunk is not None:
                self._stray_events(self._feed(chunk))

    async def _transact(
        self,
        frame: bytes | Callable[[], bytes],
        address: int,
        modes: Collection[AddressMode],
        limit: float,
        pause_chars: float,
        link: _Link | None,
        *,
        early: bool = False,
    ) -> _Result:
        """Send ``frame`` and wait for the answer of ``address`` (A 5.2); ``early``: see
        `_send`."""
        start, end = await self._send(frame, pause_chars, limit + self.rx_tolerance, early)
        deadline = end + limit + self.rx_tolerance
        faulty = False
        receiver = self._receiver
        events: list[Received | ReceiveFault] = []
        # Other slaves' jobs end at their deadlines during this exchange, also jobs queued
        # while it runs (`_JOB_CHECK`: how long a read may block before they are looked at).
        submitted = self._submitted
        jobs_due = self._next_deadline(exclude=link)
        whole, expected = self._whole_answer(link)
        clock = self.transport.clock
        read_nowait = self._read_nowait
        while True:
            now = clock()
            if submitted != self._submitted:
                submitted = self._submitted
                jobs_due = self._next_deadline(exclude=link)
            if jobs_due is not None and now > jobs_due:
                self._expire_jobs(exclude=link)
                jobs_due = self._next_deadline(exclude=link)
            # every chunk that is in is fed before time is judged (a read may time out just
            # as a chunk arrives)
            if read_nowait is not None:
                while (chunk := read_nowait()) is not None:
                    events += self._feed(chunk)
            else:
                while (chunk := await self.transport.read(0)) is not None:
                    events += self._feed(chunk)
            if receiver.busy:
                events += receiver.poll(now - self.latency)
            found: tuple[_Outcome, Received] | None = None
            for event in events:
                outcome = self._judge(event, address, modes, deadline, link)
                if outcome is _Outcome.FAULT:
                    faulty = True
                elif outcome is not None and found is None:
                    assert isinstance(event, Received)
                    found = (outcome, event)
            events = []
            if found is not None:
                return self._finish(found[0], found[1], start, end, link)
            if receiver.busy:
                nxt = receiver.next_poll()
                wait = (nxt if nxt is not None else now) + self.latency - now
                wait = max(wait, self.timing.char_time)
            else:
                # the first character of an answer that began at the deadline ends one
                # character time later and is handed over a little after that
                wait = deadline + self.timing.char_time + self.silence - now
                if wait <= 0:
                    await asyncio.sleep(0)  # what is due is handed over first
                    chunk = await self.transport.read(0)
                    if chunk is not None:
                        events = self._feed(chunk)
                        continue
                    outcome = _Outcome.FAULT if faulty else _Outcome.SILENT
                    return self._finish(outcome, None, start, end, link)
            if jobs_due is not None:
                wait = min(wait, max(jobs_due - now, 0.0) + 1e-4)
            wait = min(wait, _JOB_CHECK)
            if whole is not None and not receiver.busy:
                # nothing of the answer yet: wake once, when all of it may be in (the
                # chunks keep their timestamps, the answer is judged as it would be anyway)
                await whole(expected, wait)
                continue
            chunk = await self.transport.read(wait)
            if chunk is not None:
                events = self._feed(chunk)

    def _whole_answer(self, link: _Link | None) -> tuple[WaitBytes | None, int]:
        """How to wait for the whole answer of ``link`` at once, and its length in bytes:
        on a transport with exact timestamps that can wait for a number of bytes (the
        virtual bus, ``bus://``) and a layout of fixed length. Else None: the master is woken
        by every chunk (a virtual bus hands a telegram over in three, docs/bus.md)."""
        wait_bytes = self._wait_bytes
        if link is None or wait_bytes is None:
            return None, 0
        lge = link.layout.lge
        if lge is None or not self.transport.exact_timestamps:
            return None, 0
        return wait_bytes, lge + 2

    def _finish(
        self,
        outcome: _Outcome,
        received: Received | None,
        start: float,
        end: float,
        link: _Link | None,
    ) -> _Result:
        if link is not None and outcome in (_Outcome.SILENT, _Outcome.LATE) and not self._closing:
            self._silent(link, self._clock())
        return _Result(outcome, received if outcome is _Outcome.ANSWER else None, start, end)

    def _judge(
        self,
        event: Received | ReceiveFault,
        address: int,
        modes: Collection[AddressMode],
        deadline: float,
        link: _Link | None,
    ) -> _Outcome | None:
        """Classify one event while the answer of ``address`` is awaited."""
        if isinstance(event, ReceiveFault):
            log_frame("rx", event.raw, event.end, f"fault {event.kind.name}: {event.detail}")
            if self._overlaps(event.start):
                self._stray_seen(event.end)  # sent while the request was: a collision
            if link is not None:
                link.diagnostics.record_fault(event.kind, event.end)
            return _Outcome.FAULT
        if self._own(event, link is not None and link.layout.pzd > 0):
            return None
        telegram = event.telegram
        wrong = telegram.address != address or telegram.mode not in modes
        if wrong or self._overlaps(event.start):
            # another's telegram, or one that began while the request was on the line
            why = f"not the answer of {address}" if wrong else "began before the request ended"
            log_frame("rx", event.raw, event.end, f"discarded: {why}")
            self._stray_seen(event.end)
            if link is not None:
                link.wrong_address += wrong
                link.diagnostics.record_discarded(event.end)
            return None
        log_frame("rx", event.raw, event.end)
        if event.start > deadline + self.timing.char_time * 1e-3:
            if link is not None:
                link.late += 1
            log.debug(
                "slave %d answered %.1f ms after the deadline: not used",
                address,
                (event.start - deadline) * 1000,
            )
            return _Outcome.LATE
        return _Outcome.ANSWER
