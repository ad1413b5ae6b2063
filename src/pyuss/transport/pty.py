"""Pseudo-terminals: a serial port in software that any program can open.

`PtyPort` opens a pty pair. Other programs open `PtyPort.device_path` (``/dev/pts/N``) as if
it were a serial adapter, with pyserial or anything else; the owner reads and writes the other
(master) side through the `Transport` API. A pty has no baud rate and no line errors: bytes
pass at once, and ``baud`` only tells users the character time to reckon with.

The port keeps its own handle on the device side open, so that programs may open and close
the device as often as they like without the master side seeing a hang-up. While nobody reads
the device, what the owner writes waits in the kernel's buffer (pyserial empties it when it
opens the port); once that buffer is full, `write` waits up to ``write_timeout`` seconds and
then raises `TransportError`. Chunks are stamped with ``time.monotonic()`` when the event loop
reads them. POSIX only.

Settings a program leaves on the device (Linux). A pty keeps no parity: the kernel clears
PARENB in every setting made on it, and glibc's ``tcsetattr`` (as Debian builds it) fails with
EINVAL when the settings did not change but the parity was refused. So a program asking for the
settings the previous one left, with even parity (pyserial at 9600 8E1 twice in a row), could
not open the device. The port therefore puts the device "at rest" after every change: 50 or 75
baud, alternately (a reset that lands inside a program's ``tcsetattr`` must still count as a
change), and no CLOCAL. A pty ignores both, and pyserial always sets CLOCAL, so what the next
program asks for is a change. The kernel tells the port of changes: the master runs in packet
mode (TIOCPKT), where a read is a zero byte and data, or one control byte alone, telling of a
flush or, with EXTPROC set on the device, of new settings. The port drops that byte and rests
the device; it also does so before it writes. EXTPROC is left off while a program asks for
input processing (PARMRK marking, canonical mode, echo), which EXTPROC would skip. The reset
runs when the event loop reads the notice: a program that sets up the device, closes it and
opens it again before that (microseconds on an idle loop) can still be refused. Elsewhere, or
where the kernel sends no such notice, the port works without packet mode.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import platform
import struct
import sys
import time

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.queued import QueuedTransport

_READ_SIZE = 65536
#: Control byte of a packet-mode read: the settings of the device side changed (EXTPROC).
_TIOCPKT_IOCTL = 0x40


def _extproc_flag() -> int:
    """The EXTPROC bit of ``c_lflag`` (Python's termios may lack it); 0 off Linux."""
    if not sys.platform.startswith("linux"):
        return 0
    import termios

    flag = getattr(termios, "EXTPROC", None)
    if flag is not None:
        return int(flag)
    return 0x10000000 if platform.machine().startswith(("ppc", "powerpc", "alpha")) else 0o200000


class PtyPort(QueuedTransport):
    """A pseudo-terminal pair; see the module docstring."""

    def __init__(self, *, baud: int = 9600, echo: bool = False, write_timeout: float = 1.0) -> None:
        super().__init__(baud=baud, echo=echo)
        if write_timeout <= 0:
            raise ConfigError(f"write_timeout must be > 0 seconds, not {write_timeout!r}")
        self._write_timeout = write_timeout
        self._master = -1
        self._slave = -1
        self._path: str | None = None
        self._write_waiter: asyncio.Future[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._extproc = 0  # the EXTPROC bit while the port watches the device's settings
        self._rests = 0  # resets so far: the rest speed alternates

    @property
    def device_path(self) -> str:
        """The device other programs open (valid while the port is open)."""
        if self._path is None:
            raise TransportError("the pty is not open: no device path yet")
        return self._path

    def describe(self) -> str:
        return f"pty {self._path or '(not open)'}"

    async def open(self) -> None:
        if self.is_open:
            return
        try:
            import termios
            import tty

            master, slave = os.openpty()
        except (OSError, ImportError) as exc:
            raise TransportError(f"cannot open a pseudo-terminal: {exc}") from None
        try:
            tty.setraw(slave)
            os.set_blocking(master, False)
            self._path = os.ttyname(slave)
        except (OSError, termios.error) as exc:
            os.close(master)
            os.close(slave)
            raise TransportError(f"cannot set up the pseudo-terminal: {exc}") from None
        self._master, self._slave = master, slave
        self._watch_settings()
        self._loop = asyncio.get_running_loop()
        self._mark_open()
        self._loop.add_reader(master, self._on_readable)

    def _watch_settings(self) -> None:
        """Packet mode on the master, EXTPROC and rest settings on the device (see the module
        docstring); where the kernel sends no notice for that, the pty is left as it was."""
        self._extproc = self._rests = 0
        extproc = _extproc_flag()
        if not extproc:
            return
        import fcntl
        import termios

        try:
            before = termios.tcgetattr(self._slave)
            fcntl.ioctl(self._master, termios.TIOCPKT, struct.pack("i", 1))
        except (OSError, termios.error):
            return
        self._extproc = extproc
        self._rest()
        try:
            notice = os.read(self._master, _READ_SIZE)
        except OSError:
            notice = b""
        if len(notice) == 1 and notice[0] & _TIOCPKT_IOCTL:
            return
        self._extproc = 0
        with contextlib.suppress(OSError, termios.error):
            fcntl.ioctl(self._master, termios.TIOCPKT, struct.pack("i", 0))
            termios.tcsetattr(self._slave, termios.TCSANOW, before)

    def _rest(self) -> None:
        """Put the device's settings at rest, unless they are (as after our own reset). A program
        that asks for input processing gets its settings without EXTPROC: a change it makes
        later is not told (unless it flushes its input, as pyserial does on opening), but the
        settings it leaves are at rest."""
        import termios

        speeds = (termios.B50, termios.B75)
        processed_i = termios.IGNCR | termios.ICRNL | termios.INLCR | termios.IXON | termios.PARMRK
        processed_l = termios.ICANON | termios.ISIG | termios.ECHO
        try:
            iflag, oflag, cflag, lflag, _ispeed, ospeed, cc = termios.tcgetattr(self._slave)
            if iflag & processed_i or lflag & processed_l:
                rest_lflag = lflag & ~self._extproc
            else:
                rest_lflag = lflag | self._extproc
            if ospeed in speeds and not cflag & termios.CLOCAL and lflag == rest_lflag:
                return
            speed = speeds[self._rests % 2]
            self._rests += 1
            attrs = [iflag, oflag, cflag & ~termios.CLOCAL, rest_lflag, speed, speed, cc]
            termios.tcsetattr(self._slave, termios.TCSANOW, attrs)
        except termios.error:  # our own handle on the device: nothing to tell anyone
            pass

    def _settle_before_writing(self) -> None:
        """The kernel processes what the owner writes with the device's settings of the moment:
        a program that has just asked for processing (PARMRK) gets it before the kernel's
        notice is read."""
        if self._extproc:
            self._rest()

    def _unpack(self, data: bytes) -> bytes:
        """The data of one read from the master. In packet mode a read is a zero byte and
        data, or one control byte alone (the kernel's notice of a change of settings, a flush,
        a stop): a control byte is dropped, and the device's settings are put at rest."""
        if not self._extproc:
            return data
        if data[0]:
            self._rest()
        return data[1:]

    def _on_readable(self) -> None:
        try:
            data = os.read(self._master, _READ_SIZE)
        except BlockingIOError:
            return
        except OSError as exc:
            self._stop_reading()
            self._lose(TransportError(f"{self.describe()} lost: {exc}"))
            return
        if not data:
            self._stop_reading()
            self._lose(TransportError(f"{self.describe()} lost: end of file"))
            return
        data = self._unpack(data)
        if data:
            self._deliver(data, time.monotonic())

    def _stop_reading(self) -> None:
        if self._loop is not None and self._master >= 0:
            self._loop.remove_reader(self._master)

    async def write(self, data: bytes) -> None:
        self._check_writable()
        self._settle_before_writing()
        view = memoryview(bytes(data))
        self._arm_echo(bytes(view))
        deadline = time.monotonic() + self._write_timeout
        while view:
            try:
                n = os.write(self._master, view)
            except BlockingIOError:
                n = 0
            except OSError as exc:
                error = TransportError(f"{self.describe()}: write failed: {exc}")
                self._lose(error)
                raise error from None
            self.stats.bytes_out += n
            view = view[n:]
            if view:
                if time.monotonic() >= deadline:
                    self.stats.dropped_out += len(view)
                    raise TransportError(
                        f"{self.describe()}: nobody reads the device; "
                        f"{len(view)} bytes not written after {self._write_timeout} s"
                    )
                await self._writable(deadline)
                if not self.is_open:
                    self.stats.dropped_out += len(view)
                    raise TransportError(
                        f"{self.describe()} was closed while writing; {len(view)} bytes not written"
                    )

    def write_nowait(self, data: bytes) -> int:
        """Write what the kernel takes now, without waiting; the rest is dropped and counted
        in ``stats.dropped_out``. Returns the number of bytes written."""
        if not self.is_open:
            raise TransportError(f"{self.describe()} is not open")
        self._settle_before_writing()
        try:
            n = os.write(self._master, data)
        except BlockingIOError:
            n = 0
        except OSError as exc:
            self._lose(TransportError(f"{self.describe()}: write failed: {exc}"))
            n = 0
        self.stats.bytes_out += n
        self.stats.dropped_out += len(data) - n
        return n

    async def _writable(self, deadline: float) -> None:
        """Wait until the kernel takes more bytes, the deadline passes or the port is closed."""
        loop = asyncio.get_running_loop()
        ready: asyncio.Future[None] = loop.create_future()
        fd = self._master

        def wake() -> None:
            if not ready.done():
                ready.set_result(None)

        loop.add_writer(fd, wake)
        self._write_waiter = ready
        try:
            await asyncio.wait_for(ready, max(0.0, deadline - time.monotonic()))
        except TimeoutError:
            pass
        finally:
            self._write_waiter = None
            if self._master == fd:  # close() has dropped the writer of a closed descriptor
                loop.remove_writer(fd)

    def flush_input(self) -> None:
        super().flush_input()
        if self._master >= 0:
            while True:
                try:
                    data = os.read(self._master, _READ_SIZE)
                except OSError:  # nothing left (EAGAIN) or gone: either way nothing to drop
                    break
                if not data:
                    break
                self._unpack(data)

    async def close(self) -> None:
        if not self.is_open:
            return
        self._stop_reading()
        self._mark_closed()
        if self._write_waiter is not None:  # a write waiting for room ends (TransportError)
            if self._loop is not None:
                self._loop.remove_writer(self._master)
            if not self._write_waiter.done():
                self._write_waiter.set_result(None)
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._master = self._slave = -1
