"""Line I/O for the DP slave: a pty pair or a serial port, behind the `Transport` contract.

This is the one module of the KS VARIO part that touches the operating system. It stays small
so that it can give way to the shared transports of `pyuss.transport` (PtyPort,
SerialTransport) without changing the DP slave: the slave only uses the `Transport` methods.

* `PtyLine` opens a pseudo-terminal pair; a DP master opens `device` (for example pyprofibus's
  serial PHY). A pty has no baud rate or parity of its own: the 8E1 setting a master makes on
  its side is accepted and bytes pass unchanged.
* `SerialLine` opens a serial port or pyserial URL at 8E1 (PROFIBUS character format).
"""

from __future__ import annotations

import asyncio
import os
import termios
import time
import tty
from typing import Any

import serial

from pyuss.errors import TransportError
from pyuss.transport.base import Chunk, Transport


class PtyLine(Transport):
    """The master end of a pty pair; `device` is the path a DP master opens."""

    def __init__(self, baud: int = 19200) -> None:
        self._baud = baud
        self._master: int | None = None
        self._slave: int | None = None
        self.device = ""
        self._queue: asyncio.Queue[Chunk | None] | None = None

    @property
    def baud(self) -> int:
        return self._baud

    def clock(self) -> float:
        return time.monotonic()

    async def open(self) -> None:
        try:
            master, slave = os.openpty()
        except OSError as exc:
            raise TransportError(f"cannot open a pty pair: {exc}") from exc
        tty.setraw(slave)  # no echo, no line editing until the master configures its side
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.device = os.ttyname(slave)
        self._queue = asyncio.Queue()
        asyncio.get_running_loop().add_reader(master, self._readable)

    def _readable(self) -> None:
        assert self._master is not None and self._queue is not None
        try:
            data = os.read(self._master, 4096)
        except BlockingIOError:
            return
        except OSError:
            data = b""
        if data:
            self._queue.put_nowait(Chunk(data, self.clock()))

    async def close(self) -> None:
        if self._master is not None:
            asyncio.get_running_loop().remove_reader(self._master)
            os.close(self._master)
            self._master = None
        if self._slave is not None:
            os.close(self._slave)
            self._slave = None
        if self._queue is not None:
            self._queue.put_nowait(None)

    async def write(self, data: bytes) -> None:
        if self._master is None:
            raise TransportError("pty line is closed")
        view = memoryview(data)
        while view:
            try:
                n = os.write(self._master, view)
            except BlockingIOError:
                await asyncio.sleep(0.001)
                continue
            except OSError as exc:
                raise TransportError(f"pty write failed: {exc}") from exc
            view = view[n:]

    async def read(self, timeout: float | None = None) -> Chunk | None:
        if self._queue is None or self._master is None:
            raise TransportError("pty line is closed")
        try:
            chunk = await asyncio.wait_for(self._queue.get(), timeout)
        except TimeoutError:
            return None
        if chunk is None:
            raise TransportError("pty line is closed")
        return chunk

    def flush_input(self) -> None:
        if self._queue is not None:
            while not self._queue.empty():
                self._queue.get_nowait()


class SerialLine(Transport):
    """A serial port or pyserial URL at 8E1."""

    def __init__(self, url: str, baud: int = 19200) -> None:
        self.url = url
        self._baud = baud
        self._port: Any = None

    @property
    def baud(self) -> int:
        return self._baud

    def clock(self) -> float:
        return time.monotonic()

    def _open(self, parity: str) -> Any:
        return serial.serial_for_url(
            self.url,
            baudrate=self._baud,
            bytesize=serial.EIGHTBITS,
            parity=parity,
            stopbits=serial.STOPBITS_ONE,
            timeout=0.02,
        )

    async def open(self) -> None:
        try:
            self._port = self._open(serial.PARITY_EVEN)
        except (serial.SerialException, ValueError, termios.error) as exc:
            # Some pty drivers refuse a parity change they cannot carry anyway; a pty moves
            # bytes, not characters, so 8N1 there is the same line.
            if not self.url.startswith("/dev/pts/"):
                raise TransportError(f"cannot open {self.url}: {exc}") from exc
            try:
                self._port = self._open(serial.PARITY_NONE)
            except (serial.SerialException, ValueError, termios.error) as exc2:
                raise TransportError(f"cannot open {self.url}: {exc2}") from exc2

    async def close(self) -> None:
        if self._port is not None:
            self._port.close()
            self._port = None

    async def write(self, data: bytes) -> None:
        if self._port is None:
            raise TransportError(f"{self.url} is closed")
        try:
            await asyncio.to_thread(self._port.write, data)
        except serial.SerialException as exc:
            raise TransportError(f"write to {self.url} failed: {exc}") from exc

    async def read(self, timeout: float | None = None) -> Chunk | None:
        if self._port is None:
            raise TransportError(f"{self.url} is closed")
        deadline = None if timeout is None else self.clock() + timeout
        while True:
            try:
                data = await asyncio.to_thread(self._port.read, 4096)
            except serial.SerialException as exc:
                raise TransportError(f"read from {self.url} failed: {exc}") from exc
            if data:
                return Chunk(bytes(data), self.clock())
            if deadline is not None and self.clock() >= deadline:
                return None

    def flush_input(self) -> None:
        if self._port is not None:
            self._port.reset_input_buffer()
