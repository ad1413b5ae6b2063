"""The USS slave engine, without I/O: a received telegram and the time in, the answer or silence
out.

`SlaveEngine.handle` decides for every telegram the line brings (A 2.1, A 5.2.2, A 5.3, A 5.4):

- A slave answers only telegrams received without error (the receiver has dropped the others)
  and addressed to it (ADR bits 0..4). A normal telegram whose length does not fit the slave's
  layout is discarded as a wrong LGE (A 5.2, C 7).
- A mirror telegram (ADR bit 6) for its address is sent back unchanged (A 5.3); nothing in it
  is processed.
- A broadcast (ADR bit 5) is never answered (A 3); its process data are taken in the profile's
  form (`pyuss.slave.process`, appendix, reading 9); parameter jobs in it are never executed.
- A special telegram (ADR bit 7) is discarded unless a handler is registered (A 5.4); with one,
  the handler's answer is sent (never for a special broadcast).
- Undefined ADR combinations lead to no reaction: `Telegram` cannot even hold them, and
  `handle_bytes` drops them with every other malformed frame.

Process data come first (C 5.1: "Die PZD-Verarbeitung hat Vorrang vor der PKW-Bearbeitung"),
then the parameter channel, with the semantics of C 4.2.1.1:

- One job at a time; any change of the job (ID, PNU, IND, PWE - the toggle bit 11 is not part
  of it) is a new job; repeating a job does not execute it again.
- A new job's answer is ready after the configured processing latency (`JobLatency`: a number
  of further telegrams and/or seconds; 0 by default). Until then the answer to the previous job
  is repeated, always with the current value; the very first contact is answered "no response".
  The job itself (a write, for example) is carried out when its answer becomes ready; a job
  replaced before that is never carried out.
- "No job" is answered "no response".
- Jobs run on the drive through `pyuss.slave.channel.ParameterChannel` (request IDs, IND 255,
  texts, EEPROM IDs, response 8 without write authority, response 7 with the right number when
  the answer does not fit the PKW area).

Spontaneous messages (C 4.2.1.2), if the profile (or the caller) enables them: a change of an
active parameter made elsewhere (the drive itself, another interface) interrupts the answers:
the slave flips its toggle bit (PKE bit 11) and sends the change with response ID 9..12 until
the master acknowledges by sending the same toggle bit; then the next change, or the interrupted
answers. Normal answers carry the slave's current toggle bit. Changes of the same element that
wait are merged (the newest value is reported). Whole-array changes, and values that do not fit
a fixed PKW area, are reported with PNU and IND but without values.

Telegram failure time (C 3.1 "Telegrammausfallzeit"): monitoring starts with the first good
telegram addressed to the slave; when no further one arrives within the time, the drive trips
the fault ``telegram_failure`` of its parameter file (`TELEGRAM_FAILURE_FAULT` when the file
names none; status word bit 3) and the diagnostics record a
timeout (A 5.2.3 bit 7, counter 16). The next good telegram starts the monitoring again; the
fault stays until the master acknowledges it (control word bit 7). Broadcasts do not count.
The time comes from the interface parameter ``failure_time`` of the parameter file (its unit
and scaling; 0 = off) unless given; the time in force is shown there. `SlaveEngine.tick`
checks it; a server calls it when `SlaveEngine.next_deadline` has come.

Baumueller drives without response-delay mode (P181 bit 2 = 0) answer with the telegram prepared
after the previous request (Baumueller manual 2.5): the engine then returns that one and prepares
the
next; the first request is answered with its own process data and "no response".

Layout: given, or read from the drive's interface parameters ``pkw``/``pzd`` (C 3), or the
profile's default; the address and layout in force are written back to those parameters, and
so are the failure time in force and (`set_line_baud`) the line's baud rate
(`pyuss.slave.interface`). A change of the failure time parameter through any interface is
in force from then on.
"""

from __future__ import annotations

import logging
import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, replace

from pyuss.drive.faults import ParameterFault
from pyuss.drive.memory import WHOLE_ARRAY, ParameterChange
from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import ConfigError, TelegramError
from pyuss.profiles.base import Profile
from pyuss.protocol.diagnostics import Diagnostics, FaultKind
from pyuss.protocol.layout import PKW_VARIABLE, Layout, NetData
from pyuss.protocol.pkw import Pkw, ResponseId
from pyuss.protocol.pzd import ControlWord
from pyuss.protocol.telegram import MAX_ADDRESS, AddressMode, Telegram
from pyuss.slave.channel import ParameterChannel
from pyuss.slave.diagnostic import DiagnosticParameters, software_version
from pyuss.slave.interface import InterfaceParameters
from pyuss.slave.process import bit_set, broadcast_action, process_mapping

__all__ = ["TELEGRAM_FAILURE_FAULT", "JobLatency", "SlaveEngine", "SpecialHandler"]

log = logging.getLogger("pyuss.slave")

SpecialHandler = Callable[[Telegram, float], Telegram | None]
"""Handles a special telegram (ADR bit 7) at a time; returns the answer or None (A 5.4)."""

TELEGRAM_FAILURE_FAULT = 65
"""Fault code tripped when the telegram failure time expires and the parameter file's
``[faults]`` table names no ``telegram_failure`` (the generic profile's number)."""

_CONTROL_BY_PLC = int(ControlWord.CONTROL_BY_PLC)  # a plain int: IntFlag arithmetic is slow

_MAX_SPONTANEOUS = 64
"""Changes waiting to be reported; beyond that the oldest are dropped (and logged)."""


@dataclass(frozen=True, slots=True)
class JobLatency:
    """How long the slave takes to answer a new parameter job: the answer is ready once the job
    has been received ``cycles`` more times and ``seconds`` have passed since it first came."""

    cycles: int = 0
    seconds: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.cycles, bool) or not isinstance(self.cycles, int) or self.cycles < 0:
            raise ConfigError(
                f"job latency must be a number of telegrams >= 0, not {self.cycles!r}"
            )
        if not self.seconds >= 0:
            raise ConfigError(f"job latency must be >= 0 seconds, not {self.seconds!r}")


class SlaveEngine:
    """The slave at bus ``address`` serving ``drive`` the way ``profile`` says (see the module
    docstring).

    Options: ``layout`` (else from the drive's interface parameters, else the profile's
    default), ``interface`` (the name under which this interface writes parameters and
    receives change reports), ``latency`` (`JobLatency`), ``failure_time`` (seconds, 0 = off,
    None = from the parameter file), ``spontaneous`` (None = the profile's choice),
    ``write_authority``, ``diagnostics`` (shared with the receiver of the port; a new one if
    not given), ``diagnostic_pnu`` (first diagnostic parameter; None = the profile's),
    ``special`` (handler for special telegrams), ``now`` (start time).
    """

    def __init__(
        self,
        address: int,
        drive: SimulatedDrive,
        profile: Profile,
        *,
        layout: Layout | None = None,
        interface: str = "uss",
        latency: JobLatency | None = None,
        failure_time: float | None = None,
        spontaneous: bool | None = None,
        write_authority: bool = True,
        diagnostics: Diagnostics | None = None,
        diagnostic_pnu: int | None = None,
        special: SpecialHandler | None = None,
        now: float = 0.0,
    ) -> None:
        if isinstance(address, bool) or not isinstance(address, int):
            raise ConfigError(f"bus address must be an integer 0..{MAX_ADDRESS}, not {address!r}")
        if not 0 <= address <= MAX_ADDRESS:
            raise ConfigError(f"bus address must be 0..{MAX_ADDRESS}, not {address}")
        self.address = address
        self.drive = drive
        self.profile = profile
        self.interface = interface
        self.latency = latency or JobLatency()
        self.special = special
        self.layout = profile.check_layout(layout) if layout is not None else self._file_layout()
        self.interface_parameters = InterfaceParameters(drive)
        self._failure_time = 0.0
        if failure_time is None:
            self._failure_time = self.interface_parameters.failure_time() or 0.0
        else:
            self.failure_time = failure_time
        self.baud: int | None = None
        """The baud rate of the line, once a server told it (`set_line_baud`)."""
        self.pending_baud: int | None = None
        """A rate written to the baud rate parameter that the line is to switch to."""
        self._follows = False
        self._undo: list[Callable[[], None]] = [
            self.interface_parameters.watch_failure_time(self._failure_time_changed)
        ]
        self.diagnostics = diagnostics or Diagnostics(software_version=software_version())
        base = profile.diagnostic_pnu if diagnostic_pnu is None else diagnostic_pnu
        self.diagnostic_parameters = DiagnosticParameters(base, self.diagnostics, drive.db)
        self.channel = ParameterChannel(
            drive,
            self.layout,
            profile,
            interface=interface,
            diagnostics=self.diagnostic_parameters,
            requests=profile.request_ids,
        )
        self._write_interface()
        drive.set_write_authority(interface, write_authority)
        self.process = process_mapping(profile)
        self.spontaneous = profile.spontaneous if spontaneous is None else spontaneous
        self._changes: OrderedDict[tuple[int, int | None], ParameterChange] = OrderedDict()
        self._unsubscribe: Callable[[], None] | None = None
        if self.spontaneous and self.layout.pkw:
            self._unsubscribe = drive.subscribe(interface, self._on_change)
        # parameter channel state
        self._job: Pkw | None = None
        self._job_since = now
        self._job_repeats = 0
        self._pending = False
        self._done: tuple[Pkw, Pkw] | None = None
        self._toggle = False
        self._shown: Pkw | None = None
        # process data and monitoring
        self._last_pzd: tuple[int, ...] = (0,) * self.layout.pzd
        self._prepared: Telegram | None = None
        self._request: tuple[bytes, NetData] | None = None
        self._last_answer: tuple[Pkw | None, tuple[int, ...], Telegram] | None = None
        self._last_good: float | None = None
        self._monitoring = False
        self.timeouts = 0

    def use_diagnostics(self, diagnostics: Diagnostics) -> None:
        """Count on ``diagnostics`` from now on (a server shares one per port)."""
        self.diagnostics = diagnostics
        self.diagnostic_parameters.diagnostics = diagnostics

    def close(self) -> None:
        """End the change subscription and the watch of the interface parameters (the drive
        lives on)."""
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        undo, self._undo = self._undo, []
        for step in undo:
            step()

    # -- interface settings in force ---------------------------------------------------------

    @property
    def failure_time(self) -> float:
        """The telegram failure time in force, in seconds (0: not watched, C 3.1)."""
        return self._failure_time

    @failure_time.setter
    def failure_time(self, seconds: float) -> None:
        """Watch for ``seconds`` from now on, and show it in the drive's failure time
        parameter; `ConfigError` when the drive cannot have that time."""
        if isinstance(seconds, bool) or not isinstance(seconds, int | float) or not seconds >= 0:
            raise ConfigError(f"telegram failure time must be >= 0 s, not {seconds!r}")
        if math.isinf(seconds):
            raise ConfigError("telegram failure time must be a finite number of seconds")
        self.interface_parameters.show_failure_time(seconds)
        self._failure_time = float(seconds)

    def _failure_time_changed(self, seconds: float) -> None:
        if seconds != self._failure_time:
            log.info("address %d: telegram failure time %g s from now on", self.address, seconds)
        self._failure_time = seconds

    def set_line_baud(self, baud: int, *, follows: bool = False) -> None:
        """The line runs at ``baud``: the drive shows it in its baud rate parameter.
        ``follows``: the line switches to a rate written to that parameter (`pending_baud`,
        for the server to carry out after the answer); else the rate is fixed while the line
        runs and a change must be stored for the next start (`pyuss.slave.interface`).
        `ConfigError` when the drive does not run at ``baud``."""
        self.interface_parameters.show_baud(baud)
        ref = self.drive.db.interface.get("baud")
        if self.baud is None and ref is not None:
            self._undo.append(self.interface_parameters.guard_baud(lambda: self._follows))
            self._undo.append(self.drive.watch(ref.pnu, self._baud_changed))
        self.baud = baud
        self._follows = follows
        self.pending_baud = None

    def _baud_changed(self, _pnu: int) -> None:
        wanted = self.interface_parameters.baud()
        if wanted is None or wanted == self.baud:
            self.pending_baud = None
        elif self._follows:
            self.pending_baud = wanted
        else:
            log.info(
                "address %d: baud rate %d stored; the line runs at %s baud until the next start",
                self.address,
                wanted,
                self.baud,
            )

    # -- settings from and to the parameters ------------------------------------------------

    def _interface_value(self, role: str) -> int | float | None:
        ref = self.drive.db.interface.get(role)
        if ref is None:
            return None
        value = self.drive.ref_value(ref)
        return value if isinstance(value, int | float) else None

    def _own_layout(self) -> Layout:
        pkw, pzd = self._interface_value("pkw"), self._interface_value("pzd")
        if pkw is None or pzd is None:
            return self.profile.fixed_layout or self.profile.default_layout
        try:
            return Layout(int(pkw), int(pzd))
        except ConfigError as exc:
            raise ConfigError(f"the parameter file's interface parameters: {exc}") from None

    def _file_layout(self) -> Layout:
        """The layout of the drive's interface parameters (or the profile's default), checked
        against the profile; the error says where a refused layout came from."""
        own = self._own_layout()
        try:
            return self.profile.check_layout(own)
        except ConfigError as exc:
            refs = [self.drive.db.interface.get(role) for role in ("pkw", "pzd")]
            where = ", ".join(str(ref) for ref in refs if ref is not None)
            raise ConfigError(
                f"{exc} (the layout of the parameter file's interface parameters {where}; "
                "give the layout explicitly)"
            ) from None

    def _write_interface(self) -> None:
        db = self.drive.db
        for role, value in (
            ("address", self.address),
            ("pkw", self.layout.pkw),
            ("pzd", self.layout.pzd),
        ):
            ref = db.interface.get(role)
            if ref is None:
                continue
            try:
                self.drive.update(ref.pnu, value, ref.index)
            except ParameterFault as exc:
                log.warning(
                    "address %d: cannot show %s %d in %s: %s", self.address, role, value, ref, exc
                )

    # -- timing -----------------------------------------------------------------------------

    @property
    def delay_mode(self) -> bool:
        """The device's response-delay mode is on (Baumueller P181 bit 2)."""
        return bit_set(self.drive, self.profile.delay_mode)

    def response_window(self, baud: int) -> tuple[float, float]:
        """``(earliest, latest)`` start of an answer after the request's end, in seconds."""
        return self.profile.response_delay(baud, delayed=self.delay_mode)

    def manual_delay(self, baud: int) -> float | None:
        """The response delay the drive's parameter file gives (``[profile]
        response_delay_ms``, the family's manual), in seconds, inside `response_window`; None
        where the file gives none."""
        delay = self.drive.db.profile.response_delay_ms
        if delay is None:
            return None
        low, high = self.response_window(baud)
        return min(max(delay / 1000, low), high)

    def next_deadline(self) -> float | None:
        """When `tick` has something to do: the telegram failure time expires."""
        if not self._monitoring or self._last_good is None or not self.failure_time:
            return None
        return self._last_good + self.failure_time

    def tick(self, now: float) -> None:
        """Let time pass: the telegram failure time expires (C 3.1)."""
        deadline = self.next_deadline()
        if deadline is None or now < deadline:
            return
        self._monitoring = False
        self.timeouts += 1
        self.diagnostics.record_timeout(deadline)
        code = self.drive.db.faults.get("telegram_failure", TELEGRAM_FAILURE_FAULT)
        log.warning(
            "address %d: no telegram for %.3f s: telegram failure time expired, fault %d",
            self.address,
            self.failure_time,
            code,
        )
        self.drive.raise_fault(code, deadline)

    # -- telegrams --------------------------------------------------------------------------

    def handle_bytes(self, raw: bytes, now: float) -> bytes | None:
        """`handle` for the bytes of one whole telegram; malformed frames (STX, LGE, BCC,
        undefined ADR) are dropped without a reaction. Returns the answer's bytes."""
        try:
            telegram = Telegram.decode(raw)
        except TelegramError as exc:
            log.debug("address %d: dropped %s: %s", self.address, raw.hex(" "), exc)
            return None
        answer = self.handle(telegram, now)
        return None if answer is None else answer.encode()

    def handle(self, telegram: Telegram, now: float) -> Telegram | None:
        """The answer to ``telegram`` received complete and without error at ``now``, or None
        for silence (see the module docstring)."""
        self.tick(now)
        mode = telegram.mode
        if mode is AddressMode.BROADCAST:
            self._broadcast(telegram, now)
            return None
        if mode is AddressMode.SPECIAL_BROADCAST:
            if self.special is not None:
                self.special(telegram, now)
            return None
        if telegram.address != self.address:
            return None
        if mode is AddressMode.MIRROR:
            self._good(telegram, now)
            return telegram
        if mode is AddressMode.SPECIAL:
            if self.special is None:
                log.debug("address %d: special telegram discarded (A 5.4)", self.address)
                return None
            return self.special(telegram, now)
        return self._exchange(telegram, now)

    def _good(self, telegram: Telegram, now: float) -> None:
        self._last_good = now
        self._monitoring = True
        self.diagnostic_parameters.note_telegram(telegram)

    def _exchange(self, telegram: Telegram, now: float) -> Telegram | None:
        layout = self.layout
        try:
            net = self._unpack(telegram.data)
        except TelegramError as exc:
            self.diagnostics.record_fault(FaultKind.BAD_LGE, now)
            log.debug("address %d: telegram discarded: %s", self.address, exc)
            return None
        self._good(telegram, now)
        pipelined = self.profile.delay_mode is not None and not self.delay_mode
        if not net.pzd or net.pzd[0] & _CONTROL_BY_PLC:
            # the process data in force; with control bit 10 = 0 the telegram's are ignored
            # and the old ones stay (C Table 5.4), also as the base of the next broadcast
            self._last_pzd = net.pzd
        pzd = self.process.exchange(self.drive, net.pzd, now)
        pkw = None if net.pkw is None else self._parameter(net.pkw, now)
        answer = self._answer(pkw, pzd)
        if not pipelined:
            self._prepared = None
            return answer
        prepared, self._prepared = self._prepared, answer
        if prepared is None:
            return Telegram(self.address, AddressMode.NORMAL, layout.pack(None, pzd))
        return prepared

    def _unpack(self, data: bytes) -> NetData:
        """``layout.unpack(data)``; a master repeats its telegrams, so the last one is kept."""
        last = self._request
        if last is None or last[0] != data:
            last = self._request = (data, self.layout.unpack(data))
        return last[1]

    def _answer(self, pkw: Pkw | None, pzd: tuple[int, ...]) -> Telegram:
        """The answer telegram with ``pkw`` and ``pzd``; the last one is kept, as answers
        repeat as long as the requests do."""
        last = self._last_answer
        if last is None or last[0] != pkw or last[1] != pzd:
            answer = Telegram(self.address, AddressMode.NORMAL, self.layout.pack(pkw, pzd))
            last = self._last_answer = (pkw, pzd, answer)
        return last[2]

    def _broadcast(self, telegram: Telegram, now: float) -> None:
        try:
            net = self.layout.unpack(telegram.data)
        except TelegramError as exc:
            log.debug("address %d: broadcast not taken: %s", self.address, exc)
            return
        coding = bit_set(self.drive, self.profile.broadcast_coding)
        action = broadcast_action(
            self.profile, self.layout, net, self._last_pzd, address=self.address, coding=coding
        )
        if action.pzd is not None:
            self.process.exchange(self.drive, action.pzd, now)
        elif action.control is not None:
            old = self.drive.machine.control
            word = (old & ~action.mask & 0xFFFF) | (action.control & action.mask)
            self.process.control(self.drive, word, now)
        else:
            log.debug("address %d: broadcast not taken: %s", self.address, action.reason)

    # -- parameter channel ------------------------------------------------------------------

    def _parameter(self, request: Pkw, now: float) -> Pkw:
        if self._shown is not None and request.spm_toggle == self._toggle:
            self._shown = None  # the master acknowledged the spontaneous message
        job = replace(request, spm_toggle=False) if request.spm_toggle else request
        if job != self._job:
            self._job = job
            self._job_since = now
            self._job_repeats = 0
            self._pending = True
        else:
            self._job_repeats += 1
        latency = self.latency
        if (
            self._pending
            and self._job_repeats >= latency.cycles
            and now - self._job_since >= latency.seconds
        ):
            self._pending = False
            answer = self.channel.execute(job, now)
            self._done = (job, answer)
        elif self._done is not None:
            answer = self.channel.current(*self._done, now)
        else:
            answer = Pkw(ResponseId.NO_RESPONSE)
        if self._shown is None and self._changes:
            _, change = self._changes.popitem(last=False)
            self._toggle = not self._toggle
            self._shown = self._spontaneous(change)
        if self._shown is not None:
            answer = self._shown
        if answer.spm_toggle == self._toggle:
            return answer
        return replace(answer, spm_toggle=self._toggle)

    def _on_change(self, change: ParameterChange) -> None:
        key = (change.pnu, change.index)
        self._changes.pop(key, None)
        self._changes[key] = change
        while len(self._changes) > _MAX_SPONTANEOUS:
            (pnu, index), _ = self._changes.popitem(last=False)
            log.warning(
                "address %d: too many spontaneous messages waiting; P%d%s not reported",
                self.address,
                pnu,
                "" if index is None else f".{index}",
            )

    def _spontaneous(self, change: ParameterChange) -> Pkw:
        """The PKW area reporting ``change`` (C 4.2.1.2, C Table 4.8)."""
        if change.index is None:
            rid = ResponseId.SPONTANEOUS_DWORD if change.double else ResponseId.SPONTANEOUS_WORD
        elif change.double:
            rid = ResponseId.SPONTANEOUS_ARRAY_DWORD
        else:
            rid = ResponseId.SPONTANEOUS_ARRAY_WORD
        pnu_bits, page = self.profile.encode_pnu(change.pnu)
        index = 0 if self.profile.answer_index_zero else page | (change.index or 0)
        words = change.words
        whole = change.index == WHOLE_ARRAY
        if len(words) > self.layout.max_pwe or (whole and self.layout.pkw != PKW_VARIABLE):
            words = ()
        return Pkw(rid, pnu_bits, index, False, words)
