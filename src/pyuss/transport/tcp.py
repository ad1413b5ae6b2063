"""TCP byte pipes: a transparent serial line over TCP, as RS-485/Ethernet converters offer.

`TcpTransport` is the client: it connects to a converter (or to `TcpServerTransport`, or to
the virtual bus's ``serve_tcp``) and moves raw bytes. `TcpServerTransport` listens and carries
the line to several peers at once, as a multi-connection serial device server does: what any
peer sends goes on the line, what the owner writes goes to every peer (two masters that talk at
once collide, as on RS-485). One idle or stuck peer never locks the others out: when all
``max_peers`` places are taken, a new peer replaces an idle one (its connection is closed): the
one that connected first of those that have sent nothing since they connected, else the one
that has been silent longest, for `IDLE_PEER` seconds at least. When every peer has spoken
within that time the new one is turned away, so a peer that connects again and again pushes no
master that talks off the line. A peer that does not read what it is sent (its socket holds
more than `MAX_PEER_BACKLOG` bytes) is disconnected rather than allowed to hold up the line.
What the owner writes while no peer is connected has no listener: it is counted in
``stats.dropped_out`` and logged, like talking on an empty line.

TCP knows no character timing and no line errors: chunks are stamped with the line's clock
(`pyuss.system.clock`) when the event loop reads them, and the delivered grouping of bytes is
the network's.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import time
from collections.abc import Callable, Iterable
from typing import Any

from pyuss._tasks import cancel_and_wait, stopping
from pyuss.errors import ConfigError, TransportError
from pyuss.system import clock
from pyuss.transport.queued import QueuedTransport

log = logging.getLogger(__name__)

_READ_SIZE = 65536

MAX_PEERS = 8
"""Peers a `TcpServerTransport` serves at once by default."""
MAX_PEER_BACKLOG = 1 << 16
"""Bytes a peer may leave unread in its socket before the server disconnects it."""
IDLE_PEER = 1.0
"""Seconds a peer that has spoken must have been silent to give its place to a new one."""


def check_endpoint(host: object, port: object, *, allow_zero: bool = False) -> tuple[str, int]:
    """Validate a host name and TCP port, raising `ConfigError` naming what is wrong."""
    if not isinstance(host, str) or not host:
        raise ConfigError(f"host must be a non-empty name or address, not {host!r}")
    low = 0 if allow_zero else 1
    if isinstance(port, bool) or not isinstance(port, int) or not low <= port <= 65535:
        raise ConfigError(f"TCP port must be an integer {low}..65535, not {port!r}")
    return host, port


def _no_delay(writer: asyncio.StreamWriter) -> None:
    sock = writer.get_extra_info("socket")
    if sock is not None:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


async def pump(
    reader: asyncio.StreamReader,
    deliver: Callable[[bytes, float], None],
) -> str:
    """Hand what ``reader`` receives to ``deliver`` until the stream ends; say why it ended."""
    try:
        while True:
            data = await reader.read(_READ_SIZE)
            if not data:
                return "connection closed by the peer"
            deliver(data, clock())
    except OSError as exc:
        return f"connection lost: {exc}"


async def close_writer(writer: asyncio.StreamWriter) -> None:
    writer.close()
    try:
        await writer.wait_closed()
    except OSError:
        pass
    except asyncio.CancelledError:
        if stopping():  # the caller's own stop, not the connection's
            raise


#: How long a closing server waits for its connections' handlers to end of themselves.
HANDLERS_WAIT = 1.0


async def end_handlers(
    writers: Iterable[asyncio.StreamWriter], tasks: Iterable[asyncio.Task[Any]]
) -> None:
    """End a server's connection handlers (``tasks``, run by ``asyncio.start_server`` or an
    ``asyncio.StreamReaderProtocol``) by closing their connections (``writers``) and waiting
    for them to return; one that is still running after `HANDLERS_WAIT` is cancelled. A
    handler left to be cancelled, as every task is when the loop ends, is logged by asyncio's
    stream protocol as an error with a traceback (Python 3.11): stopping a server that has
    peers connected must print nothing of the kind."""
    for writer in list(writers):
        writer.close()
    running = set(tasks)
    if not running:
        return
    _done, pending = await asyncio.wait(running, timeout=HANDLERS_WAIT)
    for task in pending:
        task.cancel()
    for task in pending:
        await cancel_and_wait(task)


class TcpTransport(QueuedTransport):
    """A TCP client carrying a serial line. See the module docstring."""

    def __init__(
        self,
        host: str,
        port: int,
        *,
        baud: int = 9600,
        echo: bool = False,
        connect_timeout: float = 5.0,
    ) -> None:
        super().__init__(baud=baud, echo=echo)
        self.host, self.port = check_endpoint(host, port)
        if connect_timeout <= 0:
            raise ConfigError(f"connect_timeout must be > 0 seconds, not {connect_timeout!r}")
        self._connect_timeout = connect_timeout
        self._writer: asyncio.StreamWriter | None = None
        self._task: asyncio.Task[None] | None = None

    def describe(self) -> str:
        return f"tcp://{self.host}:{self.port}"

    async def open(self) -> None:
        if self.is_open:
            return
        try:
            async with asyncio.timeout(self._connect_timeout):
                reader, writer = await asyncio.open_connection(self.host, self.port)
        except TimeoutError:
            raise TransportError(
                f"cannot connect to {self.describe()}: no answer in {self._connect_timeout} s"
            ) from None
        except OSError as exc:
            raise TransportError(f"cannot connect to {self.describe()}: {exc}") from None
        _no_delay(writer)
        try:
            await self._handshake(reader, writer)
        except BaseException:
            await close_writer(writer)
            raise
        self._writer = writer
        self._mark_open()
        self._task = asyncio.create_task(self._run(reader), name=f"uss {self.describe()}")

    async def _handshake(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        """What a subclass exchanges before the line is open (nothing here); raises
        `TransportError` to refuse."""

    async def _run(self, reader: asyncio.StreamReader) -> None:
        why = await pump(reader, self._deliver)
        if self.is_open:
            self._lose(TransportError(f"{self.describe()}: {why}"))

    async def write(self, data: bytes) -> None:
        self._check_writable()
        assert self._writer is not None
        self._arm_echo(bytes(data))
        try:
            self._writer.write(data)
            await self._writer.drain()
        except (OSError, RuntimeError) as exc:
            error = TransportError(f"{self.describe()}: write failed: {exc}")
            self._lose(error)
            raise error from None
        self.stats.bytes_out += len(data)

    async def close(self) -> None:
        if not self.is_open:
            return
        self._mark_closed()
        if self._task is not None:
            await cancel_and_wait(self._task)
            self._task = None
        if self._writer is not None:
            await close_writer(self._writer)
            self._writer = None


class TcpServerTransport(QueuedTransport):
    """A TCP server carrying a serial line to up to ``max_peers`` peers at once. See the module
    docstring.

    ``port=0`` picks a free port; `port` tells which once open.
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        baud: int = 9600,
        echo: bool = False,
        max_peers: int = MAX_PEERS,
    ) -> None:
        super().__init__(baud=baud, echo=echo)
        self.host, self._port = check_endpoint(host, port, allow_zero=True)
        if isinstance(max_peers, bool) or not isinstance(max_peers, int) or max_peers < 1:
            raise ConfigError(f"max_peers must be a positive integer, not {max_peers!r}")
        self.max_peers = max_peers
        self._server: asyncio.Server | None = None
        self._peers: dict[asyncio.StreamWriter, float] = {}
        """Connected peers and when each connected or last sent something (monotonic)."""
        self._spoke: set[asyncio.StreamWriter] = set()
        """The peers that have sent something."""
        self._peer_tasks: set[asyncio.Task[None]] = set()
        self._peer_event: asyncio.Event | None = None
        self._turning_away = False
        self.peers_served = 0
        self.peers_replaced = 0
        """Peers closed to make room for a new one (they had been silent longest)."""
        self.peers_dropped = 0
        """Peers closed because they did not read what the line sent them."""
        self.peers_refused = 0
        """Peers turned away: the server was closing, or every place was taken by a peer that
        spoke within `IDLE_PEER` seconds."""

    @property
    def port(self) -> int:
        """The TCP port listened on (the chosen one when 0 was asked for)."""
        return self._port

    @property
    def connected(self) -> bool:
        """Whether a peer is connected now."""
        return bool(self._peers)

    @property
    def peers(self) -> int:
        """How many peers are connected now."""
        return len(self._peers)

    def describe(self) -> str:
        return f"tcp server {self.host}:{self._port}"

    async def open(self) -> None:
        if self.is_open:
            return
        try:
            self._server = await asyncio.start_server(self._on_peer, self.host, self._port)
        except OSError as exc:
            raise TransportError(f"cannot listen on {self.host}:{self._port}: {exc}") from None
        self._port = self._server.sockets[0].getsockname()[1]
        self._peer_event = asyncio.Event()
        self._mark_open()

    async def wait_peer(self, timeout: float | None = None) -> bool:
        """Wait until a peer is connected; False when ``timeout`` passes first."""
        if self._peer_event is None:
            raise TransportError(f"{self.describe()} is not open")
        try:
            async with asyncio.timeout(timeout):
                await self._peer_event.wait()
        except TimeoutError:
            return False
        return True

    async def _on_peer(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        who = writer.get_extra_info("peername")
        if not self.is_open:
            self.peers_refused += 1
            await close_writer(writer)
            return
        if len(self._peers) >= self.max_peers:
            now = time.monotonic()
            # those that never spoke first (anonymous), then those silent longest
            idle = min(
                (
                    p
                    for p in self._peers
                    if p not in self._spoke or now - self._peers[p] >= IDLE_PEER
                ),
                key=lambda p: (p in self._spoke, self._peers[p]),
                default=None,
            )
            if idle is None:
                self.peers_refused += 1
                log.log(
                    logging.DEBUG if self._turning_away else logging.WARNING,  # once in a row
                    "%s: all %d places taken by peers that talk: %s turned away",
                    self.describe(),
                    self.max_peers,
                    who,
                )
                self._turning_away = True
                await close_writer(writer)
                return
            self.peers_replaced += 1
            log.info(
                "%s: %d peers connected: closed %s, silent for %.1f s, to serve %s",
                self.describe(),
                len(self._peers),
                idle.get_extra_info("peername"),
                time.monotonic() - self._peers[idle],
                who,
            )
            self._forget(idle)
            idle.close()
        _no_delay(writer)
        self._peers[writer] = time.monotonic()
        self.peers_served += 1
        self._turning_away = False
        assert self._peer_event is not None
        self._peer_event.set()
        log.info("%s: peer %s connected", self.describe(), who)
        task = asyncio.current_task()
        assert task is not None
        self._peer_tasks.add(task)

        def deliver(data: bytes, timestamp: float) -> None:
            if writer in self._peers:
                self._peers[writer] = timestamp
                self._spoke.add(writer)
                self._deliver(data, timestamp)

        try:
            why = await pump(reader, deliver)
            log.info("%s: peer %s left: %s", self.describe(), who, why)
        finally:
            self._peer_tasks.discard(task)
            self._forget(writer)
            await close_writer(writer)

    def _forget(self, writer: asyncio.StreamWriter) -> None:
        self._peers.pop(writer, None)
        self._spoke.discard(writer)
        if not self._peers and self._peer_event is not None:
            self._peer_event.clear()

    async def write(self, data: bytes) -> None:
        self._check_writable()
        if not self._peers:
            self.stats.dropped_out += len(data)
            log.info("%s: no peer connected: %d bytes not sent", self.describe(), len(data))
            return
        self._arm_echo(bytes(data))
        for peer in list(self._peers):
            if peer.is_closing():
                self._forget(peer)
                continue
            if peer.transport.get_write_buffer_size() > MAX_PEER_BACKLOG:
                self.peers_dropped += 1
                log.warning(
                    "%s: peer %s does not read what it is sent: disconnected",
                    self.describe(),
                    peer.get_extra_info("peername"),
                )
                self._forget(peer)
                peer.close()
                continue
            try:
                peer.write(data)
            except (OSError, RuntimeError) as exc:
                log.warning("%s: peer lost while writing: %s", self.describe(), exc)
                self._forget(peer)
        self.stats.bytes_out += len(data)

    async def close(self) -> None:
        if not self.is_open:
            return
        self._mark_closed()
        if self._server is not None:
            self._server.close()
        await end_handlers(self._peers, self._peer_tasks)
        for peer in list(self._peers):
            await close_writer(peer)
        self._peers.clear()
        if self._server is not None:
            await self._server.wait_closed()
            self._server = None
