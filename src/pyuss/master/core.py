"""The bus master's decisions, without I/O and without a clock: `MasterCore`.

The core is told what happens - "a chunk of bytes arrived", "it is now t", "a job was
submitted", "this telegram went out from s to e" - and says what to do: which telegram comes
next (`MasterCore.next_action`), when the start pause before it ends (`MasterCore.send_due`),
how long to wait for an answer and what the answer was (`Exchange`), which jobs are done or
failed, which drive does not send. It reads no clock and touches no transport or event loop:
`pyuss.master.scheduler.Master` is the asyncio loop around it (the one `uss` and every face
use), and any other driver (a thread of its own, a test with a simulated clock) is another
loop around the same core. Futures are anything with ``done``/``set_result``/
``set_exception`` (`Pending`: an asyncio or a `concurrent.futures` future).
One state machine read as a whole: the module is longer than the project's 700 lines for it.

Telegram traffic (A 2, A 5.1)
    - Cyclic mode (the default, A 2.1): the master goes round the poll list ("Umlaufliste",
      A 5.1) again and again; an address may appear several times to be served more often; a
      one-entry list is a point-to-point link. With ``cycle_time`` the master waits after the
      last entry for the rest of the cycle (A 5.1.1); `MasterCore.cycle_stats` gives the
      achieved cycle time, its jitter and the overruns. A change of the poll list applies from
      the next cycle.
    - Acyclic mode (A 2.2): telegrams only on demand - a slave gets turns while it has a
      parameter job, new process data to deliver, or an exchange was asked for; the slaves
      with demand take turns by address.
    - Between turns, and before the next entry of the poll list, the master sends what was
      asked of it in the order asked: broadcasts, mirror telegrams and any other telegram
      (`Special`).

Timing (A 5.1.2, A 5.2.1)
    - Before every telegram the master keeps a start pause after the end of the last byte on
      the line, its own or received (chunk timestamps): 2 character times, or more where the
      slave's profile asks for more (reading 2).
    - The answer must begin within the slave's response delay limit (20 ms by default, never
      below the start pause; a profile or the caller may set another) after the end of the
      request, and the core `Receiver` checks its residual time and BCC. Otherwise the master
      marks "slave x does not send" (`Slave.not_sending`), counts the timeout (A 5.2.3 bit 7
      and counter 16) and goes on with the next entry; the mark is cleared only by the next
      good telegram from that slave, which stays in the poll list. A slave that answers late
      is treated the same and its answer is not used. `Slave.missed` counts the telegrams
      in a row without a usable answer (silent, late or garbled); its callbacks are told of
      each.
    - Answers from another address or of another type, and answers that do not fit the
      slave's layout, are discarded and counted (A 5.2, A 5.2.2). Telegrams that arrive when no
      answer is awaited are counted as stray; after a broadcast the master listens for one
      response delay: nobody may answer (A 3), and whoever does is counted.
    - ``rx_tolerance`` widens the receive side for transports that stamp bytes when read
      (the receiver's tolerance, and the answer may begin up to it after the response delay
      limit); ``latency`` is how long past a deadline bytes that were on the line in time may
      still be delivered; ``silence`` the wait for a silent slave beyond its window. See
      "Time bases" in `pyuss.master.scheduler`.

Process data (C 5.1)
    Every telegram to a slave carries its latest control word and setpoints, as they are when
    the telegram is built (`Slave.request`, at the end of the start pause); every answer
    updates the slave's status first, before the parameter channel looks at it, and wakes the
    callbacks and the waits for an answer (`MasterCore.wait_update`, `wait_version`).

Parameter jobs (C 4.2.1.1, C 4.2.1.2): see `pyuss.master.jobs`; the core ends every job whose
time is up after each exchange, and during one at the deadline of any other slave's job.

Echoes and old answers
    The master's own telegram heard back (a line that echoes) is never an answer
    (`MasterCore.own`); no answer is taken that began before the request ended where the line
    stamps exactly; an old answer is never taken for a new job (`pyuss.master.jobs`).

A lost line
    Told that the link is down (`MasterCore.line_down`) the core takes every slave for not
    sending, fails what waits for the line with that error and refuses nothing itself (the
    loop refuses new requests while it is down); told that it is back (`line_back`) the loop
    sends again what it sent before - the process data in force, the poll list.
"""

from __future__ import annotations

import enum
import logging
import math
from collections import deque
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, TypeVar

from pyuss import _callbacks
from pyuss.errors import ConfigError, TelegramError, TransportError
from pyuss.log import log_frame
from pyuss.master.errors import MirrorMismatch, NotSending
from pyuss.master.jobs import Job, ParameterChannel, SpontaneousMessage
from pyuss.master.process import DriveStatus
from pyuss.master.profile import Profile, resolve_profile, response_limit
from pyuss.master.stats import BusDiagnostics, CycleStats, Samples, SlaveCounts, SlaveDiagnostics
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.diagnostics import Diagnostics, FaultKind
from pyuss.protocol.frozen import builder
from pyuss.protocol.layout import Layout, NetData
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.receiver import Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import MAX_ADDRESS, AddressMode, Telegram
from pyuss.protocol.timing import LineTiming

if TYPE_CHECKING:
    from pyuss.transport.base import Chunk

__all__ = [
    "ACYCLIC",
    "CYCLIC",
    "Exchange",
    "Idle",
    "MasterCore",
    "MirrorResult",
    "Mode",
    "Outcome",
    "Pending",
    "Reply",
    "Result",
    "Slave",
    "Special",
]

log = logging.getLogger("pyuss.master")

DEFAULT_LATENCY = 0.020
"""How long past a deadline the master still waits for bytes that were on the line in time."""
EXACT_LATENCY = 0.004
"""How long the master waits for the first character of an answer beyond the response window
on a virtual bus, which hands each character over within microseconds of its end
(milliseconds on a loaded machine): what a silent address costs beyond its window."""
DEFAULT_JOB_TIMEOUT = 2.0
JOB_CHECK = 0.05
"""Longest wait for the line during an exchange before the jobs of other slaves are looked at
(only a long response delay limit waits longer than this at once)."""
STRAY_ALARM = 10
"""Telegrams nobody asked for that, within `STRAY_WINDOW` seconds, are told of (once)."""
STRAY_WINDOW = 10.0
MAX_CYCLE_TIME = 60.0
"""The longest fixed cycle time (seconds): every drive goes that long without a telegram, and a
drive's telegram monitoring is set to seconds, not minutes."""
_MIRROR_BIT = int(AddressMode.MIRROR)
"""ADR bit 6: a mirror telegram (A 5.3), byte 2 of a telegram."""
_NORMAL = frozenset({AddressMode.NORMAL})

T_contra = TypeVar("T_contra", contravariant=True)


class Pending(Protocol[T_contra]):
    """A future the core completes: an `asyncio.Future` or a `concurrent.futures.Future`."""

    def done(self) -> bool: ...
    def set_result(self, result: T_contra, /) -> None: ...
    def set_exception(self, exception: BaseException, /) -> None: ...


class Mode(enum.Enum):
    """Telegram traffic (A 2)."""

    CYCLIC = "cyclic"
    """Go round the poll list continuously (A 2.1); what drives need."""
    ACYCLIC = "acyclic"
    """Telegrams only on demand (A 2.2); slaves cannot watch for telegram failures."""


CYCLIC = Mode.CYCLIC
ACYCLIC = Mode.ACYCLIC


@dataclass(frozen=True, slots=True)
class Reply:
    """The answer to a telegram sent with `pyuss.master.Master.request`."""

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


_drive_status = builder(DriveStatus)
_slave_counts = builder(SlaveCounts)
"""`DriveStatus` of an answer and `SlaveCounts` of a slave, made at every answer
(`pyuss.protocol.frozen.builder`)."""


class Outcome(enum.Enum):
    ANSWER = "answer"
    SILENT = "silent"
    FAULT = "fault"
    LATE = "late"


@dataclass(slots=True)
class Result:
    """How one exchange ended: the answer (`Outcome.ANSWER` only) and the request's times."""

    outcome: Outcome
    received: Received | None
    request_start: float
    request_end: float


class Slave:
    """Everything the master keeps about one slave (read by its `pyuss.master.Drive`)."""

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
        self.update_waiters: list[Pending[DriveStatus]] = []
        self.version_waiters: list[tuple[int, Pending[DriveStatus]]] = []
        self.update_callbacks: list[Callable[[DriveStatus], object]] = []
        self.spontaneous_callbacks: list[Callable[[SpontaneousMessage], object]] = []
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
class Special:
    """A telegram asked for between the turns: ``kind`` "broadcast", "mirror" or "request"."""

    kind: str
    frame: bytes
    address: int
    pending: Pending[object]


@dataclass(frozen=True, slots=True)
class Idle:
    """Nothing to send until ``until`` (None: until something is asked) or until woken."""

    until: float | None


def _seconds(name: str, value: float | None, *, positive: bool) -> None:
    if value is None:
        return
    ok = not isinstance(value, bool) and (value > 0 if positive else value >= 0)
    if not ok:
        raise ConfigError(
            f"{name} must be {'a positive number of' if positive else '>= 0'} seconds, "
            f"not {value!r}"
        )


class MasterCore:
    """The master's state and decisions (see the module docstring); every time is passed in.

    ``baud``: the line's rate. ``profile``, ``layout``, ``cycle_time``, ``mode``,
    ``response_delay``, ``job_timeout``, ``latency``, ``silence``: as for
    `pyuss.master.Master`; ``rx_tolerance``: the receive tolerance (seconds); ``exact``: the
    line stamps characters exactly (a virtual bus); ``loopback``: every copy of a request is
    its echo (pyserial's ``loop://``); ``poke``: called when something was asked (a request,
    new process data, a poll list), so that a loop that waits (`Idle`) looks again.
    """

    def __init__(
        self,
        baud: int,
        *,
        profile: Profile | str | None = None,
        layout: Layout | str | None = None,
        cycle_time: float | None = None,
        mode: Mode = Mode.CYCLIC,
        response_delay: float | None = None,
        job_timeout: float = DEFAULT_JOB_TIMEOUT,
        rx_tolerance: float = 0.0,
        latency: float | None = None,
        silence: float | None = None,
        exact: bool = False,
        loopback: bool = False,
        poke: Callable[[], None] | None = None,
    ) -> None:
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
        _seconds("job_timeout", job_timeout, positive=True)
        _seconds("response_delay", response_delay, positive=True)
        _seconds("rx_tolerance", rx_tolerance, positive=False)
        _seconds("latency", latency, positive=False)
        _seconds("silence", silence, positive=False)
        self.baud = baud
        self.timing = LineTiming(baud)
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
        self.rx_tolerance = rx_tolerance
        self.latency = DEFAULT_LATENCY if latency is None else latency
        self.silence = self.latency if silence is None else silence
        self.exact = exact
        self.loopback = loopback
        self.poke: Callable[[], None] = poke or (lambda: None)
        """Told when something was asked, so that a loop that waits (`Idle`) looks again."""
        self.slaves: dict[int, Slave] = {}
        self._poll: list[int] = []
        self.specials: list[Special] = []
        self._spontaneous_callbacks: list[Callable[[SpontaneousMessage], object]] = []
        self._line_callbacks: list[Callable[[TransportError | None], object]] = []
        self.line = Diagnostics()
        self.receiver = Receiver(
            baud,
            tolerance=rx_tolerance,
            diagnostics=self.line,
            residual_extra_chars=self.profile.residual_extra_chars,
        )
        self.line_free = -math.inf
        """The end of the master's last telegram on the line."""
        self._after_broadcast = False
        self.broadcasts = 0
        self.answered_broadcasts = 0
        self.stray = 0
        self._stray_times: deque[float] = deque(maxlen=STRAY_ALARM)
        self._stray_told = False
        self.own_heard = 0
        self._sent_frame = b""
        self._sent_end = -math.inf
        self._echo_in = False
        """The echo of the latest request was heard (a line that echoes gives back one copy)."""
        self._cycles = Samples()
        self._cycle_count = 0
        self._overruns = 0
        self._last_cycle_start: float | None = None
        self._entries: tuple[int, ...] = ()
        self._entry = 0
        self._cycle_end: float | None = None
        """The poll list of the cycle under way, the next entry, and (a fixed cycle time,
        its entries all done) when the rest of the cycle is over."""
        self._rotation = 0
        self.submitted = 0
        """Jobs submitted so far (an `Exchange` looks again at other slaves' deadlines when
        it changes)."""
        self._idle_at: int | None = None
        """`submitted` when no slave had a job open or queued: until the next job is
        submitted none has (jobs only end meanwhile), and the slaves need not be looked at."""
        self.woken: Slave | None = None
        """The slave whose last answer woke tasks waiting for it."""
        self.closing = False
        self.failure: TransportError | None = None
        """What every request fails with from now on (the master stopped or was closed)."""
        self.down: TransportError | None = None
        """While the link is down (being reopened): what requests are refused with."""

    # -- drives and the poll list ----------------------------------------------------------
    def add_slave(
        self,
        address: int,
        *,
        layout: Layout | str | None = None,
        profile: Profile | str | None = None,
        response_delay: float | None = None,
        poll: bool = True,
    ) -> Slave:
        """The slave at ``address`` (made on the first call, which fixes its ``layout``,
        ``profile`` and ``response_delay`` limit; later calls may repeat them, not change
        them); ``poll``: append it to the poll list if it is not in it yet."""
        if isinstance(address, bool) or not isinstance(address, int):
            raise ConfigError(f"slave address must be an integer 0..{MAX_ADDRESS}, not {address!r}")
        if not 0 <= address <= MAX_ADDRESS:
            raise ConfigError(f"slave address must be 0..{MAX_ADDRESS}, not {address}")
        if isinstance(layout, str):
            layout = Layout.parse(layout)
        prof = resolve_profile(profile) if profile is not None else None
        slave = self.slaves.get(address)
        if slave is not None:
            if layout is not None and layout != slave.layout:
                raise ConfigError(f"slave {address} uses layout {slave.layout}, not {layout}")
            if prof is not None and prof.name != slave.profile.name:
                raise ConfigError(
                    f"slave {address} uses profile {slave.profile.name}, not {prof.name}"
                )
            if response_delay is not None and response_delay != slave.response_delay:
                raise ConfigError(
                    f"slave {address} has response delay limit {slave.response_delay:g} s"
                )
        else:
            named = prof is not None or self.profile_named
            prof = prof or self.profile
            if layout is None:
                layout = self.default_layout if prof is self.profile else prof.default_layout
            prof.check_layout(layout)
            _seconds("response delay", response_delay, positive=True)
            limit = response_limit(prof, self.baud, response_delay or self.response_delay)
            slave = Slave(address, layout, prof, limit, named)
            self.slaves[address] = slave
            if layout.lge is not None:
                self.receiver.fixed_lengths[address] = layout.lge
        if poll and address not in self._poll:
            self._poll.append(address)
            self.poke()
        return slave

    @property
    def poll_list(self) -> tuple[int, ...]:
        """The addresses of the poll list in order (A 5.1)."""
        return tuple(self._poll)

    def set_poll_list(self, addresses: Iterable[int]) -> None:
        """Set the poll list; an address may appear several times (A 5.1). Addresses not known
        yet get a slave with the master's defaults."""
        entries = list(addresses)
        for address in entries:
            self.add_slave(address, poll=False)
        self._poll = entries
        self.poke()

    def on_spontaneous(self, callback: Callable[[SpontaneousMessage], object]) -> None:
        """Call ``callback`` for every new spontaneous message of any slave (C 4.2.1.2)."""
        self._spontaneous_callbacks.append(callback)

    def on_line(self, callback: Callable[[TransportError | None], object]) -> Callable[[], None]:
        """Call ``callback`` when the line is lost (with the error: the link is down and
        being reopened, or the master stopped) and when it is back (None). Returns a function
        that removes it. Whoever follows the line reports its loss for good; while nobody
        does, the master logs it itself (ERROR)."""
        return _callbacks.add(self._line_callbacks, callback)

    @property
    def line_followed(self) -> bool:
        """Whether anyone follows the line (`on_line`): else its loss is logged as an error."""
        return bool(self._line_callbacks)

    def tell_line(self, error: TransportError | None) -> None:
        _callbacks.call_each(self._line_callbacks, error, log, "line callback failed")

    # -- what drives and users ask ---------------------------------------------------------
    def check_job(self, slave: Slave) -> None:
        """Refuse a parameter job the slave cannot be given."""
        if not slave.layout.pkw:
            raise ConfigError(
                f"slave {slave.address} has layout {slave.layout}: without a PKW area no "
                "parameter can be read or written (C 4.1)"
            )
        if self.mode is Mode.CYCLIC and slave.address not in self._poll:
            raise ConfigError(
                f"slave {slave.address} is not in the poll list: it gets no telegrams in "
                "cyclic mode"
            )

    def submit(self, slave: Slave, job: Job, now: float) -> None:
        """Queue ``job`` for ``slave`` (checked with `check_job`); its callback is called when
        it ends."""
        slave.channel.submit(job, now)
        self.submitted += 1
        self.poke()

    def start_job(
        self,
        slave: Slave,
        request: Pkw,
        pnu: int,
        index: int | None,
        timeout: float | None,
        pending: Pending[Pkw],
        now: float,
    ) -> Job:
        """Check and queue a parameter job for ``slave`` that completes ``pending`` with its
        answer or error (``pnu``/``index`` word its errors; ``timeout``: else the master's)."""
        self.check_job(slave)

        def done(job: Job) -> None:
            if pending.done():
                return
            if job.error is not None:
                pending.set_exception(job.error)
            else:
                assert job.answer is not None
                pending.set_result(job.answer)

        job = Job(request, pnu, index, self.job_timeout_for(timeout), done)
        self.submit(slave, job, now)
        return job

    def job_timeout_for(self, timeout: float | None) -> float:
        return self.job_timeout if timeout is None else timeout

    def set_process_data(
        self, slave: Slave, control: int | None = None, setpoints: dict[int, int] | None = None
    ) -> int:
        """Change the control word and setpoints (PZD number -> word) from the next telegram
        on; returns the version to wait for (`wait_version`)."""
        if control is not None:
            slave.control = int(control) & 0xFFFF
        for number, value in (setpoints or {}).items():
            slave.setpoints[number - 2] = value & 0xFFFF
        slave.version += 1
        self.poke()
        return slave.version

    def check_polled(self, slave: Slave) -> None:
        if self.mode is Mode.CYCLIC and slave.address not in self._poll:
            raise ConfigError(f"slave {slave.address} is not in the poll list")

    def wait_version(
        self, slave: Slave, version: int, pending: Pending[DriveStatus]
    ) -> DriveStatus | None:
        """The status of the answer to a telegram that carried process data ``version`` or
        later if one came; else None, and ``pending`` is completed with the first."""
        if slave.answered_version >= version and slave.status is not None:
            return slave.status
        slave.version_waiters.append((version, pending))
        self.poke()
        return None

    def wait_update(self, slave: Slave, pending: Pending[DriveStatus]) -> None:
        """Complete ``pending`` with the slave's next answer (acyclic: asks for a turn)."""
        slave.update_waiters.append(pending)
        if self.mode is Mode.ACYCLIC:
            slave.polls_wanted += 1
            self.poke()

    def add_special(self, kind: str, frame: bytes, address: int, pending: Pending[object]) -> None:
        self.specials.append(Special(kind, frame, address, pending))
        self.poke()

    def mirror_frame(self, address: int, data: bytes | None) -> bytes:
        """A mirror telegram (A 5.3) to ``address``; ``data`` default: a test pattern of the
        slave's length (its fixed length, or the shortest variable one; 5 words for an
        address not known)."""
        slave = self.slaves.get(address)
        if data is None:
            if slave is None:
                count = 5
            else:
                words = slave.layout.words
                count = 3 + slave.layout.pzd if words is None else words
            data = bytes((0x55 + 0x11 * i) & 0xFF for i in range(2 * count))
        try:
            return Telegram(address, AddressMode.MIRROR, bytes(data)).encode()
        except (TelegramError, TypeError) as exc:
            raise ConfigError(f"mirror telegram to {address!r}: {exc}") from None

    @staticmethod
    def broadcast_data(
        pzd: list[int],
        enable: BroadcastEnableArray | None,
        pkw: list[int] | Pkw | None,
        layout: Layout | None,
    ) -> bytes:
        """The net data of a broadcast (see `pyuss.master.Master.broadcast`)."""
        if enable is not None:
            if pkw is not None:
                raise ConfigError("give a Broadcast Enable Array or PKW words, not both")
            from pyuss.master.broadcast import enable_array_data

            return enable_array_data(pzd, enable, layout)
        if layout is None:
            layout = Layout(4 if pkw is not None else 0, len(pzd))
        area = pkw if pkw is None or isinstance(pkw, Pkw) else Pkw.from_words(list(pkw))
        return layout.pack(area, pzd)

    # -- failing what waits ----------------------------------------------------------------
    def fail(self, error: TransportError) -> None:
        """From now on every request fails with ``error``; so does all that waits."""
        if self.failure is None:
            self.failure = error
        self.fail_waiting(error, updates=True)

    def fail_waiting(self, error: TransportError, *, updates: bool) -> None:
        """Fail the jobs, process data and special telegrams waiting for the line (and, with
        ``updates``, the waits for a slave's next answer) with ``error``."""
        for slave in self.slaves.values():
            slave.channel.fail_all(error)
            if updates:
                for pending in slave.update_waiters:
                    if not pending.done():
                        pending.set_exception(error)
                slave.update_waiters.clear()
            for _, pending in slave.version_waiters:
                if not pending.done():
                    pending.set_exception(error)
            slave.version_waiters.clear()
        for special in self.specials:
            if not special.pending.done():
                special.pending.set_exception(error)
        self.specials.clear()

    def abandon(self) -> None:
        """Whoever waits is gone (a blocking call interrupted, or its port lost): its jobs are
        forgotten as a cancelled wait forgets them (an open job leaves the slave's answer
        unknown), its special telegrams and waits dropped: nothing of it goes out later."""
        for slave in self.slaves.values():
            channel = slave.channel
            for job in [
                *([channel.current] if channel.current is not None else []),
                *channel.queue,
            ]:
                channel.cancel(job)
            slave.update_waiters.clear()
            slave.version_waiters.clear()
            slave.polls_wanted = 0
        self.specials.clear()

    def stopped_hearing(self) -> None:
        """Nothing is heard of any slave any more, so each does not send (A 5.2.1.1) and no
        face shows its last answer as now."""
        for slave in self.slaves.values():
            slave.not_sending = True
            slave.channel.not_sending = True

    def stopped(self, error: TransportError) -> None:
        """The master stopped on its own (the port failed for good)."""
        self.stopped_hearing()
        self.fail(error)
        self.tell_line(error)

    def line_down(self, error: TransportError) -> None:
        """The link is down (being reopened; ``error`` is what requests are refused with until
        it is back): nothing is heard of any slave, what waits for the line fails."""
        if self.down is not None:
            return
        self.down = error
        self.stopped_hearing()
        for slave in self.slaves.values():
            slave.missed = 0  # nothing was missed by the slaves: nothing was sent to them
        self.fail_waiting(error, updates=False)
        self.tell_line(error)
        self.poke()

    def line_back(self) -> None:
        self.down = None
        self.tell_line(None)

    def stop_time(self) -> float:
        """How long the telegram on the line may still take when the master is closed."""
        longest = max((slave.response_delay for slave in self.slaves.values()), default=0.02)
        return 1.0 + longest + self.latency + self.timing.transmit(512)

    # -- what comes next -------------------------------------------------------------------
    def next_action(self, now: float) -> Special | Slave | Idle:
        """What the master does next: a special telegram, a turn of a slave (a telegram to it
        and its answer: `Slave.request`, then `end_turn`), or nothing until
        `Idle.until`. Call `expire_jobs` after an idle time."""
        if self.specials:
            return self.specials.pop(0)
        if self.mode is Mode.ACYCLIC:
            slave = self._next_demand()
            if slave is None:
                return Idle(None)
            if slave.polls_wanted > 0:
                slave.polls_wanted -= 1
            return slave
        while True:
            if self._entry < len(self._entries):
                address = self._entries[self._entry]
                self._entry += 1
                slave = self.slaves.get(address)
                if slave is not None:
                    return slave
                continue
            if self._entries:  # the last entry is done
                self._entries = ()
                self._cycle_count += 1
                if self.cycle_time is not None and self._last_cycle_start is not None:
                    end = self._last_cycle_start + self.cycle_time
                    if now > end:
                        self._overruns += 1
                    else:
                        self._cycle_end = end
            if self._cycle_end is not None:
                if now < self._cycle_end:
                    until = self._cycle_end
                    deadline = self.next_deadline()
                    if deadline is not None:  # a job running out meanwhile ends on time
                        until = min(until, max(deadline, now) + self.timing.char_time)
                    return Idle(until)
                self._cycle_end = None
            if not self._poll:
                self._last_cycle_start = None  # the time without a poll list is no cycle
                return Idle(None)
            if self._last_cycle_start is not None:
                self._cycles.add(now - self._last_cycle_start)
            self._last_cycle_start = now
            self._entries, self._entry = tuple(self._poll), 0

    def _next_demand(self) -> Slave | None:
        addresses = sorted(self.slaves)
        for step in range(len(addresses)):
            address = addresses[(self._rotation + step) % len(addresses)]
            slave = self.slaves[address]
            if slave.wants_turn:
                self._rotation = (self._rotation + step + 1) % len(addresses)
                return slave
        return None

    def end_turn(
        self, slave: Slave, result: Result, version: int, control: int, now: float
    ) -> None:
        """The exchange of a turn is over: ``version`` and ``control`` are what its telegram
        carried."""
        slave.exchanges += 1
        if result.outcome is Outcome.ANSWER and result.received is not None:
            self._answer(slave, result, version, control)
        elif not self.closing:
            slave.missed += 1
            _callbacks.call_each(
                slave.miss_callbacks,
                slave.missed,
                log,
                "slave %d: missed answer callback failed",
                slave.address,
            )
        self.expire_jobs(now)

    def special_setup(
        self, special: Special
    ) -> tuple[Slave | None, float, float, frozenset[AddressMode]]:
        """The slave (if known), start pause (characters), response delay limit and the
        modes of a fitting answer of a special telegram other than a broadcast."""
        slave = self.slaves.get(special.address)
        profile = slave.profile if slave is not None else self.profile
        limit = (
            slave.response_delay
            if slave is not None
            else response_limit(self.profile, self.baud, self.response_delay)
        )
        mode = Telegram.decode(special.frame).mode
        modes = {mode, AddressMode.NORMAL} if mode is AddressMode.SPECIAL else {mode}
        return slave, profile.start_pause_chars, limit, frozenset(modes)

    def special_result(self, special: Special, slave: Slave | None, result: Result) -> object:
        """What the exchange of a special telegram gives (`Reply`, None, `MirrorResult`)."""
        received = result.received
        if result.outcome is not Outcome.ANSWER or received is None:
            if special.kind == "request":
                return None
            raise NotSending(special.address, "no answer to the mirror telegram (A 5.3)")
        if slave is not None:
            self._good_answer(slave, received, result)
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

    def broadcast_pause(self) -> float:
        """The start pause before a broadcast: the longest any slave asks for."""
        return max((s.profile.start_pause_chars for s in self.slaves.values()), default=2)

    def broadcast_sent(self) -> tuple[float, int]:
        """A broadcast went out: until when to listen (`listen_done`) and the count of answers
        so far (what `answered_broadcasts` grows by was answered, against A 3)."""
        self.broadcasts += 1
        self._after_broadcast = True
        limit = response_limit(self.profile, self.baud, self.response_delay)
        return self.line_free + limit + self.rx_tolerance, self.answered_broadcasts

    # -- parameter job deadlines -----------------------------------------------------------
    def expire_jobs(self, now: float, exclude: Slave | None = None) -> None:
        """End the jobs whose time is up, of every slave but ``exclude`` (whose telegram is
        on the line). Called after every exchange and at the deadlines during one, so a job
        ends at its deadline - or, when a telegram carrying it is on the line then, once that
        exchange is over - never a cycle later."""
        if self._idle_at == self.submitted:  # (no job since all were found without one)
            return
        for slave in self._busy(exclude):
            deadline = slave.channel.deadline
            if deadline is not None and now > deadline:
                slave.channel.expire(now)

    def next_deadline(self, exclude: Slave | None = None) -> float | None:
        """The earliest deadline of a job of any slave but ``exclude``."""
        if self._idle_at == self.submitted:
            return None
        busy = self._busy(exclude)
        if not busy:
            return None
        deadlines = [slave.channel.deadline for slave in busy]
        return min((d for d in deadlines if d is not None), default=None)

    def _busy(self, exclude: Slave | None) -> list[Slave]:
        """The slaves but ``exclude`` with a job open or queued (looked at after every
        exchange: plain attributes, as most slaves have none; none at all while no job was
        submitted since they were last all found without one)."""
        if self._idle_at == self.submitted:
            return []
        busy = [
            slave
            for slave in self.slaves.values()
            if slave.channel.current is not None or slave.channel.queue
        ]
        if not busy:
            self._idle_at = self.submitted
        return [slave for slave in busy if slave is not exclude]

    # -- answers ---------------------------------------------------------------------------
    def _answer(self, slave: Slave, result: Result, version: int, control: int) -> None:
        received = result.received
        assert received is not None
        try:
            net = slave.layout.unpack(received.telegram.data)
        except TelegramError as exc:
            slave.unusable += 1
            slave.diagnostics.record_fault(FaultKind.BAD_LGE, received.end)
            log.warning(
                "slave %d: answer does not fit layout %s: %s", slave.address, slave.layout, exc
            )
            return
        self._good_answer(slave, received, result)
        self._process_data(slave, net, received.end, version, control)
        if net.pkw is not None:
            message = slave.channel.answer(net.pkw, received.end)
            if message is not None:
                self._deliver_spontaneous(slave, message)

    def _good_answer(self, slave: Slave, received: Received, result: Result) -> None:
        slave.answers += 1
        slave.missed = 0
        slave.diagnostics.record_received(received.end)
        slave.response_times.add(max(0.0, received.start - result.request_end))
        if slave.not_sending:
            slave.not_sending = False
            slave.channel.not_sending = False
            log.info("slave %d sends again", slave.address)

    def _process_data(
        self, slave: Slave, net: NetData, when: float, version: int, control: int
    ) -> None:
        if not net.pzd:
            status = _drive_status(slave.address, 0, (), when, control)
        else:
            status = _drive_status(slave.address, net.pzd[0], net.pzd[1:], when, control)
        slave.status = status
        if version > slave.answered_version:
            slave.answered_version = version
        self.woken = slave if slave.update_waiters or slave.version_waiters else None
        # the subscribers first: what they leave for later (`call_soon`) is done before the
        # tasks woken below look at it
        for callback in list(slave.update_callbacks):
            try:
                callback(status)
            except Exception:
                log.exception("slave %d: process data callback failed", slave.address)
        if slave.update_waiters:
            waiters, slave.update_waiters = slave.update_waiters, []
            for pending in waiters:
                if not pending.done():
                    pending.set_result(status)
        if slave.version_waiters:
            keep = []
            for wanted, pending in slave.version_waiters:
                if wanted <= version:
                    if not pending.done():
                        pending.set_result(status)
                else:
                    keep.append((wanted, pending))
            slave.version_waiters = keep

    def _deliver_spontaneous(self, slave: Slave, message: SpontaneousMessage) -> None:
        log.info(
            "slave %d: spontaneous message P%d %s %s",
            slave.address,
            message.pnu,
            message.response.text,
            message.values,
        )
        for callback in (*slave.spontaneous_callbacks, *self._spontaneous_callbacks):
            try:
                callback(message)
            except Exception:
                log.exception("slave %d: spontaneous message callback failed", slave.address)

    def _silent(self, slave: Slave, when: float) -> None:
        slave.timeouts += 1
        slave.diagnostics.record_timeout(when)
        if not slave.not_sending:
            slave.not_sending = True
            slave.channel.not_sending = True
            # INFO: one lost answer on a noisy line is no news; who shows the drive decides
            # when it is gone (`pyuss.points`: after several, "offline")
            log.info(
                "slave %d does not send (no answer within %.1f ms)",
                slave.address,
                slave.response_delay * 1000,
            )

    # -- the line --------------------------------------------------------------------------
    def send_due(self, pause_chars: float) -> float:
        """When the start pause before the next telegram ends: after the end of the last byte
        on the line, the master's own or received."""
        pause = max(2.0, pause_chars) * self.timing.char_time
        return max(self.line_free, self.receiver.last_byte_end) + pause + 1e-9

    def sending(self, now: float) -> None:
        """The next telegram goes out now: what the receiver holds is over (``now`` matters
        only while the receiver holds something, `Receiver.busy`)."""
        receiver = self.receiver
        if receiver.busy:
            self.between(receiver.poll(now))
        receiver.reset()
        self._after_broadcast = False

    def sent(self, frame: bytes, start: float, on_line: float, end: float) -> None:
        """``frame`` went out at ``start`` and took ``on_line`` seconds on the line; the write
        returned at ``end`` (or later)."""
        on_line += start
        end = max(on_line, end)
        self.line_free = end
        # the model's end, not the clock's: a master woken late must not take an answer
        # that began after its request for one that began before
        self._sent_frame, self._sent_end = frame, on_line
        self._echo_in = False
        log_frame("tx", frame, end)

    def feed(self, chunk: Chunk) -> list[Received | ReceiveFault]:
        """Feed a chunk to the receiver (which allows for coarse stamps, ``rx_tolerance``)."""
        return self.receiver.feed(chunk.data, chunk.timestamp, chunk.errors)

    def settle(self, now: float) -> None:
        """Between exchanges: what the receiver holds that ended ``latency`` ago is over (only
        while it holds something, `Receiver.busy`)."""
        self.between(self.receiver.poll(now - self.latency))

    def _overlaps(self, start: float) -> bool:
        """Whether what began at ``start`` was on the line while the request just sent was:
        known on a line that stamps characters exactly (the virtual bus, ``bus://``) only.
        No answer begins before its request ended."""
        return self.exact and start < self._sent_end - 1e-6

    def own(self, event: Received, process_data: bool = False) -> bool:
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
        if self.exact:
            if not self._overlaps(event.start):
                return False
        elif (
            (bool(sent[2] & _MIRROR_BIT) or not process_data or not any(event.telegram.data))
            and not self.loopback
            and (self.own_heard == 0 or self._echo_in)
        ):
            return False
        self._echo_in = True
        self._heard_own(event)
        return True

    def _heard_own(self, event: Received) -> None:
        self.own_heard += 1
        log_frame("rx", event.raw, event.end, "the master's own telegram heard back")
        if self.own_heard == 1:
            log.warning(
                "the master hears its own telegrams back (the line echoes: a 2-wire adapter "
                "without echo suppression?): they are not taken as answers; add echo=1 to "
                "the port URL to have the echo checked and removed"
            )

    def between(self, events: list[Received | ReceiveFault]) -> None:
        """What arrived while no answer was awaited: echoes, answers to a broadcast, stray."""
        for event in events:
            if isinstance(event, Received):
                # a copy of the request: its echo where time tells, or where nothing else
                # could send it (a loopback; a broadcast, which no slave answers, and an
                # answer would carry the slave's address); else a late answer (a mirror)
                if event.raw == self._sent_frame and (
                    self._overlaps(event.start)
                    if self.exact
                    else self.loopback or event.telegram.mode.is_broadcast
                ):
                    self._heard_own(event)
                    continue
                log_frame("rx", event.raw, event.end, "stray")
                if self._after_broadcast:
                    self.answered_broadcasts += 1
                    log.warning(
                        "a telegram from address %d answered a broadcast (A 3 forbids it)",
                        event.telegram.address,
                    )
                else:
                    self.stray += 1
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

    def listen_done(self, until: float, now: float) -> float | None:
        """After a broadcast: None when listening is over (``until`` plus latency passed and
        the line quiet), else how long to wait for more."""
        left = until + self.latency - now
        if left <= 0 and not self.receiver.busy:
            return None
        return max(left, self.timing.start_pause)

    def judge(
        self,
        event: Received | ReceiveFault,
        address: int,
        modes: Collection[AddressMode],
        deadline: float,
        slave: Slave | None,
    ) -> Outcome | None:
        """Classify one event while the answer of ``address`` is awaited."""
        if isinstance(event, ReceiveFault):
            log_frame("rx", event.raw, event.end, f"fault {event.kind.name}: {event.detail}")
            if self._overlaps(event.start):
                self._stray_seen(event.end)  # sent while the request was: a collision
            if slave is not None:
                slave.diagnostics.record_fault(event.kind, event.end)
            return Outcome.FAULT
        if event.raw == self._sent_frame and self.own(
            event, slave is not None and slave.layout.pzd > 0
        ):
            return None
        telegram = event.telegram
        wrong = telegram.address != address or telegram.mode not in modes
        if wrong or (self.exact and event.start < self._sent_end - 1e-6):  # `_overlaps`
            # another's telegram, or one that began while the request was on the line
            why = f"not the answer of {address}" if wrong else "began before the request ended"
            log_frame("rx", event.raw, event.end, f"discarded: {why}")
            self._stray_seen(event.end)
            if slave is not None:
                slave.wrong_address += wrong
                slave.diagnostics.record_discarded(event.end)
            return None
        log_frame("rx", event.raw, event.end)
        if event.start > deadline + self.timing.char_time * 1e-3:
            if slave is not None:
                slave.late += 1
            log.debug(
                "slave %d answered %.1f ms after the deadline: not used",
                address,
                (event.start - deadline) * 1000,
            )
            return Outcome.LATE
        return Outcome.ANSWER

    def finish(
        self,
        outcome: Outcome,
        received: Received | None,
        start: float,
        end: float,
        slave: Slave | None,
        now: float,
    ) -> Result:
        if slave is not None and outcome in (Outcome.SILENT, Outcome.LATE) and not self.closing:
            self._silent(slave, now)
        return Result(outcome, received if outcome is Outcome.ANSWER else None, start, end)

    # -- figures ---------------------------------------------------------------------------
    def cycle_stats(self) -> CycleStats:
        """Achieved cycle times (A 5.1.1)."""
        return CycleStats(
            cycles=self._cycle_count,
            cycle_time=self.cycle_time,
            achieved=self._cycles.summary(),
            overruns=self._overruns,
        )

    def snapshot(self, now: float) -> BusDiagnostics:
        """A snapshot of the line and of every slave."""
        return BusDiagnostics(
            baud=self.baud,
            line=self.line.snapshot(now),
            cycles=self.cycle_stats(),
            broadcasts=self.broadcasts,
            answered_broadcasts=self.answered_broadcasts,
            stray=self.stray,
            own_heard=self.own_heard,
            slaves=tuple(self.slaves[a].snapshot(now) for a in sorted(self.slaves)),
        )


class Exchange:
    """The wait for one answer (A 5.2): fed every chunk (`feed`) and told the time (`step`),
    it says how long to wait for more, or how the exchange ended. Meanwhile the jobs of other
    slaves end at their deadlines, also jobs queued while it runs."""

    __slots__ = (
        "_core",
        "_events",
        "_jobs_due",
        "_receiver",
        "_submitted",
        "address",
        "deadline",
        "end",
        "faulty",
        "modes",
        "slave",
        "start",
    )  # fmt: skip

    def __init__(
        self,
        core: MasterCore,
        address: int,
        modes: Collection[AddressMode],
        limit: float,
        slave: Slave | None,
        start: float,
        end: float,
    ) -> None:
        self._core = core
        self._receiver = core.receiver
        self.address = address
        self.modes = modes
        self.slave = slave
        self.start = start
        self.end = end
        self.deadline = end + limit + core.rx_tolerance
        self.faulty = False
        self._events: list[Received | ReceiveFault] = []
        self._submitted = core.submitted
        self._jobs_due = core.next_deadline(exclude=slave)

    def feed(self, chunk: Chunk) -> None:
        self._events += self._receiver.feed(chunk.data, chunk.timestamp, chunk.errors)

    def step(self, now: float) -> Result | float | None:
        """After feeding every chunk that is in: the `Result`, or how long to wait for more
        (seconds), or None when the window is over - the loop then takes one last look for
        what is due (a chunk to `feed`, then `step` again) before `give_up`."""
        core = self._core
        slave = self.slave
        if self._submitted != core.submitted:
            self._submitted = core.submitted
            self._jobs_due = core.next_deadline(exclude=slave)
        if self._jobs_due is not None and now > self._jobs_due:
            core.expire_jobs(now, exclude=slave)
            self._jobs_due = core.next_deadline(exclude=slave)
        receiver = core.receiver
        events = self._events
        if receiver.busy:
            events += receiver.poll(now - core.latency)
        found: tuple[Outcome, Received] | None = None
        for event in events:
            outcome = core.judge(event, self.address, self.modes, self.deadline, slave)
            if outcome is Outcome.FAULT:
                self.faulty = True
            elif outcome is not None and found is None:
                assert isinstance(event, Received)
                found = (outcome, event)
        self._events = []
        if found is not None:
            return core.finish(found[0], found[1], self.start, self.end, slave, now)
        if receiver.busy:
            nxt = receiver.next_poll()
            wait = (nxt if nxt is not None else now) + core.latency - now
            wait = max(wait, core.timing.char_time)
        else:
            # the first character of an answer that began at the deadline ends one
            # character time later and is handed over a little after that
            wait = self.deadline + core.timing.char_time + core.silence - now
            if wait <= 0:
                return None
        if self._jobs_due is not None:
            wait = min(wait, max(self._jobs_due - now, 0.0) + 1e-4)
        return min(wait, JOB_CHECK)

    def give_up(self, now: float) -> Result:
        """The window is over and nothing more came: silent, or garbled."""
        outcome = Outcome.FAULT if self.faulty else Outcome.SILENT
        return self._core.finish(outcome, None, self.start, self.end, self.slave, now)
