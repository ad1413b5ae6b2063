"""Stations in other processes: each a pseudo-terminal or a TCP connection.

`serve_pty` opens ptys; a program opens a pty's device path as a serial port and is a station
(named ``pty1``, ``pty2``, ...). The pty carries no timing: what the program writes is put on
the line when the bus reads it, and what the line delivers is written to the pty at its
(real) delivery time.

`serve_tcp` listens on a TCP port; every connection is a station for as long as it lasts.
Raw connections (any serial-over-TCP client: pyuss ``tcp://``, pyserial ``socket://``) are
named ``tcp1``, ``tcp2``, ... and carry bytes only. Framed connections (``framed=True``, for
pyuss ``bus://`` clients, see `pyuss.bus.wire`) keep the ideal timestamps and the line error
flags of every delivery and let the client choose its name, echo and listen-only mode.

Raw stations are anonymous: when all 32 sending places of the bus are taken, a raw station that
has sent nothing since it connected, else the one silent longest (at least
`pyuss.bus.core.EVICT_IDLE` seconds), is disconnected to make room for a new station, so idle
raw connections never lock ``bus://`` masters out, nor do new ones push out one that talks.
What a station sends beyond its queue (`pyuss.bus.core.MAX_QUEUE`, `PTY_QUEUE` for a pty)
is dropped; what it had not sent when it leaves is dropped too. A socket that does not read
what the bus sends it loses what comes next once `MAX_BACKLOG` bytes wait in it (besides the
kernel's `SEND_BUFFER`), counted in its station's ``stats.dropped_out`` and logged once.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
import socket
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from pyuss._tasks import cancel_and_wait
from pyuss.bus.core import Segment, Station
from pyuss.bus.wire import MAX_AHEAD, MAX_DATA, SendDecoder, encode_frame, read_hello
from pyuss.errors import ConfigError, ProtocolError, TransportError
from pyuss.system import clock
from pyuss.transport.base import LineError
from pyuss.transport.pty import PtyPort
from pyuss.transport.tcp import check_endpoint, close_writer, end_handlers

log = logging.getLogger(__name__)

#: Characters a pty station may have waiting for or on the line: one telegram of the longest
#: (STX, LGE, ADR, 252 net bytes, BCC). The bus cannot see a pty's program leave (it holds the
#: pty open itself), so what a program wrote and did not wait for costs later ones at most
#: one telegram time; a USS station sends one telegram at a time.
PTY_QUEUE = 256
#: A station whose socket has this much unsent data loses what comes next (it does not read).
MAX_BACKLOG = 1 << 20
#: The kernel's send buffer of a station's socket (bytes; some seconds of a busy line).
SEND_BUFFER = 1 << 16
_HELLO_TIMEOUT = 5.0


Echo = bool | Collection[str]
"""Which stations hear their own characters: all (True), none (False) or those named."""


class _Reader(asyncio.StreamReader):
    """A stream reader that hands what arrives straight to `direct` once that is set (no task
    to wake up in between: a telegram reaches the line one turn of the event loop sooner).
    Reading it then returns what had arrived before, and b"" at the end of the connection."""

    direct: Callable[[bytes], None] | None = None

    def feed_data(self, data: Any) -> None:
        if self.direct is None:
            super().feed_data(data)
        elif data:
            self.direct(bytes(data))


def _hears_own(echo: Echo, name: str) -> bool:
    if isinstance(echo, bool):
        return echo
    return name == echo if isinstance(echo, str) else name in echo


def _free_name(bus: Segment, prefix: str) -> str:
    for i in itertools.count(1):
        name = f"{prefix}{i}"
        if name not in bus.stations:
            return name
    raise AssertionError("unreachable")


async def serve_pty(bus: Segment, n: int, *, echo: Echo = False) -> list[str]:
    """Open ``n`` ptys as stations; return their device paths. ``echo``: True for every pty,
    or the names of the ptys (``pty1``, ...) that hear their own characters."""
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigError(f"number of ptys must be a positive integer, not {n!r}")
    paths = []
    for _ in range(n):
        pty = PtyPort(baud=bus.baud)
        await pty.open()
        name = _free_name(bus, "pty")

        def sink(
            data: bytes, _ts: float, _errors: tuple[tuple[int, LineError], ...], pty: PtyPort = pty
        ) -> None:
            if pty.is_open:
                pty.write_nowait(data)

        station = bus.attach(name, echo=_hears_own(echo, name), sink=sink)
        station.max_queue = PTY_QUEUE
        task = asyncio.create_task(_pty_in(bus, name, pty), name=f"uss bus {name}")

        async def closer(
            pty: PtyPort = pty, task: asyncio.Task[None] = task, name: str = name
        ) -> None:
            await cancel_and_wait(task)
            bus.detach(name)
            await pty.close()

        bus.closers.append(closer)
        paths.append(pty.device_path)
    return paths


async def _pty_in(bus: Segment, name: str, pty: PtyPort) -> None:
    while True:
        try:
            chunk = await pty.read()
        except TransportError as exc:
            log.warning("bus station %s: %s", name, exc)
            return
        if chunk is not None and name in bus.stations:
            bus.send(name, chunk.data)


async def serve_tcp(
    bus: Segment,
    host: str = "127.0.0.1",
    port: int = 0,
    *,
    framed: bool = False,
    echo: Echo = False,
) -> tuple[str, int]:
    """Listen for stations on ``host:port`` (0: any free port); return the address bound.
    ``echo`` (raw stations): True for every one, or the names (``tcp1``, ...) of those that
    hear their own characters; framed stations choose for themselves."""
    host, port = check_endpoint(host, port, allow_zero=True)
    writers: set[asyncio.StreamWriter] = set()
    handlers: set[asyncio.Task[Any]] = set()
    door = _Door()

    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        assert isinstance(reader, _Reader)  # made by `connection` below
        sock = writer.get_extra_info("socket")
        if sock is not None:  # (else the kernel lets a peer that does not read have megabytes)
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER)
        writers.add(writer)
        task = asyncio.current_task()
        assert task is not None
        handlers.add(task)
        try:
            if framed:
                await _framed_station(bus, reader, writer)
            else:
                await _raw_station(bus, reader, writer, echo, door)
        finally:
            writers.discard(writer)
            handlers.discard(task)
            await close_writer(writer)

    def connection() -> asyncio.StreamReaderProtocol:  # as asyncio.start_server makes them
        return asyncio.StreamReaderProtocol(_Reader(), handle)

    try:
        server = await asyncio.get_running_loop().create_server(connection, host, port)
    except OSError as exc:
        raise TransportError(f"cannot listen on {host}:{port}: {exc}") from None
    bound = server.sockets[0].getsockname()[1]

    async def closer() -> None:
        server.close()
        await end_handlers(writers, handlers)
        with contextlib.suppress(OSError):
            await server.wait_closed()

    bus.closers.append(closer)
    return host, bound


def _socket_sink(writer: asyncio.StreamWriter, *, framed: bool, station: list[Station]) -> Any:
    def sink(data: bytes, timestamp: float, errors: tuple[tuple[int, LineError], ...]) -> None:
        if writer.is_closing():
            return
        if writer.transport.get_write_buffer_size() > MAX_BACKLOG:
            if station:
                stats = station[0].stats
                if not stats.dropped_out:
                    log.warning(
                        "bus: station %s does not read what the bus sends it: what comes next "
                        "is dropped while %d bytes wait in its socket",
                        station[0].name,
                        MAX_BACKLOG,
                    )
                stats.dropped_out += len(data)
            return
        if not framed:
            writer.write(data)
            return
        for i in range(0, len(data), MAX_DATA):
            part = data[i : i + MAX_DATA]
            errs = tuple((p - i, f) for p, f in errors if i <= p < i + MAX_DATA)
            writer.write(encode_frame(timestamp, part, errs))

    return sink


@dataclass(slots=True)
class _Door:
    """The raw stations' way in of one `serve_tcp`."""

    turning_away: bool = False
    """Whether the last raw connection was turned away (the bus was full)."""


async def _raw_station(
    bus: Segment, reader: _Reader, writer: asyncio.StreamWriter, echo: Echo, door: _Door
) -> None:
    name = _free_name(bus, "tcp")
    holder: list[Station] = []
    try:
        station = bus.attach(
            name,
            echo=_hears_own(echo, name),
            sink=_socket_sink(writer, framed=False, station=holder),
        )
    except ConfigError as exc:
        # once until a station gets in again: a peer that connects again and again does
        # not fill the log
        log.log(
            logging.DEBUG if door.turning_away else logging.WARNING,
            "bus: turned away a TCP station: %s",
            exc,
        )
        door.turning_away = True
        return
    door.turning_away = False
    holder.append(station)
    station.evict = writer.close  # anonymous: gives its place when idle on a full bus
    log.info("bus: station %s connected from %s", name, writer.get_extra_info("peername"))
    await _pump_in(bus, station, reader)


async def _pump_in(
    bus: Segment,
    station: Station,
    reader: _Reader,
    frames: SendDecoder | None = None,
    hold_answer: bool = False,
) -> None:
    """Put what a station sends on the line: raw bytes, or send frames (`pyuss.bus.wire`), as
    it arrives (`_Reader`); returns when the connection ends or breaks the frame rules. With
    ``hold_answer`` a send frame without characters is the moment until which the station
    may be handed its answer whole (`Station.hold_answer`)."""
    name = station.name
    failed: list[Exception] = []

    def put(data: bytes) -> None:
        if failed or bus.stations.get(name) is not station or station.listen_only:
            return
        if frames is None:
            bus.send(name, data)
            return
        now = clock()
        try:
            for start, part in frames.feed(data):
                if not part and hold_answer:
                    station.hold_answer(min(start, now + MAX_AHEAD))
                    continue
                if start > now + MAX_AHEAD:
                    raise ProtocolError(
                        f"a send frame asks to start {start - now:.3f} s ahead "
                        f"(at most {MAX_AHEAD:g} s)"
                    )
                bus.send(name, part, at=start)
        except ProtocolError as exc:
            failed.append(exc)
            reader.direct = None
            reader.feed_eof()  # ends the reading below

    try:
        reader.direct = put
        # What came before, then the end of the connection.
        while data := await reader.read(65536):
            put(data)
        if failed:
            raise failed[0]
    except (OSError, ProtocolError) as exc:
        log.info("bus: station %s lost: %s", name, exc)
    finally:
        bus.detach(name, station)
        log.info("bus: station %s left", name)


async def _framed_station(bus: Segment, reader: _Reader, writer: asyncio.StreamWriter) -> None:
    def answer(item: dict[str, Any]) -> None:
        writer.write(json.dumps(item).encode() + b"\n")

    try:
        async with asyncio.timeout(_HELLO_TIMEOUT):
            line = await reader.readuntil(b"\n")
        hello = read_hello(line)
    except TimeoutError:
        answer({"ok": False, "error": f"bad hello: no line in {_HELLO_TIMEOUT:g} s"})
        return
    except asyncio.LimitOverrunError as exc:
        answer({"ok": False, "error": f"bad hello: no line end in {exc.consumed} bytes"})
        return
    except asyncio.IncompleteReadError as exc:  # the peer closed in the middle of its hello
        answer({"ok": False, "error": f"bad hello: cut off after {len(exc.partial)} bytes"})
        return
    except (ConfigError, OSError) as exc:
        answer({"ok": False, "error": f"bad hello: {exc}"})
        return
    timed, hold = hello.timed, hello.hold
    hold_answer = hold and timed and hello.hold_answer
    holder: list[Station] = []
    try:
        station = bus.attach(
            hello.name or _free_name(bus, "tcp"),
            echo=hello.echo,
            listen_only=hello.listen_only,
            sink=_socket_sink(writer, framed=True, station=holder),
            hold=hold,
        )
    except ConfigError as exc:
        answer({"ok": False, "error": str(exc)})
        return
    holder.append(station)
    answer(
        {
            "ok": True,
            "name": station.name,
            "baud": bus.baud,
            "timed": timed,
            "hold": hold,
            "hold_answer": hold_answer,
        }
    )
    log.info("bus: station %s connected (bus://)", station.name)
    await _pump_in(bus, station, reader, SendDecoder() if timed else None, hold_answer)
