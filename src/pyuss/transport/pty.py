"""Pseudo-terminals: a serial port in software that any program can open.

`PtyPort` opens a pty pair. Other programs open `PtyPort.device_path` (``/dev/pts/N``) as if
it were a serial adapter, with pyserial or anything else; the owner reads and writes the other
(master) side through the `Transport` API. A pty has no baud rate and no line errors: bytes
pass at once, and ``baud`` only tells users the character time to reckon with.

The port keeps its own handle on the device side open, so that programs may open and close
the device as often as they like without the master side seeing a hang-up. While nobody reads
the device, what the owner writes waits in the kernel's buffer (pyserial empties it when it
opens the port); once that buffer is full, `write` waits up to ``write_timeout`` seconds and
then raises `TransportError`. Chunks are stamped with the line's clock when the event loop
reads them. Linux and macOS only: on Windows making a port says what to use instead.
"""

from __future__ import annotations

import asyncio
import contextlib
import os

from pyuss import system
from pyuss.errors import ConfigError, TransportError
from pyuss.system import clock
from pyuss.transport.queued import QueuedTransport

_READ_SIZE = 65536


class PtyPort(QueuedTransport):
    """A pseudo-terminal pair; see the module docstring."""

    def __init__(self, *, baud: int = 9600, echo: bool = False, write_timeout: float = 1.0) -> None:
        super().__init__(baud=baud, echo=echo)
        if not system.HAS_PTY:
            raise system.NoPty(system.PTY_ADVICE)
        if write_timeout <= 0:
            raise ConfigError(f"write_timeout must be > 0 seconds, not {write_timeout!r}")
        self._write_timeout = write_timeout
        self._master = -1
        self._slave = -1
        self._path: str | None = None
        self._write_waiter: asyncio.Future[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

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
            master, slave, self._path = system.open_pty()
        except OSError as exc:
            raise TransportError(f"cannot open a pseudo-terminal: {exc}") from None
        self._master, self._slave = master, slave
        self._loop = asyncio.get_running_loop()
        self._mark_open()
        self._loop.add_reader(master, self._on_readable)

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
        self._deliver(data, clock())

    def _stop_reading(self) -> None:
        if self._loop is not None and self._master >= 0:
            self._loop.remove_reader(self._master)

    async def write(self, data: bytes) -> None:
        self._check_writable()
        view = memoryview(bytes(data))
        self._arm_echo(bytes(view))
        deadline = clock() + self._write_timeout
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
                if clock() >= deadline:
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
            async with asyncio.timeout(max(0.0, deadline - clock())):
                await ready
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
                    if not os.read(self._master, _READ_SIZE):
                        break
                except OSError:  # nothing left (EAGAIN) or gone: either way nothing to drop
                    break

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
