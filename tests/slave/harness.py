"""Simulated drives on a line without timing, and a master that speaks raw bytes.

`LineSim` runs a `SlaveServer` with engines in an event loop of its own thread, on a TCP server
of a free loopback port (`TcpServerTransport`, ``line="tcp"``, the default) or on a real pty
(`PtyPort`, ``line="pty"``): both carry no timing, and the server keeps the same line of its
own on them. A test talks to it with a plain blocking socket or pyserial, exactly as an outside
program would. Code that touches the drives runs in that thread (`LineSim.call`).
"""

from __future__ import annotations

import asyncio
import select
import socket
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from typing import Any, TypeVar

import serial

from pyuss.drive import SimulatedDrive
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import AddressMode, Telegram, bcc
from pyuss.protocol.timing import BAUD_RATES
from pyuss.slave import SlaveEngine, SlaveServer
from pyuss.transport.base import Transport
from pyuss.transport.pty import PtyPort
from pyuss.transport.tcp import TcpServerTransport

T = TypeVar("T")

#: Generous: a loaded machine. An answer normally comes within a few milliseconds.
WAIT = 5.0
#: How long silence is waited for: far beyond the 20 ms an answer may take (A 5.2.1.1).
SILENCE = 0.25

Setup = Callable[[float], Sequence[SlaveEngine]]


def engine(
    address: int,
    profile: str = "generic",
    layout: str | None = None,
    *,
    store: str | None = None,
    **options: Any,
) -> Setup:
    """A setup making one engine with a fresh drive of ``profile``."""

    def make(now: float) -> Sequence[SlaveEngine]:
        prof = get_profile(profile)
        drive = SimulatedDrive(prof.database(), store=store, now=now)
        shape = None if layout is None else Layout.parse(layout)
        return [SlaveEngine(address, drive, prof, layout=shape, now=now, **options)]

    return make


class LineSim:
    """Engines served until `close` on ``line``: ``"tcp"`` (``path`` is
    ``tcp://127.0.0.1:PORT``) or ``"pty"`` (``path`` is the device to open). ``baud``: the
    rate of the line (default: the fastest rate every drive runs at)."""

    def __init__(
        self, setup: Setup, *, baud: int | None = None, line: str = "tcp", **server: Any
    ) -> None:
        if line not in ("tcp", "pty"):
            raise ValueError(f"line is 'tcp' or 'pty', not {line!r}")
        self.line = line
        self.baud = baud or 0
        self.loop = asyncio.new_event_loop()
        self._ready: Future[None] = Future()
        self._stop: asyncio.Event | None = None
        self.engines: list[SlaveEngine] = []
        self.server: SlaveServer | None = None
        self.path = ""
        self._thread = threading.Thread(
            target=self._main, args=(setup, server), name=f"{line}-sim", daemon=True
        )
        self._thread.start()
        self._ready.result(WAIT)

    def _main(self, setup: Setup, options: dict[str, Any]) -> None:
        asyncio.set_event_loop(self.loop)
        self.loop.run_until_complete(self._serve(setup, options))
        self.loop.close()

    async def _serve(self, setup: Setup, options: dict[str, Any]) -> None:
        try:
            self._stop = asyncio.Event()
            self.engines = list(setup(time.monotonic()))
            if not self.baud:  # the fastest rate every drive runs at (quick tests)
                rates = set(BAUD_RATES)
                for one in self.engines:
                    rates &= set(one.interface_parameters.rates())
                self.baud = max(rates)
            port: Transport
            if self.line == "pty":
                port = pty = PtyPort(baud=self.baud)
                await port.open()
                self.path = pty.device_path
            else:
                port = tcp = TcpServerTransport("127.0.0.1", 0, baud=self.baud)
                await port.open()
                self.path = f"tcp://127.0.0.1:{tcp.port}"
            self.server = SlaveServer(port, *self.engines, **options)
        except BaseException as exc:
            self._ready.set_exception(exc)
            raise
        self._ready.set_result(None)
        try:
            await self.server.run(self._stop)
        finally:
            self.server.close()
            await port.close()

    @property
    def drive(self) -> SimulatedDrive:
        return self.engines[0].drive

    def call(self, func: Callable[[], T]) -> T:
        """Run ``func`` in the simulator's thread and return its result."""

        async def run() -> T:
            return func()

        return asyncio.run_coroutine_threadsafe(run(), self.loop).result(WAIT)

    def close(self) -> None:
        if self._stop is not None and not self.loop.is_closed():
            self.loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(WAIT)

    def __enter__(self) -> LineSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def master(self) -> Master:
        return Master(self.path)


class Master:
    """The far end of the line: raw bytes through a socket (``tcp://HOST:PORT``) or pyserial
    (a pty's path). Neither has a baud rate (the simulator times the line itself); a pty is
    opened at 9600 baud, 8E1."""

    def __init__(self, path: str) -> None:
        self.sock: socket.socket | None = None
        self.port: serial.Serial | None = None
        if path.startswith("tcp://"):
            host, port = path.removeprefix("tcp://").rsplit(":", 1)
            self.sock = socket.create_connection((host, int(port)), timeout=WAIT)
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        else:
            self.port = serial.Serial(path, 9600, parity=serial.PARITY_EVEN, timeout=WAIT)

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
        if self.port is not None:
            self.port.close()

    def __enter__(self) -> Master:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def send(self, data: bytes | str) -> None:
        raw = bytes.fromhex(data) if isinstance(data, str) else data
        if self.sock is not None:
            self.sock.sendall(raw)
            return
        assert self.port is not None
        self.port.write(raw)
        self.port.flush()

    def _readable(self, timeout: float) -> bool:
        # select() instead of changing the port's timeout: that re-applies the termios
        # settings, which a pty may refuse once the other side has written
        ready, _, _ = select.select([self.sock or self.port], [], [], timeout)
        return bool(ready)

    def _read(self, n: int) -> bytes:
        """``n`` bytes, or fewer when no more come within `WAIT` seconds."""
        if self.sock is None:
            assert self.port is not None
            return bytes(self.port.read(n))
        got = b""
        while len(got) < n and self._readable(WAIT):
            chunk = self.sock.recv(n - len(got))
            if not chunk:
                break
            got += chunk
        return got

    def read_telegram(self, timeout: float = WAIT) -> bytes | None:
        """One telegram (STX, LGE and LGE more bytes), or None when nothing comes in time."""
        if not self._readable(timeout):
            return None
        head = self._read(2)
        assert len(head) == 2 and head[0] == 0x02, f"not a telegram start: {head.hex(' ')}"
        rest = self._read(head[1])
        assert len(rest) == head[1], f"telegram cut short: {(head + rest).hex(' ')}"
        return head + rest

    def exchange(self, data: bytes | str) -> bytes:
        """Send a request and return the answer (which must come)."""
        self.send(data)
        answer = self.read_telegram()
        assert answer is not None, f"no answer to {data!r}"
        return answer

    def silent(self, data: bytes | str, wait: float = SILENCE) -> bool:
        """Send and check that no byte comes back within ``wait`` seconds."""
        self.send(data)
        return not self._readable(wait)

    def ask(self, address: int, layout: Layout, pkw: Any = None, pzd: Sequence[int] = ()) -> Any:
        """Send a normal telegram built from ``pkw`` (a `Pkw` or None) and PZD words; return
        the answer's unpacked `NetData`."""
        words = list(pzd) + [0] * (layout.pzd - len(pzd))
        request = Telegram(address, AddressMode.NORMAL, layout.pack(pkw, words))
        answer = Telegram.decode(self.exchange(request.encode()))
        assert answer.address == address
        return layout.unpack(answer.data)


def frame(adr: int, data: bytes | str) -> bytes:
    """A telegram with any ADR byte (also the undefined ones) and a correct BCC."""
    net = bytes.fromhex(data.replace(" ", "")) if isinstance(data, str) else data
    head = bytes((0x02, len(net) + 2, adr)) + net
    return head + bytes((bcc(head),))
