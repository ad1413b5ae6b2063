"""``bus://HOST:PORT``: a station on a virtual bus in another process (``uss bus --bus-tcp``).

Unlike a raw TCP or pty station, it receives the bus's ideal character end times and its line
error flags (see `pyuss.bus.wire`), so a receiver measures the same gaps and sees the same
parity and framing errors as an in-process station. Timestamps are the bus's
the line's clock (`pyuss.system.clock`), which is the clock of every process on the same machine.

What the bus sends is decoded and queued as it arrives (an `asyncio.Protocol`, no reader task
in between), and `BusClientTransport.write_at` hands a telegram to the bus ahead of time with
the moment it is to start (send frames, `pyuss.bus.wire`): the master's start pause and the
simulator's response delay are kept on the bus's timeline to the microsecond, however late the
station's process wakes up.
"""

from __future__ import annotations

import asyncio
import json
from typing import cast

from pyuss.bus.wire import MAX_HELLO, FrameDecoder, check_name, encode_send
from pyuss.errors import ConfigError, ProtocolError, TransportError
from pyuss.system import clock
from pyuss.transport.base import LineError
from pyuss.transport.queued import QueuedTransport
from pyuss.transport.tcp import check_endpoint

_ANSWER_TIMEOUT = 5.0
_MAX_BACKLOG = 1 << 20
"""Unsent bytes at which the bus counts as not reading (the write fails)."""

Delivery = tuple[bytes, float, tuple[tuple[int, LineError], ...]]


class _Protocol(asyncio.Protocol):
    """The connection: the bus's answer line, then delivery frames straight to the owner."""

    def __init__(self, owner: BusClientTransport) -> None:
        self.owner = owner
        self.transport: asyncio.Transport | None = None
        self.answer: asyncio.Future[bytes] = asyncio.get_running_loop().create_future()
        self._head = bytearray()
        self._decoder: FrameDecoder | None = None
        self.early: list[Delivery] = []
        """Deliveries that came before the station was open (right after the answer)."""

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = cast(asyncio.Transport, transport)  # a stream transport (any loop's)

    def data_received(self, data: bytes) -> None:
        if self._decoder is None:
            self._head += data
            line, newline, rest = self._head.partition(b"\n")
            if not newline:
                if len(self._head) > MAX_HELLO:
                    self._fail("the bus's answer is too long")
                return
            self._decoder = FrameDecoder()
            if not self.answer.done():
                self.answer.set_result(bytes(line))
            data = bytes(rest)
            if not data:
                return
        try:
            deliveries = self._decoder.feed(data)
        except ProtocolError as exc:
            self._fail(str(exc))
            return
        owner = self.owner
        if not owner._open:  # (`is_open`, without the call: at every delivery)
            self.early += deliveries
            return
        for payload, timestamp, errors in deliveries:
            owner._deliver(payload, timestamp, errors)

    def connection_lost(self, exc: Exception | None) -> None:
        why = f"connection lost: {exc}" if exc else "connection closed by the bus"
        if not self.answer.done():
            self.answer.set_exception(ConnectionError(why))
        self.owner._connection_lost(why)

    def _fail(self, why: str) -> None:
        self.owner._connection_lost(why)
        if self.transport is not None:
            self.transport.close()


class BusClientTransport(QueuedTransport):
    """A ``bus://`` station.

    ``name``: the station's name on the bus (the bus picks one when ``None``).
    ``echo``: the station's adapter echoes: the bus sends its own characters back and this
    transport checks and removes them (a garbled echo reveals a collision, `EchoError`).
    ``bus_echo``: the bus sends them back and they are delivered as they are.
    ``listen_only``: a monitor that cannot send.
    ``hold``: the bus hands this station a run's first character when it ends and the rest
    of the run when the run ends (`pyuss.bus.core.Segment.attach`): two hand-overs per
    telegram, each a wake-up of this process, instead of three or four. A reader still
    sees a telegram begin (a master waiting for an answer), and every character keeps its
    end time on the line.
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        baud: int = 9600,
        name: str | None = None,
        echo: bool = False,
        bus_echo: bool = False,
        listen_only: bool = False,
        hold: bool = True,
        connect_timeout: float = 5.0,
    ) -> None:
        super().__init__(baud=baud, echo=echo)
        self.host, self.port = check_endpoint(host, port)
        if connect_timeout <= 0:
            raise ConfigError(f"connect_timeout must be > 0 seconds, not {connect_timeout!r}")
        if name is not None:
            check_name(name)
        self._connect_timeout = connect_timeout
        self.name = name
        self._bus_echo = bus_echo or echo
        self.listen_only = listen_only
        self.hold = hold
        self._protocol: _Protocol | None = None
        self.timed = False
        """Whether the bus takes send frames (`write_at` is then exact)."""
        self.hold_answer = False
        """The bus hands this station its answers whole where the master still takes them
        (``hold_until`` of `write_at`): one hand-over per answer instead of two."""

    @property
    def exact_timestamps(self) -> bool:
        return True  # the bus's own end times of the characters

    def describe(self) -> str:
        return f"bus://{self.host}:{self.port} station {self.name or '(unnamed)'}"

    async def open(self) -> None:
        if self.is_open:
            return
        loop = asyncio.get_running_loop()
        try:
            async with asyncio.timeout(self._connect_timeout):
                _, protocol = await loop.create_connection(
                    lambda: _Protocol(self), self.host, self.port
                )
        except TimeoutError:
            raise TransportError(
                f"cannot connect to {self.describe()}: no answer in {self._connect_timeout} s"
            ) from None
        except OSError as exc:
            raise TransportError(f"cannot connect to {self.describe()}: {exc}") from None
        try:
            await self._handshake(protocol)
        except BaseException:
            if protocol.transport is not None:
                protocol.transport.close()
            raise
        self._protocol = protocol
        self._mark_open()
        early, protocol.early = protocol.early, []
        for payload, timestamp, errors in early:
            self._deliver(payload, timestamp, errors)

    async def _handshake(self, protocol: _Protocol) -> None:
        assert protocol.transport is not None
        hello = {
            "name": self.name,
            "echo": self._bus_echo,
            "listen_only": self.listen_only,
            "timed": True,
            "hold": self.hold,
            "hold_answer": self.hold and not self._bus_echo,
        }
        try:
            protocol.transport.write(json.dumps(hello).encode() + b"\n")
            async with asyncio.timeout(_ANSWER_TIMEOUT):
                line = await protocol.answer
            answer = json.loads(line)
        except (OSError, TimeoutError, ValueError) as exc:
            raise TransportError(
                f"{self.describe()}: no valid answer from the bus: {exc or 'timeout'}"
            ) from None
        if not isinstance(answer, dict) or not answer.get("ok"):
            why = answer.get("error") if isinstance(answer, dict) else answer
            raise TransportError(f"{self.describe()}: the bus refused the station: {why}")
        if answer.get("baud") != self.baud:
            raise TransportError(
                f"{self.describe()}: the bus runs at {answer.get('baud')} baud, not {self.baud}"
            )
        self.name = str(answer.get("name"))
        self.timed = answer.get("timed") is True
        self.hold_answer = answer.get("hold_answer") is True

    def _connection_lost(self, why: str) -> None:
        if self.is_open:
            self._lose(TransportError(f"{self.describe()}: {why}"))

    async def write(self, data: bytes) -> None:
        self._send(bytes(data), 0.0)

    async def write_at(self, data: bytes, start: float, hold_until: float | None = None) -> None:
        """Like `write`, but the first character starts at ``start`` (monotonic seconds) if
        that is later. A bus without send frames gets the bytes at that moment instead.
        ``hold_until``: the answer to this telegram is still taken if its first character is
        handed over by then, so the bus may hand it over whole (`hold_answer`, a bus that
        offers it)."""
        if not self.timed:
            from pyuss.loop import sleep_until

            await sleep_until(start, clock)
            start = 0.0
        self._send(bytes(data), start, hold_until if self.hold_answer else None)

    def _send(self, data: bytes, start: float, hold_until: float | None = None) -> None:
        if self.listen_only:
            raise TransportError(f"{self.describe()} is listen-only: it cannot send")
        if self._failure is not None or not self._open:
            self._check_writable()  # raises
        protocol = self._protocol
        assert protocol is not None and protocol.transport is not None
        transport = protocol.transport
        if transport.is_closing() or transport.get_write_buffer_size() > _MAX_BACKLOG:
            error = TransportError(f"{self.describe()}: write failed: the bus does not read")
            self._lose(error)
            raise error
        if self._echo:  # (what `_arm_echo` looks at first, without the call)
            self._arm_echo(data)
        if not self.timed:
            transport.write(data)
        elif hold_until is None:
            transport.write(encode_send(start, data))
        else:  # a send frame without characters: the moment the answer is held until
            transport.write(encode_send(start, data) + encode_send(hold_until, b""))
        self.stats.bytes_out += len(data)

    async def close(self) -> None:
        if not self.is_open and self._protocol is None:
            return
        self._mark_closed()
        protocol, self._protocol = self._protocol, None
        if protocol is not None and protocol.transport is not None:
            protocol.transport.close()
