"""The Modbus register map of one drive: data points <-> registers, without sockets.

The Modbus face (`pyuss.gateway.modbus`) answers unit id N with the drive at USS address N;
this module decides what every register of that unit means. Addresses are the protocol's,
counting from 0 (the "register 30001/40001" of many HMIs is address 0). A value of 32 bits
(integer or IEEE 754 float) fills two registers; `WordOrder` says which comes first (high
word first by default, as USS itself sends double words). Reserved addresses inside the map
read 0; addresses beyond it are refused (exception 02).

Input registers (function 4), what the drive reports::

    0        status word (PZD1 of the latest answer)
    1        drive state: 0 no answer yet, 1 not ready to switch on, 2 switch-on inhibited,
             3 ready to switch on, 4 ready, 5 operation enabled, 6 fault, 7 OFF2, 8 OFF3
    2        health bits: 0 offline (no answer yet, as many answers missed in a row or as
             long without one as the bus's offline_after_* say, or the bus offline: the
             values are not live), 1 no answer yet, 2 fault (status bit 3), 3 warning
             (status bit 7), 4 the reference is known, 5 stale (online, but the latest
             answer missed: the values are the last answer's), 6 the bus is offline (no
             master exchanges on its line: the port lost and being reopened)
    3        error status word of A 5.2.3
    4        last fault number (read from the profile's fault parameter when the fault bit
             rose; 0 none)
    5        last refused job: response ID (0 none, 7 refused, 8 no write authority)
    6        last refused job: the drive's error number (C Table 4.3)
    7        last refused job: PNU
    8..22    PZD2..PZD16 of the latest answer (raw words)
    24+4k    actual value k in its unit (float, 2 registers); k = 0..3, configured order
    26+4k    actual value k in percent (float, 2 registers)
    40..55   the 16 diagnostic parameters of A 5.2.3 (counters modulo 65536)
    56..57   answers received (32 bits)
    58..59   answers missed (timeouts, 32 bits)
    100+2k   configured parameter k as last read (no job is sent): float for float and
             scaled parameters, else a 32-bit integer; NaN / 8000 0000h until read

Holding registers (functions 3, 6, 16, 22, 23), what the master sends::

    0        control word (read: as sent; write: sent from the next telegram)
    1        command (write): 1 ON, 2 OFF1, 3 OFF2, 4 OFF3, 5 acknowledge; reads 0
    2..16    PZD2..PZD16 of the request (raw setpoint words)
    24+4k    setpoint k in its unit (float); k = 0..3, configured order
    26+4k    setpoint k in percent (float)
    100+2k   configured parameter k: a read sends a parameter job (unless the parameter is
             polled: then its last value), a write sends one
    200..210 the parameter mailbox, for any parameter:
             200 PNU, 201 index (FFFFh: none), 202 format (`MailboxFormat`), 203..204
             the value to write (32 bits), 205 command (write 1 read, 2 write, 3 write and
             store in EEPROM), 206 status (0 idle, 1 done, 2 refused, 3 failed, 4 written but
             the drive holds another value), 207
             response ID (7 or 8 when refused), 208 the drive's error number, 209..210 the
             value read or answered

Mailbox formats (register 202) say what 203..204 and 209..210 carry::

    0        the value in the parameter's unit: 32-bit integer for integer parameters,
             float for float and scaled ones
    1, 2     the drive's word as on the line (no scaling), unsigned / signed 16 bits, in
             the low register (refused for double-word and float parameters)
    3, 4     the drive's double word as on the line, unsigned / signed 32 bits (a float
             parameter's IEEE 754 bits)
    5        the value in the parameter's unit, float
    6, 7, 8  the value in the parameter's unit times 10, 100, 1000, signed 32 bits

P448 = 7.5 Hz (a word in steps of 0.01 Hz) is 750 in format 2, 7.5 in formats 0 and 5, 75 in
format 6.

A write is checked whole before anything is sent: `DriveRegisters.plan_write` turns the
request into a `WritePlan` or refuses it (`RegisterError`) without sending anything or
changing the mailbox, and only a whole plan is carried out (`DriveRegisters.carry_out`): a
refused request changes nothing. The plan's parts go out in this order: process data (the
control word, PZD words and setpoints in one telegram), the configured parameters' jobs, the
mailbox's job, the command. What the gateway cannot check beforehand is the drive's own
answer: a parameter job the drive refuses stops the parts after it, the ones before it were
answered.

A write returns once the telegram carrying it was answered (process data) or the parameter job
was answered, so a client that writes a setpoint sees it on the bus in the next cycle, and a
refusal comes back as the Modbus exception of `EXCEPTIONS`. The drive's error number is in
the mailbox (208) and in input registers 5..7.

Values of two registers must be written whole, in one request (function 16 or 23). A face
configured read-only refuses every write (exception 01) except one to the mailbox's registers
200..205 alone with command 0 or 1 (a read job), which changes no drive.
"""

from __future__ import annotations

import enum
import math
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from pyuss.errors import ConfigError, DriveRefusal, UssError
from pyuss.points import NoWriteAuthority
from pyuss.points.config import ProcessConfig
from pyuss.points.drive import DrivePoints
from pyuss.points.errors import Failure, NotInControl, classify
from pyuss.points.parameters import ParamMeta
from pyuss.points.state import DriveState, ProcessValue

__all__ = [
    "EXCEPTIONS",
    "HOLDING_SIZE",
    "INPUT_SIZE",
    "DriveRegisters",
    "MailboxFormat",
    "MailboxJob",
    "ModbusException",
    "RegisterError",
    "WordOrder",
    "WritePlan",
    "from_registers",
    "to_registers",
]


class ModbusException(enum.IntEnum):
    """Modbus exception codes the gateway answers with."""

    ILLEGAL_FUNCTION = 0x01
    ILLEGAL_DATA_ADDRESS = 0x02
    ILLEGAL_DATA_VALUE = 0x03
    SERVER_DEVICE_FAILURE = 0x04
    GATEWAY_PATH_UNAVAILABLE = 0x0A
    GATEWAY_TARGET_NO_RESPONSE = 0x0B


EXCEPTIONS: dict[Failure, ModbusException] = {
    Failure.NOT_FOUND: ModbusException.ILLEGAL_DATA_ADDRESS,
    Failure.BAD_VALUE: ModbusException.ILLEGAL_DATA_VALUE,
    Failure.REFUSED: ModbusException.SERVER_DEVICE_FAILURE,
    Failure.NO_AUTHORITY: ModbusException.SERVER_DEVICE_FAILURE,
    Failure.READ_ONLY: ModbusException.ILLEGAL_FUNCTION,
    Failure.NO_ANSWER: ModbusException.GATEWAY_TARGET_NO_RESPONSE,
    Failure.UNAVAILABLE: ModbusException.GATEWAY_PATH_UNAVAILABLE,
}
"""The exception for each class of failure (`pyuss.points.errors`)."""


class RegisterError(UssError):
    """A request the map answers with a Modbus exception."""

    def __init__(self, code: ModbusException, message: str) -> None:
        self.code = code
        super().__init__(f"Modbus exception {int(code):02X}h: {message}")


class WordOrder(enum.Enum):
    """Which register of a 32-bit value comes first."""

    BIG = "big"
    """High word first (the USS order of double words, C 6)."""
    LITTLE = "little"
    """Low word first."""

    @classmethod
    def parse(cls, text: object) -> WordOrder:
        for order in cls:
            if text == order.value:
                return order
        raise ConfigError(f"word order must be 'big' or 'little', not {text!r}")


def to_registers(value: float | int | None, kind: str, order: WordOrder) -> tuple[int, int]:
    """Two registers of ``value``: ``kind`` "float" (IEEE 754; None -> NaN) or "int"
    (32 bits two's complement; None -> 8000 0000h)."""
    if kind == "float":
        number = math.nan if value is None else float(value)
        raw = struct.unpack(">I", struct.pack(">f", number))[0]
    else:
        raw = 0x8000_0000 if value is None else int(value) & 0xFFFF_FFFF
    high, low = raw >> 16, raw & 0xFFFF
    return (high, low) if order is WordOrder.BIG else (low, high)


def from_registers(words: Sequence[int], kind: str, order: WordOrder) -> float | int:
    """The value of two registers (see `to_registers`); "int" reads signed 32 bits,
    "uint" unsigned."""
    first, second = words[0] & 0xFFFF, words[1] & 0xFFFF
    high, low = (first, second) if order is WordOrder.BIG else (second, first)
    raw = high << 16 | low
    if kind == "float":
        value: float = struct.unpack(">f", struct.pack(">I", raw))[0]
        return value
    if kind == "uint":
        return raw
    return raw - (1 << 32) if raw & 0x8000_0000 else raw


INPUT_SIZE = 100 + 2 * 50
HOLDING_SIZE = 211
MAX_PROCESS_POINTS = 4
MAX_PARAMETERS = 50
PROCESS_BASE = 24
COUNTERS_BASE = 40
PARAM_BASE = 100
MAILBOX = 200

COMMAND_CODES = {1: "on", 2: "off1", 3: "off2", 4: "off3", 5: "acknowledge"}
"""Holding register 1."""


class MailboxFormat(enum.IntEnum):
    """How the mailbox's value registers (203..204, 209..210) carry a parameter's value."""

    AUTO = 0
    """The value in the parameter's unit: a 32-bit integer for integer parameters, a float
    for float and scaled ones."""
    UINT16 = 1
    """The drive's word as it is on the line (no scaling), unsigned, in the low register."""
    INT16 = 2
    """The drive's word, signed."""
    UINT32 = 3
    """The drive's double word (a float parameter's IEEE 754 bits), unsigned."""
    INT32 = 4
    """The drive's double word, signed."""
    FLOAT = 5
    """The value in the parameter's unit as a float."""
    TIMES_10 = 6
    """The value in the parameter's unit times 10, a signed 32-bit integer."""
    TIMES_100 = 7
    """Times 100."""
    TIMES_1000 = 8
    """Times 1000."""


_SCALED = {MailboxFormat.TIMES_10: 10, MailboxFormat.TIMES_100: 100, MailboxFormat.TIMES_1000: 1000}


class MailboxStatus(enum.IntEnum):
    IDLE = 0
    DONE = 1
    REFUSED = 2
    FAILED = 3
    DIFFERS = 4
    """A write the drive answered with another value (it limits or rounds): the result
    registers hold what it holds."""


def param_kind(meta: ParamMeta) -> str:
    """How a parameter sits in two registers: "float" or "int"."""
    return "int" if meta.is_integer else "float"


@dataclass(frozen=True, slots=True)
class MailboxJob:
    """A checked mailbox job: read (command 1) or write ``value`` (in the parameter's unit;
    command 3 also to EEPROM)."""

    command: int
    meta: ParamMeta
    fmt: MailboxFormat
    value: float | int | None


@dataclass(frozen=True, slots=True)
class WritePlan:
    """What a checked write request does, in the order `DriveRegisters.carry_out` does it."""

    control: int | None = None
    pzd: Mapping[int, int] = field(default_factory=dict)
    """Raw PZD words by number (2..16), sent with the control word in one telegram."""
    parameters: tuple[tuple[ParamMeta, float | int], ...] = ()
    """Configured parameters to write, values in their units."""
    mailbox: tuple[int, int, int, tuple[int, int]] | None = None
    """The mailbox's PNU, index, format and value registers after the request."""
    job: MailboxJob | None = None
    command: str | None = None
    """A `COMMAND_CODES` name."""


@dataclass(slots=True)
class _Mailbox:
    pnu: int = 0
    index: int = 0xFFFF
    fmt: int = 0
    value: tuple[int, int] = (0, 0)
    status: MailboxStatus = MailboxStatus.IDLE
    response: int = 0
    error: int = 0
    result: tuple[int, int] = (0, 0)


def _bits(state: DriveState) -> int:
    """Input register 2 (see the module docstring)."""
    bits = 0
    if not state.online:
        bits |= 1
    if not state.answered:
        bits |= 2
    if state.fault:
        bits |= 4
    if state.warning:
        bits |= 8
    if state.reference is not None or state.model.unit == "%":
        bits |= 16
    if state.stale:
        bits |= 32
    if not state.bus_online:
        bits |= 64
    return bits


class DriveRegisters:
    """The registers of one drive (see the module docstring). ``read_only``: every write
    that would reach the drive is refused with exception 01."""

    def __init__(
        self,
        drive: DrivePoints,
        *,
        word_order: WordOrder = WordOrder.BIG,
        read_only: bool = False,
    ) -> None:
        self.drive = drive
        self.word_order = word_order
        self.read_only = read_only
        self.mailbox = _Mailbox()
        model = drive.model
        if len(model.parameters) > MAX_PARAMETERS:
            raise ConfigError(
                f"{model.key}: the Modbus map holds {MAX_PARAMETERS} parameters, "
                f"not {len(model.parameters)}"
            )
        for kind, items in (("actual", model.actual), ("setpoints", model.setpoints)):
            if len(items) > MAX_PROCESS_POINTS:
                raise ConfigError(
                    f"{model.key}: the Modbus map holds {MAX_PROCESS_POINTS} {kind} values"
                )

    # -- reading -----------------------------------------------------------------------------
    def _pair(self, value: float | int | None, kind: str) -> tuple[int, int]:
        return to_registers(value, kind, self.word_order)

    def _put_process(
        self,
        regs: list[int],
        items: Sequence[ProcessConfig],
        values: Mapping[str, ProcessValue],
    ) -> None:
        """Each process value as a float pair and its percent as another, from `PROCESS_BASE`."""
        for k, item in enumerate(items):
            value = values.get(item.key)
            base = PROCESS_BASE + 4 * k
            regs[base : base + 2] = self._pair(None if value is None else value.value, "float")
            regs[base + 2 : base + 4] = self._pair(
                None if value is None else value.percent, "float"
            )

    def _put_parameters(self, regs: list[int], state: DriveState) -> None:
        """Each configured parameter as last read, a register pair each from `PARAM_BASE`."""
        for k, point in enumerate(state.model.parameters):
            reading = state.parameters.get(point.key)
            base = PARAM_BASE + 2 * k
            regs[base : base + 2] = self._pair(
                None if reading is None else reading.value, param_kind(point.meta)
            )

    def input_image(self) -> list[int]:
        """Every input register, as the drive's state is now."""
        state = self.drive.snapshot()
        regs = [0] * INPUT_SIZE
        regs[0] = state.status_word or 0
        regs[1] = state.state_code
        regs[2] = _bits(state)
        regs[3] = int(state.health.counters.error_status) & 0xFFFF
        regs[4] = (state.health.last_fault or 0) & 0xFFFF
        refusal = state.health.last_refusal
        if refusal is not None:
            regs[5] = 8 if refusal.get("response_id") == 8 else 7
            regs[6] = int(refusal.get("number", 0)) & 0xFFFF
            regs[7] = int(refusal.get("pnu", 0)) & 0xFFFF
        for i, word in enumerate(state.actual_words[:15]):
            regs[8 + i] = word & 0xFFFF
        self._put_process(regs, state.model.actual, state.actual)
        for i, word in enumerate(state.health.counters.words()):
            regs[COUNTERS_BASE + i] = word
        regs[56:58] = self._pair(state.health.answers & 0xFFFF_FFFF, "int")
        regs[58:60] = self._pair(state.health.timeouts & 0xFFFF_FFFF, "int")
        self._put_parameters(regs, state)
        return regs

    def read_input(self, address: int, count: int) -> list[int]:
        self._check_range(address, count, INPUT_SIZE)
        return self.input_image()[address : address + count]

    def holding_image(self) -> list[int]:
        state = self.drive.snapshot()
        regs = [0] * HOLDING_SIZE
        regs[0] = state.control_word & 0xFFFF
        for i, word in enumerate(state.setpoint_words[:15]):
            regs[2 + i] = word & 0xFFFF
        self._put_process(regs, state.model.setpoints, state.setpoints)
        self._put_parameters(regs, state)
        box = self.mailbox
        regs[MAILBOX : MAILBOX + 11] = [
            box.pnu,
            box.index,
            box.fmt,
            *box.value,
            0,
            int(box.status),
            box.response,
            box.error,
            *box.result,
        ]
        return regs

    def plan_read(self, address: int, count: int) -> tuple[ParamMeta, ...]:
        """The configured parameters a read of holding registers ``address`` .. ``address +
        count - 1`` reads from the drive first (those not polled; pure), or `RegisterError`
        02 for registers outside the map."""
        self._check_range(address, count, HOLDING_SIZE)
        return tuple(
            point.meta
            for k, point in enumerate(self.drive.model.parameters)
            if point.poll is None
            and address < PARAM_BASE + 2 * k + 2
            and PARAM_BASE + 2 * k < address + count
        )

    async def read_holding(self, address: int, count: int) -> list[int]:
        """Holding registers; configured parameters that are not polled are read from the
        drive first (one job each, `plan_read`)."""
        for meta in self.plan_read(address, count):
            await self._guard(self.drive.read_parameter(meta.pnu, meta.index))
        return self.holding_image()[address : address + count]

    @staticmethod
    def _check_range(address: int, count: int, size: int) -> None:
        if count < 1 or address < 0 or address + count > size:
            raise RegisterError(
                ModbusException.ILLEGAL_DATA_ADDRESS,
                f"registers {address}..{address + count - 1} are outside the map (0..{size - 1})",
            )

    # -- writing: a request becomes a checked plan; only a whole plan is carried out ---------
    async def _guard(self, operation: object) -> object:
        """Await ``operation``; failures become `RegisterError` with the class's code."""
        try:
            return await operation  # type: ignore[misc]
        except RegisterError:
            raise
        except (UssError, ValueError) as exc:
            raise RegisterError(EXCEPTIONS[classify(exc)], str(exc)) from exc

    def _writable(self) -> frozenset[int]:
        model = self.drive.model
        writable = {0, 1, *range(2, 2 + max(model.layout.pzd - 1, 0))}
        for k in range(len(model.setpoints)):
            writable.update(range(PROCESS_BASE + 4 * k, PROCESS_BASE + 4 * k + 4))
        for k in range(len(model.parameters)):
            writable.update((PARAM_BASE + 2 * k, PARAM_BASE + 2 * k + 1))
        writable.update(range(MAILBOX, MAILBOX + 6))
        return frozenset(writable)

    def plan_write(self, address: int, values: Sequence[int]) -> WritePlan:
        """The checked plan of writing ``values`` from ``address`` on, or `RegisterError`.

        Pure: nothing is sent and nothing of the face changes; the drive's state is only read
        (its reference, for setpoints in the unit). Every part of the request is checked
        here: addresses, read-only, both halves of 32-bit values, setpoints against 16/32 bits,
        parameter values against the parameter's type and limits, the command, the mailbox's
        command, format, parameter and value."""
        self._check_range(address, len(values), HOLDING_SIZE)
        words = {address + i: v & 0xFFFF for i, v in enumerate(values)}
        writable = self._writable()
        for reg in words:
            if reg not in writable:
                raise RegisterError(
                    ModbusException.ILLEGAL_DATA_ADDRESS,
                    f"register {reg} cannot be written (see the register map)",
                )
        job_command = words.get(MAILBOX + 5, 0)
        mailbox_read = all(MAILBOX <= reg < MAILBOX + 6 for reg in words) and job_command in (0, 1)
        if self.read_only and not mailbox_read:
            raise RegisterError(ModbusException.ILLEGAL_FUNCTION, "this Modbus face is read-only")
        model = self.drive.model
        # process data: raw PZD words, setpoints as floats, the control word: one telegram
        pzd = {reg: words[reg] for reg in range(2, 17) if reg in words}
        for k, item in enumerate(model.setpoints):
            base = PROCESS_BASE + 4 * k
            for offset, unit in ((0, "value"), (2, "percent")):
                pair = _whole(words, base + offset, f"setpoint {item.key}")
                if pair is None:
                    continue
                number = from_registers(pair, "float", self.word_order)
                try:
                    raw = self.drive.setpoint_raw(number, item.key, unit=unit)
                except ConfigError as exc:
                    raise RegisterError(ModbusException.ILLEGAL_DATA_VALUE, str(exc)) from exc
                if item.dword:
                    pzd[item.pzd] = raw >> 16 & 0xFFFF
                    pzd[item.pzd + 1] = raw & 0xFFFF
                else:
                    pzd[item.pzd] = raw & 0xFFFF
        parameters: list[tuple[ParamMeta, float | int]] = []
        for k, point in enumerate(model.parameters):
            pair = _whole(words, PARAM_BASE + 2 * k, point.key)
            if pair is not None:
                value = from_registers(pair, param_kind(point.meta), self.word_order)
                parameters.append((point.meta, _checked_value(point.meta, value)))
        command = None
        if 1 in words:
            command = COMMAND_CODES.get(words[1])
            if command is None:
                raise RegisterError(
                    ModbusException.ILLEGAL_DATA_VALUE,
                    f"command {words[1]} is not 1..5 (ON, OFF1, OFF2, OFF3, acknowledge)",
                )
        try:  # a command or control word that would take a running drive over: refused whole
            self.drive.check_takeover(command=command, control=words.get(0), words=list(pzd))
        except NotInControl as exc:
            raise RegisterError(EXCEPTIONS[classify(exc)], str(exc)) from exc
        mailbox, job = self._plan_mailbox(words)
        return WritePlan(
            control=words.get(0),
            pzd=pzd,
            parameters=tuple(parameters),
            mailbox=mailbox,
            job=job,
            command=command,
        )

    def _plan_mailbox(
        self, words: Mapping[int, int]
    ) -> tuple[tuple[int, int, int, tuple[int, int]] | None, MailboxJob | None]:
        """The mailbox's registers 200..204 after the request, and its job (if 205 asks for
        one), checked."""
        if not any(MAILBOX <= reg < MAILBOX + 6 for reg in words):
            return None, None
        box = self.mailbox
        pnu = words.get(MAILBOX, box.pnu)
        index = words.get(MAILBOX + 1, box.index)
        fmt_code = words.get(MAILBOX + 2, box.fmt)
        pair = _whole(words, MAILBOX + 3, "the mailbox value") or box.value
        registers = (pnu, index, fmt_code, pair)
        command = words.get(MAILBOX + 5, 0)
        if command == 0:
            return registers, None
        if command not in (1, 2, 3):
            raise RegisterError(
                ModbusException.ILLEGAL_DATA_VALUE,
                f"mailbox command {command} is not 1 (read), 2 (write) or 3 (write, EEPROM)",
            )
        try:
            fmt = MailboxFormat(fmt_code)
        except ValueError:
            known = ", ".join(str(int(f)) for f in MailboxFormat)
            raise RegisterError(
                ModbusException.ILLEGAL_DATA_VALUE,
                f"mailbox format {fmt_code} is not one of {known}",
            ) from None
        param_index = None if index == 0xFFFF else index
        try:
            meta = self.drive.meta(pnu, param_index)
        except ConfigError as exc:
            raise RegisterError(EXCEPTIONS[classify(exc)], str(exc)) from exc
        if fmt in (MailboxFormat.UINT16, MailboxFormat.INT16) and (meta.is_float or meta.dword):
            raise RegisterError(
                ModbusException.ILLEGAL_DATA_VALUE,
                f"{meta.key} is a double word: use mailbox format 3 or 4 for its raw value",
            )
        value = None
        if command != 1:
            value = _checked_value(meta, self._mailbox_value(pair, fmt, meta))
        return registers, MailboxJob(command, meta, fmt, value)

    async def carry_out(self, plan: WritePlan) -> None:
        """Carry out a checked plan; returns when the drive answered. The parts go in this
        order: the mailbox's registers, process data (one telegram), parameter jobs, the
        mailbox's job, the command. A part the drive refuses or does not answer stops the
        parts after it (`RegisterError`)."""
        if plan.mailbox is not None:
            box = self.mailbox
            box.pnu, box.index, box.fmt, box.value = plan.mailbox
        if plan.control is not None or plan.pzd:
            await self._guard(self.drive.set_process(control=plan.control, words=plan.pzd))
        for meta, value in plan.parameters:
            await self._guard(self.drive.write_parameter(meta.pnu, value, meta.index))
        if plan.job is not None:
            await self._run_job(plan.job)
        if plan.command is not None:
            await self._guard(self.drive.command(plan.command))

    async def write_holding(self, address: int, values: Sequence[int]) -> None:
        """Write ``values`` from ``address`` on: `plan_write`, then `carry_out`. A request
        refused by the check sends nothing and changes nothing."""
        await self.carry_out(self.plan_write(address, values))

    async def _run_job(self, job: MailboxJob) -> None:
        box = self.mailbox
        meta = job.meta
        box.status, box.response, box.error = MailboxStatus.IDLE, 0, 0
        try:
            if job.value is None:
                reading = await self.drive.read_parameter(meta.pnu, meta.index)
            else:
                reading = await self.drive.write_parameter(
                    meta.pnu, job.value, meta.index, eeprom=job.command == 3
                )
        except (DriveRefusal, NoWriteAuthority) as exc:
            box.status = MailboxStatus.REFUSED
            box.response = 8 if isinstance(exc, NoWriteAuthority) else 7
            box.error = exc.number & 0xFFFF if isinstance(exc, DriveRefusal) else 0
            box.result = (0, 0)
            raise RegisterError(EXCEPTIONS[classify(exc)], str(exc)) from exc
        except (UssError, ValueError) as exc:
            box.status = MailboxStatus.FAILED
            box.result = (0, 0)
            raise RegisterError(EXCEPTIONS[classify(exc)], str(exc)) from exc
        box.status = MailboxStatus.DONE if reading.written is None else MailboxStatus.DIFFERS
        box.result = self._mailbox_result(reading.value, job.fmt, meta)

    def _mailbox_value(
        self, pair: tuple[int, int], fmt: MailboxFormat, meta: ParamMeta
    ) -> float | int:
        """The value in the parameter's unit that registers 203..204 carry in ``fmt``."""
        if fmt is MailboxFormat.AUTO:
            fmt = MailboxFormat.INT32 if meta.is_integer else MailboxFormat.FLOAT
            if fmt is MailboxFormat.INT32:
                return from_registers(pair, "int", self.word_order)
        if fmt is MailboxFormat.FLOAT:
            return from_registers(pair, "float", self.word_order)
        if fmt in _SCALED:
            return from_registers(pair, "int", self.word_order) / _SCALED[fmt]
        raw = int(from_registers(pair, "uint", self.word_order))
        if fmt in (MailboxFormat.UINT16, MailboxFormat.INT16):
            raw &= 0xFFFF
            if fmt is MailboxFormat.INT16 and raw & 0x8000:
                raw -= 0x10000
        elif fmt is MailboxFormat.INT32 and raw & 0x8000_0000:
            raw -= 1 << 32
        if meta.is_float:
            value: float = struct.unpack(">f", struct.pack(">I", raw & 0xFFFF_FFFF))[0]
            return value
        return meta.physical(raw)

    def _mailbox_result(
        self, value: float | int | None, fmt: MailboxFormat, meta: ParamMeta
    ) -> tuple[int, int]:
        """Registers 209..210: ``value`` (in the parameter's unit) in ``fmt``."""
        if fmt is MailboxFormat.AUTO:
            fmt = MailboxFormat.INT32 if meta.is_integer else MailboxFormat.FLOAT
            if fmt is MailboxFormat.INT32:
                return self._pair(None if value is None else round(value), "int")
        if fmt is MailboxFormat.FLOAT:
            return self._pair(value, "float")
        if value is None:
            return self._pair(None, "int")
        if fmt in _SCALED:
            return self._pair(round(value * _SCALED[fmt]), "int")
        if meta.is_float:
            return self._pair(struct.unpack(">I", struct.pack(">f", value))[0], "int")
        raw = round(value / meta.scaling) if meta.scaling is not None else round(value)
        if fmt in (MailboxFormat.UINT16, MailboxFormat.UINT32):
            raw &= 0xFFFF if fmt is MailboxFormat.UINT16 else 0xFFFF_FFFF
        return self._pair(raw, "int")


def _whole(words: Mapping[int, int], base: int, what: str) -> tuple[int, int] | None:
    """The two registers of a 32-bit value at ``base`` if the request writes them, None if it
    writes neither; a request writing one of them is refused (03)."""
    inside = [a in words for a in (base, base + 1)]
    if not any(inside):
        return None
    if not all(inside):
        raise RegisterError(
            ModbusException.ILLEGAL_DATA_VALUE,
            f"{what} at {base}..{base + 1} is 32 bits: write both registers at once",
        )
    return words[base], words[base + 1]


def _checked_value(meta: ParamMeta, value: float | int) -> float | int:
    """``value`` if P``meta`` may be written with it (writable, a number of its type, within
    its limits), else `RegisterError` 03: the check the write would make, made before
    anything of the request is sent."""
    if not meta.writable:
        raise RegisterError(
            ModbusException.ILLEGAL_DATA_VALUE, f"{meta.key} ({meta.name}) is read-only"
        )
    try:
        meta.raw(value)
    except ConfigError as exc:
        raise RegisterError(ModbusException.ILLEGAL_DATA_VALUE, str(exc)) from exc
    return value
