"""The KS VARIO parameter channel (module A.1, 8 bytes each way), both sides (KS VARIO interface
description 4).

A job is a start telegram, one data telegram per value and an end telegram (4.2). Everything
travels in the cyclic process image, so both sides act on a *change* of the 8 bytes they see:

* master -> coupler start (4.2): ``10 ID1 Rd.Cnt Adr.High Adr.Low 00 Cnt.Real Cnt.Int``;
  a write when Cnt.Real or Cnt.Int is not 0, else a read (which needs Rd.Cnt != 0);
* coupler -> master start answer: ``10`` and, for a read, the counts it will deliver in bytes
  6 and 7 (4.4). Bytes 1..5 of the answer are not specified ("xx" in the vectors); this
  coupler echoes the request's bytes 1..5 there;
* data (4.3, 4.4): ``68 Count 00 00 Value`` with Count = 1..n; the side that does not carry the
  value echoes Count for flow control;
* end: master ``16``, coupler ``16 00 Result``. The interface description puts Result in byte 2 in
  one table and
  in "bytes 2-3" in another; this coupler writes byte 2 (byte 3 = 0) and the master side reads
  whichever of bytes 2 and 3 is not 0, so both readings interoperate.

Value placement in bytes 4..7 (4.2 a-d): REAL (ID1 1 or 3) a 4-byte IEEE 754 float in bytes
4..7; INTEGER (0) 2 bytes in bytes 6..7; CHAR (2) one byte in byte 5 (where the flattened table
puts it); COMPACT CHAR (4) four characters in bytes 4..7, unused places 00h. Real and integer
values follow the byte order of the user parameters (Motorola = big-endian, the default, or
Intel = little-endian, interface description 6); characters are never swapped.

Counts in compact-char format count groups of four characters (one data telegram each); a group
covers four consecutive data. Results (4.2): 0 OK, 2 bad address, 3 invalid value, 4 buffer
overflow.

The master side (`ChannelClient`) also keeps the display word ANZW of the S7 function blocks
FB106/FB107 (KS VARIO interface description 8.1, 7.1.1) as `DisplayWord`: bit 0 running, 1 done
without error,
2 done with error, 3 waiting for acknowledgement, 4 reset, 5 service (0 read, 1 write),
6 waiting for the end telegram, bits 8..10 the result, 14 wrong service, 15 timeout.
"""

from __future__ import annotations

import enum
import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

from pyuss.errors import ConfigError, ProtocolError
from pyuss.ksvario.address import Address, View

#: Size of the parameter channel in each direction (module A.1).
CHANNEL_BYTES = 8
#: Counts are single bytes (Rd.Cnt, Cnt.Real, Cnt.Int, Count).
MAX_COUNT = 255


class TelegramId(enum.IntEnum):
    """Byte 0 of every parameter-channel telegram (4.1)."""

    START = 0x10
    DATA = 0x68
    END = 0x16


class DataFormat(enum.IntEnum):
    """ID1: the data format of a job (4.1)."""

    INTEGER = 0
    REAL = 1
    CHAR = 2
    REAL3 = 3
    COMPACT_CHAR = 4

    @property
    def is_real(self) -> bool:
        return self in (DataFormat.REAL, DataFormat.REAL3)


class Result(enum.IntEnum):
    """Result of the end telegram (4.2)."""

    OK = 0
    BAD_ADDRESS = 2
    INVALID_VALUE = 3
    BUFFER_OVERFLOW = 4

    @property
    def meaning(self) -> str:
        return _RESULT_TEXT[self]


_RESULT_TEXT = {
    Result.OK: "OK",
    Result.BAD_ADDRESS: "bad address",
    Result.INVALID_VALUE: "invalid value",
    Result.BUFFER_OVERFLOW: "buffer overflow",
}


def result_meaning(number: int) -> str:
    """The meaning of a result number, also for numbers the interface description does not list."""
    try:
        return Result(number).meaning
    except ValueError:
        return f"unknown result {number}"


class ByteOrder(enum.IntEnum):
    """Byte order of real and integer values (user parameter byte 4 bit 0, interface description
    6)."""

    MOTOROLA = 0
    INTEL = 1


#: A value as the channel carries it: int (integer, char), float (real), bytes (4 compact chars).
Value = int | float | bytes


def target_view(fmt: DataFormat, address: Address) -> Address:
    """The address a job really works on (4.1): integer and char formats turn a float address
    into the integer view (char formats also a FixPoint1 one), real formats turn any other
    address into the float view."""
    if fmt.is_real:
        return address.as_view(View.FLOAT)
    if fmt is DataFormat.INTEGER:
        return address.as_view(View.INTEGER) if address.view is View.FLOAT else address
    return address.as_view(View.INTEGER)


def encode_value(fmt: DataFormat, value: Value, order: ByteOrder) -> bytes:
    """The 4 value bytes (bytes 4..7 of a data telegram) for ``value`` in ``fmt``."""
    little = order is ByteOrder.INTEL
    if fmt.is_real:
        if isinstance(value, bytes) or not isinstance(value, int | float):
            raise ConfigError(f"a real value must be a number, not {value!r}")
        try:
            return struct.pack("<f" if little else ">f", float(value))
        except OverflowError:
            raise ConfigError(f"{value!r} does not fit a 32-bit float") from None
    if fmt is DataFormat.INTEGER:
        if not isinstance(value, int) or isinstance(value, bool):
            raise ConfigError(f"an integer value must be an int, not {value!r}")
        if not -0x8000 <= value <= 0xFFFF:
            raise ConfigError(f"integer {value} does not fit 16 bits")
        return b"\x00\x00" + (value & 0xFFFF).to_bytes(2, "little" if little else "big")
    if fmt is DataFormat.CHAR:
        code = _char_code(value)
        return bytes((0, code, 0, 0))
    if isinstance(value, str):
        value = value.encode("latin-1")
    if not isinstance(value, bytes) or len(value) > 4:
        raise ConfigError(f"a compact-char value is up to 4 bytes, not {value!r}")
    return value.ljust(4, b"\x00")


def _char_code(value: Value | str) -> int:
    if isinstance(value, str):
        value = value.encode("latin-1")
    if isinstance(value, bytes):
        if len(value) != 1:
            raise ConfigError(f"a char value is one character, not {value!r}")
        return value[0]
    if isinstance(value, int) and 0 <= value <= 0xFF:
        return value
    raise ConfigError(f"a char value is a code 0..255, not {value!r}")


def decode_value(fmt: DataFormat, field4: bytes, order: ByteOrder) -> Value:
    """The value carried in the 4 value bytes of a data telegram."""
    if len(field4) != 4:
        raise ProtocolError(f"value field must be 4 bytes, got {len(field4)}")
    little = order is ByteOrder.INTEL
    if fmt.is_real:
        number: float = struct.unpack("<f" if little else ">f", field4)[0]
        return number
    if fmt is DataFormat.INTEGER:
        word = int.from_bytes(field4[2:4], "little" if little else "big")
        return word - 0x10000 if word & 0x8000 else word
    if fmt is DataFormat.CHAR:
        return field4[1]
    return bytes(field4)


# --------------------------------------------------------------------------- telegrams


@dataclass(frozen=True, slots=True)
class StartRequest:
    """The master's start telegram (4.2)."""

    fmt: DataFormat
    address: int
    read_count: int = 0
    write_real: int = 0
    write_int: int = 0

    @property
    def is_write(self) -> bool:
        return self.write_real != 0 or self.write_int != 0

    @property
    def write_count(self) -> int:
        return self.write_real or self.write_int

    def encode(self) -> bytes:
        for name in ("read_count", "write_real", "write_int"):
            if not 0 <= getattr(self, name) <= MAX_COUNT:
                raise ConfigError(f"{name} must be 0..{MAX_COUNT}")
        return bytes(
            (
                TelegramId.START,
                self.fmt,
                self.read_count,
                self.address >> 8,
                self.address & 0xFF,
                0,
                self.write_real,
                self.write_int,
            )
        )

    @classmethod
    def decode(cls, data: bytes) -> StartRequest:
        _check(data, TelegramId.START)
        try:
            fmt = DataFormat(data[1])
        except ValueError:
            raise ProtocolError(f"unknown data format ID1={data[1]}") from None
        return cls(fmt, (data[3] << 8) | data[4], data[2], data[6], data[7])


def _check(data: bytes, ident: TelegramId) -> None:
    if len(data) != CHANNEL_BYTES:
        raise ProtocolError(f"parameter channel telegram must be 8 bytes, got {len(data)}")
    if data[0] != ident:
        raise ProtocolError(f"expected {ident.name} telegram ({ident:02X}h), got {data[0]:02X}h")


def data_telegram(count: int, value_field: bytes = b"\x00\x00\x00\x00") -> bytes:
    """``68 Count 00 00 v v v v``."""
    if not 0 <= count <= MAX_COUNT:
        raise ConfigError(f"count must be 0..{MAX_COUNT}")
    return bytes((TelegramId.DATA, count, 0, 0)) + value_field


def end_request() -> bytes:
    return bytes((TelegramId.END,)) + bytes(7)


def end_response(result: int) -> bytes:
    return bytes((TelegramId.END, 0, result, 0, 0, 0, 0, 0))


def end_result(data: bytes) -> int:
    """The result of a coupler's end telegram: byte 2, or byte 3 (see module docstring)."""
    _check(data, TelegramId.END)
    return data[2] or data[3]


# --------------------------------------------------------------------------- coupler side


class DataAccess(Protocol):
    """What the coupler side needs from the device: read and write runs of data."""

    def read_values(self, address: Address, fmt: DataFormat, count: int) -> list[Value] | Result:
        """``count`` values from ``address`` on (already in the job's view), or a result."""
        ...

    def write_values(self, address: Address, fmt: DataFormat, values: Sequence[Value]) -> Result:
        """Write ``values`` from ``address`` on; all or nothing."""
        ...


class _Phase(enum.Enum):
    IDLE = "idle"
    READ = "read"
    WRITE = "write"
    ENDED = "ended"


class ChannelServer:
    """The bus coupler's side of the parameter channel.

    Call `exchange` with each 8-byte request image the master sends (every bus cycle); it
    returns the 8-byte response image. Only a changed request image is acted on, so the same
    telegram seen in many cycles is one telegram. A job that sees no new telegram for
    ``timeout`` seconds is dropped. ``max_block`` is the coupler's buffer: longer jobs end
    with result 4 (buffer overflow).
    """

    def __init__(
        self,
        access: DataAccess,
        *,
        byte_order: ByteOrder = ByteOrder.MOTOROLA,
        max_block: int = 128,
        timeout: float = 10.0,
    ) -> None:
        self.access = access
        self.byte_order = byte_order
        self.max_block = max_block
        self.timeout = timeout
        self._last_request = bytes(CHANNEL_BYTES)
        self._response = bytes(CHANNEL_BYTES)
        self._phase = _Phase.IDLE
        self._fmt = DataFormat.INTEGER
        self._address: Address | None = None
        self._values: list[Value] = []
        self._received: dict[int, Value] = {}
        self._expected = 0
        self._result = Result.OK
        self._last_change = 0.0

    @property
    def response(self) -> bytes:
        return self._response

    @property
    def busy(self) -> bool:
        return self._phase in (_Phase.READ, _Phase.WRITE)

    def reset(self) -> None:
        """Forget the current job (bus failure, new parameterisation)."""
        self._phase = _Phase.IDLE
        self._last_request = bytes(CHANNEL_BYTES)
        self._response = bytes(CHANNEL_BYTES)

    def exchange(self, request: bytes, now: float) -> bytes:
        """Process one request image; return the response image."""
        if len(request) != CHANNEL_BYTES:
            raise ProtocolError(f"parameter channel image must be 8 bytes, got {len(request)}")
        request = bytes(request)
        if self.busy and now - self._last_change > self.timeout:
            self._phase = _Phase.IDLE
        if request == self._last_request:
            return self._response
        self._last_request = request
        self._last_change = now
        ident = request[0]
        if ident == TelegramId.START:
            self._start(request)
        elif ident == TelegramId.DATA:
            self._data(request)
        elif ident == TelegramId.END:
            self._end()
        # any other byte 0 (e.g. 00 while idle) is not a telegram: the image stays
        return self._response

    def _start(self, request: bytes) -> None:
        self._values = []
        self._received = {}
        self._result = Result.OK
        counts = (0, 0)
        try:
            start = StartRequest.decode(request)
        except ProtocolError:
            self._phase = _Phase.ENDED
            self._result = Result.INVALID_VALUE
            self._response = bytes((TelegramId.START, *request[1:6], 0, 0))
            return
        self._fmt = start.fmt
        try:
            self._address = target_view(start.fmt, Address.decode(start.address))
        except ConfigError:
            self._address = None
        if start.write_real and start.write_int:
            self._fail(Result.INVALID_VALUE)
        elif start.is_write:
            wrong_kind = (start.write_real != 0) != start.fmt.is_real
            if self._accepted(wrong_kind or start.read_count != 0, start.write_count) is not None:
                self._phase = _Phase.WRITE
                self._expected = start.write_count
        elif (address := self._accepted(start.read_count == 0, start.read_count)) is not None:
            got = self.access.read_values(address, start.fmt, start.read_count)
            if isinstance(got, Result):
                self._fail(got)
            else:
                self._values = list(got)
                self._phase = _Phase.READ
                n = len(self._values)
                counts = (n, 0) if start.fmt.is_real else (0, n)
        if start.is_write:
            self._response = bytes((TelegramId.START, *request[1:8]))
        else:
            self._response = bytes((TelegramId.START, *request[1:6], *counts))

    def _fail(self, result: Result) -> None:
        self._phase = _Phase.ENDED
        self._result = result

    def _accepted(self, invalid: bool, count: int) -> Address | None:
        """The address of a job that may go on; None where it is refused (and ended with its
        result): a start telegram that is ``invalid``, a ``count`` of values more than a block
        holds, or no valid address."""
        if invalid:
            self._fail(Result.INVALID_VALUE)
        elif count > self.max_block:
            self._fail(Result.BUFFER_OVERFLOW)
        elif self._address is None:
            self._fail(Result.BAD_ADDRESS)
        else:
            return self._address
        return None

    def _data(self, request: bytes) -> None:
        count = request[1]
        if self._phase is _Phase.READ:
            if 1 <= count <= len(self._values):
                value = encode_value(self._fmt, self._values[count - 1], self.byte_order)
                self._response = data_telegram(count, value)
            else:
                self._result = Result.BUFFER_OVERFLOW
                self._response = data_telegram(count)
        elif self._phase is _Phase.WRITE:
            if 1 <= count <= self._expected:
                try:
                    self._received[count] = decode_value(self._fmt, request[4:8], self.byte_order)
                except ProtocolError:
                    self._result = Result.INVALID_VALUE
            else:
                self._result = Result.BUFFER_OVERFLOW
            self._response = data_telegram(count)
        else:
            self._response = data_telegram(count)

    def _end(self) -> None:
        result = self._result
        if self._phase is _Phase.WRITE and result is Result.OK:
            if len(self._received) != self._expected:
                result = Result.INVALID_VALUE
            else:
                assert self._address is not None
                values = [self._received[i] for i in range(1, self._expected + 1)]
                result = self.access.write_values(self._address, self._fmt, values)
        if self._phase is _Phase.IDLE:
            result = Result.INVALID_VALUE
        self._phase = _Phase.IDLE
        self._response = end_response(result)


# --------------------------------------------------------------------------- master side


class DisplayWord(enum.IntFlag):
    """ANZW, the display word of the S7 blocks FB106/FB107 (KS VARIO interface description 8.1);
    the result lives
    in bits 8..10 (`RESULT_SHIFT`)."""

    NONE = 0
    RUNNING = 1 << 0
    DONE_OK = 1 << 1
    DONE_ERROR = 1 << 2
    WAIT_ACK = 1 << 3
    RESET = 1 << 4
    WRITE = 1 << 5
    WAIT_END = 1 << 6
    WRONG_SERVICE = 1 << 14
    TIMEOUT = 1 << 15


RESULT_SHIFT = 8
RESULT_MASK = 0x7 << RESULT_SHIFT


@dataclass(frozen=True, slots=True)
class ChannelStatus:
    """The state of a master-side job as a user reads it: the ANZW word and its meaning."""

    word: int

    @property
    def flags(self) -> DisplayWord:
        return DisplayWord(self.word & ~RESULT_MASK)

    @property
    def result(self) -> int:
        return (self.word & RESULT_MASK) >> RESULT_SHIFT

    @property
    def running(self) -> bool:
        return bool(self.word & DisplayWord.RUNNING)

    @property
    def done(self) -> bool:
        return bool(self.word & (DisplayWord.DONE_OK | DisplayWord.DONE_ERROR))

    @property
    def ok(self) -> bool:
        return bool(self.word & DisplayWord.DONE_OK)

    def describe(self) -> str:
        names = [f.name.lower() for f in DisplayWord if f.name and f and f in self.flags]
        text = ", ".join(names) if names else "idle"
        if self.done:
            text += f"; result {self.result} ({result_meaning(self.result)})"
        return f"ANZW {self.word:04X}h: {text}"


@dataclass(slots=True)
class _Job:
    fmt: DataFormat
    address: int
    write: bool
    read_count: int = 0
    values: list[Value] = field(default_factory=list)


class _Step(enum.Enum):
    IDLE = "idle"
    START = "start"
    DATA = "data"
    END = "end"
    DONE = "done"


class ChannelClient:
    """The master's side of the parameter channel, pure: it produces the 8-byte request image
    for each cycle (`request`) and consumes the coupler's 8-byte response image (`feed`).

    Start a job with `start_read` / `start_write`; it is finished when `status.done`; then
    `values` holds what was read and `result` the coupler's result. ``timeout`` (seconds, on
    the ``now`` passed in) aborts a job with the TIMEOUT bit, as FB106 does.
    """

    def __init__(self, *, byte_order: ByteOrder = ByteOrder.MOTOROLA, timeout: float = 5.0) -> None:
        self.byte_order = byte_order
        self.timeout = timeout
        self._job: _Job | None = None
        self._step = _Step.IDLE
        self._request = bytes(CHANNEL_BYTES)
        self._index = 0
        self._available = 0
        self._values: list[Value] = []
        self._result: int | None = None
        self._word = 0
        self._deadline = 0.0

    # -- job set-up
    def start_read(self, fmt: DataFormat, address: int | Address, count: int, now: float) -> None:
        if not 1 <= count <= MAX_COUNT:
            raise ConfigError(f"read count must be 1..{MAX_COUNT}, got {count}")
        self._begin(_Job(self._service(fmt), int(address), False, read_count=count), now)

    def start_write(
        self, fmt: DataFormat, address: int | Address, values: Sequence[Value], now: float
    ) -> None:
        fmt = self._service(fmt)
        if not 1 <= len(values) <= MAX_COUNT:
            raise ConfigError(f"write 1..{MAX_COUNT} values, got {len(values)}")
        for value in values:
            encode_value(fmt, value, self.byte_order)  # validates
        self._begin(_Job(fmt, int(address), True, values=list(values)), now)

    def _service(self, fmt: DataFormat | int) -> DataFormat:
        """The data format of a new job. One the channel does not know (ID1 not 0..4) ends the
        job at once with ANZW bit 14 "service wrong" and done with error (8.1), and raises."""
        try:
            return DataFormat(fmt)
        except ValueError:
            if not self.busy:
                self._step = _Step.DONE
                self._job = None
                self._result = None
                self._word = int(DisplayWord.WRONG_SERVICE | DisplayWord.DONE_ERROR)
            raise ConfigError(f"data format {fmt!r} is not ID1 0..4: service wrong") from None

    def _begin(self, job: _Job, now: float) -> None:
        if not 0 <= job.address <= 0xFFFF:
            raise ConfigError(f"address {job.address} is not a 16-bit word")
        if self._step not in (_Step.IDLE, _Step.DONE):
            raise ConfigError("a parameter channel job is still running")
        self._job = job
        self._values = []
        self._result = None
        self._index = 0
        self._available = 0
        self._deadline = now + self.timeout
        n = len(job.values)
        if job.write:
            start = StartRequest(
                job.fmt, job.address, 0, n if job.fmt.is_real else 0, 0 if job.fmt.is_real else n
            )
        else:
            start = StartRequest(job.fmt, job.address, job.read_count)
        self._request = start.encode()
        self._step = _Step.START
        self._word = DisplayWord.RUNNING | DisplayWord.WAIT_ACK
        if job.write:
            self._word |= DisplayWord.WRITE

    def reset(self) -> None:
        """Abandon any job (ANZW bit 4): the next request image is an end telegram."""
        self._step = _Step.IDLE
        self._job = None
        self._request = end_request()
        self._word = int(DisplayWord.RESET)

    # -- cyclic interface
    def request(self) -> bytes:
        """The 8 bytes to put into the output image this cycle."""
        return self._request

    @property
    def status(self) -> ChannelStatus:
        return ChannelStatus(self._word)

    @property
    def values(self) -> list[Value]:
        return list(self._values)

    @property
    def result(self) -> int | None:
        return self._result

    @property
    def busy(self) -> bool:
        return self._step in (_Step.START, _Step.DATA, _Step.END)

    def feed(self, response: bytes, now: float) -> None:
        """Consume the coupler's response image of this cycle."""
        if len(response) != CHANNEL_BYTES:
            raise ProtocolError(f"parameter channel image must be 8 bytes, got {len(response)}")
        if not self.busy:
            return
        job = self._job
        assert job is not None
        if now > self._deadline:
            self._finish(None, timeout=True)
            return
        ident = response[0]
        if self._step is _Step.START and ident == TelegramId.START:
            if job.write:
                self._index = 1
                self._send_data()
            else:
                self._available = response[6] if job.fmt.is_real else response[7]
                self._available = min(self._available, job.read_count)
                if self._available == 0:
                    self._send_end()
                else:
                    self._index = 1
                    self._send_data()
        elif self._step is _Step.DATA and ident == TelegramId.DATA and response[1] == self._index:
            if not job.write:
                self._values.append(decode_value(job.fmt, response[4:8], self.byte_order))
            total = len(job.values) if job.write else self._available
            if self._index >= total:
                self._send_end()
            else:
                self._index += 1
                self._send_data()
        elif self._step is _Step.END and ident == TelegramId.END:
            self._finish(end_result(response))

    def _send_data(self) -> None:
        job = self._job
        assert job is not None
        self._step = _Step.DATA
        if job.write:
            value = encode_value(job.fmt, job.values[self._index - 1], self.byte_order)
            self._request = data_telegram(self._index, value)
        else:
            self._request = data_telegram(self._index)

    def _send_end(self) -> None:
        self._step = _Step.END
        self._request = end_request()
        self._word = (self._word & ~DisplayWord.WAIT_ACK) | DisplayWord.WAIT_END

    def _finish(self, result: int | None, *, timeout: bool = False) -> None:
        self._step = _Step.DONE
        job = self._job
        word = DisplayWord.WRITE if job is not None and job.write else DisplayWord.NONE
        if timeout:
            word |= DisplayWord.TIMEOUT | DisplayWord.DONE_ERROR
            self._request = end_request()
        elif result == 0:
            word |= DisplayWord.DONE_OK
        else:
            word |= DisplayWord.DONE_ERROR
        self._result = result
        self._word = int(word) | (((result or 0) & 0x7) << RESULT_SHIFT)

    def short_read(self) -> bool:
        """True when the coupler delivered fewer values than asked for."""
        job = self._job
        return job is not None and not job.write and self._available < job.read_count


def is_finite_real(value: Value) -> bool:
    return isinstance(value, float | int) and not isinstance(value, bool) and math.isfinite(value)
