"""Serial ports through pyserial: any URL `serial.serial_for_url` accepts (``/dev/ttyUSB0``,
``COM3``, ``rfc2217://host:port``, ``socket://host:port``, ``loop://``).

Character frame 8E1 by default (B 3.2: start bit, 8 data bits, even parity, stop bit). Reading
happens in a worker thread that blocks in the port's read and stamps each burst with the
line's clock (`pyuss.system.clock`) the moment it wakes up: the stamp does not depend on how
busy the event loop is (a loop reader would stamp when the loop gets round to it), and the
same code serves every pyserial backend, including those without a file descriptor (``loop://``, ``rfc2217://``).
Writes run in a second single worker thread, in order.

Line errors: on a POSIX serial device the terminal is switched to mark bad characters
(termios INPCK + PARMRK). The kernel then flags parity and framing errors alike, without saying
which, so a flagged character is reported as ``LineError.PARITY | LineError.FRAMING``; a break
reads as a flagged 0x00. Other backends cannot tell, and report no line errors.

RS-485 direction control for 2-wire adapters (B 2: half duplex, one sender at a time):

- ``RS485Mode.AUTO``: the adapter switches its driver itself (most USB adapters). Nothing to do.
- ``RS485Mode.KERNEL``: the kernel driver toggles RTS (TIOCSRS485 through pyserial's
  ``rs485_mode``); ports whose driver lacks it fail to open with a `TransportError`.
- ``RS485Mode.RTS``: pyuss raises RTS, writes, waits until the bytes have left the line and
  drops RTS. "Left the line" is the later of the port's drain and ``len(data)`` character times
  (A 6.1) after the write began, because many USB adapters report the drain early; then
  ``rts_delay_after`` more (default none: the next telegram waits a start pause of 2 character
  times anyway, A 5.1.2).

Pseudo-terminals (Linux): a pty keeps no parity. The kernel clears PARENB in every setting made
on one, and glibc's ``tcsetattr`` reads the settings back and fails with EINVAL when the parity
asked for was dropped and nothing else changed; pyserial's open then ends in that error. So a
program that opened the device at 8E1 or 8N1 before (9600 baud both times) kept a second 8E1
open from working. A pty's settings end the same whatever parity is asked for, so pyuss asks for
none on a pty (`is_pty`): its frame is the one a pty keeps anyway, and the open is never refused,
whatever another program left on the device. The line still carries 8 data bits; a pty has no
parity errors to report.

Latency of USB adapters: many drivers hold received bytes for a while before handing them on
(FTDI chips: a latency timer of 16 ms by default), which is most of a 20 ms response window
(A 5.2.1.1). Where the driver offers it, the port asks for low-latency mode on opening
(``ASYNC_LOW_LATENCY`` through ``TIOCGSERIAL``/``TIOCSSERIAL``, as ``setserial ... low_latency``
does; an FTDI driver then sets its timer to 1 ms) and puts the old setting back on closing.
Drivers without it (ptys, most USB CDC adapters) are left as they are. ``low_latency=False``
keeps it off.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import enum
import errno
import logging
import math
import threading
import time

import serial
import serial.rs485

from pyuss import system
from pyuss.errors import ConfigError, TransportError
from pyuss.system import clock
from pyuss.transport.address import split_url
from pyuss.transport.base import Chunk, LineError
from pyuss.transport.queued import QueuedTransport, char_time

log = logging.getLogger(__name__)

#: How often an idle reader thread wakes up to see whether it should stop (seconds).
_READ_POLL = 0.1
#: Longest a write may block in the OS before the port is taken as lost (seconds).
_WRITE_TIMEOUT = 2.0
#: pyserial backends that refuse a write timeout (they raise NotImplementedError on open).
_NO_WRITE_TIMEOUT = ("rfc2217://",)
#: How a character flagged by the kernel (PARMRK) is reported.
MARKED = LineError.PARITY | LineError.FRAMING

_PARITIES = {
    "N": serial.PARITY_NONE,
    "E": serial.PARITY_EVEN,
    "O": serial.PARITY_ODD,
    "M": serial.PARITY_MARK,
    "S": serial.PARITY_SPACE,
}
_STOPBITS = {1: serial.STOPBITS_ONE, 1.5: serial.STOPBITS_ONE_POINT_FIVE, 2: serial.STOPBITS_TWO}

#: Errors of opening and setting up a port (``termios.error`` is no OSError).
_OPEN_ERRORS: tuple[type[BaseException], ...] = (
    OSError,
    ValueError,
    NotImplementedError,
    serial.SerialException,
    *system.LINE_SETUP_ERRORS,
)


def is_pty(url: str) -> bool:
    """True when ``url`` is the device side of a Linux pseudo-terminal (``/dev/pts/N``, or a
    link to one such as socat makes): a port that keeps no parity (see the module docstring)."""
    return system.is_pty_device(url)


def low_latency(fd: int, on: bool) -> bool | None:
    """Ask the driver of the open terminal ``fd`` for low-latency mode (``on``) or normal mode;
    returns whether it was in low-latency mode before, or None when the driver does not offer
    it (`pyuss.system.low_latency`)."""
    return system.low_latency(fd, on)


def _open_problem(exc: BaseException) -> str:
    """What went wrong opening a port, in words, then pyserial's own text."""
    text = str(exc)
    number = getattr(exc, "errno", None)
    if number == errno.ENOENT or "FileNotFoundError" in text:
        return f"no such port ({text})"
    if number in (errno.EBUSY, errno.EACCES) or "PermissionError" in text:
        return f"the port is in use by another program, or not open to this user ({text})"
    return text


def port_list(url: str) -> str:
    """For a port that cannot be opened: the serial ports the system has (pyserial's
    ``list_ports``), as a sentence to add to the error; nothing for a URL."""
    if "://" in url:
        return ""
    try:
        from serial.tools import list_ports

        ports = sorted(list_ports.comports(), key=lambda info: info.device)
    except Exception:  # pragma: no cover - a system whose port listing fails
        return ""
    if not ports:
        return (
            "; this system lists no serial ports (is the adapter plugged in, its driver installed?)"
        )
    named = [
        f"{info.device} ({info.description})"
        if info.description and info.description not in ("n/a", info.device)
        else info.device
        for info in ports
    ]
    return "; serial ports here: " + ", ".join(named)


def _check_network_url(url: str) -> None:
    """``socket://`` and ``rfc2217://`` need HOST:PORT; say so rather than pyserial's riddle."""
    parts = split_url(url)
    scheme = parts.scheme.lower()
    if scheme not in ("socket", "rfc2217"):
        return
    try:
        port = parts.port
    except ValueError:
        port = None
    if not parts.hostname or port is None or not 0 < port < 65536:
        raise ConfigError(f"serial port URL {url!r}: expected {scheme}://HOST:PORT")


class RS485Mode(enum.Enum):
    """Who switches the RS-485 driver between sending and listening."""

    AUTO = "auto"
    KERNEL = "kernel"
    RTS = "rts"

    @classmethod
    def parse(cls, value: RS485Mode | str) -> RS485Mode:
        if isinstance(value, RS485Mode):
            return value
        try:
            return cls(str(value).lower())
        except ValueError:
            names = ", ".join(m.value for m in cls)
            raise ConfigError(f"RS-485 mode {value!r} is not one of {names}") from None


class MarkDecoder:
    """Undo the kernel's PARMRK marking: ``FF FF`` is a data byte FF, ``FF 00 c`` is character
    ``c`` received with a parity or framing error (``FF 00 00`` also stands for a break)."""

    def __init__(self) -> None:
        self._held = b""

    def feed(self, raw: bytes) -> tuple[bytes, tuple[tuple[int, LineError], ...]]:
        buf = self._held + raw
        self._held = b""
        out = bytearray()
        errors: list[tuple[int, LineError]] = []
        i = 0
        n = len(buf)
        while i < n:
            b = buf[i]
            if b != 0xFF:
                out.append(b)
                i += 1
                continue
            if i + 1 >= n:
                self._held = buf[i:]
                break
            nxt = buf[i + 1]
            if nxt == 0xFF:
                out.append(0xFF)
                i += 2
            elif nxt == 0x00:
                if i + 2 >= n:
                    self._held = buf[i:]
                    break
                errors.append((len(out), MARKED))
                out.append(buf[i + 2])
                i += 3
            else:  # not a mark the kernel makes: take the byte as it is
                out.append(0xFF)
                i += 1
        return bytes(out), tuple(errors)


class SerialTransport(QueuedTransport):
    """A serial port (any pyserial URL) as a `Transport`. See the module docstring."""

    def __init__(
        self,
        url: str,
        *,
        baud: int = 9600,
        parity: str = "E",
        stopbits: float = 1,
        rs485: RS485Mode | str = RS485Mode.AUTO,
        echo: bool = False,
        echo_timeout: float = 0.2,
        line_errors: bool = True,
        rts_delay_before: float = 0.0,
        rts_delay_after: float = 0.0,
        low_latency: bool = True,
    ) -> None:
        super().__init__(baud=baud, echo=echo, echo_timeout=echo_timeout)
        if not isinstance(url, str) or not url:
            raise ConfigError(f"serial port URL must be a non-empty string, not {url!r}")
        _check_network_url(url)
        key = str(parity).upper()
        if key not in _PARITIES:
            raise ConfigError(f"parity {parity!r} is not one of N, E, O, M, S")
        if stopbits not in _STOPBITS:
            raise ConfigError(f"stop bits {stopbits!r} is not one of 1, 1.5, 2")
        if rts_delay_before < 0 or rts_delay_after < 0:
            raise ConfigError("RTS delays must be >= 0 seconds")
        self.url = url
        self._parity = _PARITIES[key]
        self.rs485 = RS485Mode.parse(rs485)
        self._line_errors = line_errors
        self._rts_before = rts_delay_before
        self._rts_after = rts_delay_after
        self.low_latency = low_latency
        #: Low-latency mode while open: True (asked for and given), False (kept off), None
        #: (the driver does not offer it).
        self.low_latency_mode: bool | None = None
        self._latency_before: bool | None = None
        try:
            self._port = serial.serial_for_url(
                url,
                baudrate=self.baud,
                bytesize=serial.EIGHTBITS,
                parity=_PARITIES[key],
                stopbits=_STOPBITS[stopbits],
                timeout=_READ_POLL,
                write_timeout=None if url.lower().startswith(_NO_WRITE_TIMEOUT) else _WRITE_TIMEOUT,
                do_not_open=True,
            )
        except (ValueError, serial.SerialException) as exc:
            raise ConfigError(f"serial port URL {url!r}: {exc}") from None
        self._now_decoder: MarkDecoder | None = None
        self._now_timeout: float | None = self._port.timeout
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._writer: concurrent.futures.ThreadPoolExecutor | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

    def describe(self) -> str:
        return f"serial port {self.url}"

    @property
    def port(self) -> serial.SerialBase:
        """The pyserial port object (for settings pyuss does not cover)."""
        return self._port

    async def open(self) -> None:
        if self.is_open:
            return
        await asyncio.to_thread(self.open_port)  # (bad characters marked: `read_now` reads them)
        self._loop = asyncio.get_running_loop()
        self._mark_open()
        self._stop.clear()
        self._writer = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="uss-write")
        self._thread = threading.Thread(
            target=self._read_worker,
            name=f"uss-read {self.url}",
            daemon=True,
        )
        self._thread.start()

    def open_port(self) -> bool:
        """Open the pyserial port as `open` does (RS-485 mode, the frame, line-error marking,
        low latency) without the reader and writer threads, for a caller that reads `port`
        and writes through `write_now` in its own thread (`pyuss.master.blocking`). Returns
        whether bad characters are marked (`MarkDecoder` reads them)."""
        if self.rs485 is RS485Mode.KERNEL:
            self._port.rs485_mode = serial.rs485.RS485Settings(
                rts_level_for_tx=True, rts_level_for_rx=False
            )
        # A pty keeps no parity, and asking for one may be refused (see the module docstring).
        self._port.parity = self._parity if not is_pty(self.url) else serial.PARITY_NONE
        try:
            self._port.open()
            marking = self._setup_marking()
            if self.rs485 is RS485Mode.RTS:
                self._port.rts = False
            self._setup_latency()
            self._now_decoder = MarkDecoder() if marking else None
            self._now_timeout = self._port.timeout
        except _OPEN_ERRORS as exc:
            self.close_port()
            what = {
                RS485Mode.KERNEL: "kernel RS-485 mode: ",
                RS485Mode.RTS: "RTS direction control: ",
            }.get(self.rs485, "")
            raise TransportError(
                f"cannot open {self.describe()}: {what}{_open_problem(exc)}{port_list(self.url)}"
            ) from None
        return marking

    def read_now(self, count: int | None, timeout: float) -> Chunk | None:
        """In the calling thread, after `open_port`: ``count`` bytes (None: what is waiting, at
        least one) within ``timeout`` seconds, stamped when read (the line's clock); None when
        none came."""
        port = self._port
        try:
            if timeout <= 0:  # what is in, without waiting
                waiting = port.in_waiting
                data = port.read(waiting if count is None else min(count, waiting))
            else:
                # in whole milliseconds: a port's timeout is set again only when it changes
                timeout = math.ceil(timeout * 1000) / 1000
                if timeout != self._now_timeout:
                    port.timeout = self._now_timeout = timeout
                data = port.read(count or 1)
                if data and count is None and (waiting := port.in_waiting):
                    data += port.read(waiting)
        except Exception as exc:  # pyserial raises many kinds when a port vanishes
            raise TransportError(f"{self.describe()} lost: {exc}") from None
        if not data:
            return None
        stamp = clock()
        if self._now_decoder is None:
            return Chunk(data, stamp)
        clean, errors = self._now_decoder.feed(data)
        return Chunk(clean, stamp, errors)

    def _setup_marking(self) -> bool:
        """Switch a POSIX terminal to mark bad characters; False where that is not possible."""
        fd = getattr(self._port, "fd", None)
        if not self._line_errors or not isinstance(fd, int):
            return False
        return system.mark_line_errors(fd)

    def _setup_latency(self) -> None:
        """Low-latency mode on a driver that offers it (see the module docstring)."""
        self._latency_before = self.low_latency_mode = None
        fd = getattr(self._port, "fd", None)
        if not isinstance(fd, int):
            return
        before = low_latency(fd, self.low_latency)
        if before is not None:
            self._latency_before = before
            self.low_latency_mode = self.low_latency
            mode = "on" if self.low_latency else "off"
            log.debug("%s: low-latency mode %s", self.describe(), mode)

    def _read_worker(self) -> None:
        """The reader thread: `read_now` in a loop, each burst handed to the event loop."""
        while not self._stop.is_set():
            try:
                chunk = self.read_now(None, _READ_POLL)
            except TransportError as exc:
                if not self._stop.is_set():
                    self._post(self._lose, exc)
                break
            if chunk is not None:
                self._post(self._deliver, chunk.data, chunk.timestamp, chunk.errors)

    def _post(self, func: object, *args: object) -> None:
        assert self._loop is not None
        try:
            self._loop.call_soon_threadsafe(func, *args)  # type: ignore[arg-type]
        except RuntimeError:  # the loop is closed: nobody is left to tell
            self._stop.set()

    async def write(self, data: bytes) -> None:
        self._check_writable()
        if not data:
            return
        assert self._writer is not None
        self._arm_echo(data)
        loop = asyncio.get_running_loop()
        try:
            await loop.run_in_executor(self._writer, self.write_now, bytes(data))
        except (OSError, ValueError, serial.SerialException) as exc:
            error = TransportError(f"{self.describe()}: write failed: {exc}")
            self._lose(error)
            raise error from None
        self.stats.bytes_out += len(data)

    def write_now(self, data: bytes) -> None:
        """Write ``data`` in the calling thread (RTS direction control included)."""
        port = self._port
        if self.rs485 is not RS485Mode.RTS:
            port.write(data)
            return
        port.rts = True
        try:
            if self._rts_before:
                time.sleep(self._rts_before)
            began = clock()
            port.write(data)
            port.flush()
            left = began + len(data) * char_time(self.baud) - clock()
            if left > 0:
                time.sleep(left)
            if self._rts_after:
                time.sleep(self._rts_after)
        finally:
            port.rts = False

    def flush_input(self) -> None:
        super().flush_input()
        if self.is_open:
            try:
                self._port.reset_input_buffer()
            except _OPEN_ERRORS as exc:
                log.debug("%s: input flush failed: %s", self.describe(), exc)

    async def close(self) -> None:
        if not self.is_open:
            return
        self._mark_closed()
        self._stop.set()
        cancel = getattr(self._port, "cancel_read", None)
        if cancel is not None:
            with contextlib.suppress(Exception):  # best effort: the thread polls anyway
                cancel()
        if self._thread is not None:
            await asyncio.to_thread(self._thread.join, 2.0)
            self._thread = None
        if self._writer is not None:
            writer, self._writer = self._writer, None
            await asyncio.to_thread(writer.shutdown, True)
        self.close_port()

    def close_port(self) -> None:
        """Close the port (after `open_port`), low-latency mode as it was."""
        fd = getattr(self._port, "fd", None)
        before = self._latency_before
        if before is not None and before != self.low_latency and isinstance(fd, int):
            low_latency(fd, before)  # as it was before
        self._latency_before = self.low_latency_mode = None
        try:
            self._port.close()
        except Exception as exc:  # pragma: no cover - closing a vanished port
            log.debug("%s: close: %s", self.describe(), exc)
