"""Running a `Monitor` on transports (live) or on a capture (replay).

`watch` reads every transport in its own task and feeds what comes to the monitor; when a
port is quiet it tells the monitor that time has passed (`Monitor.advance`), ``lag``
seconds behind the transport's clock, because bytes on the wire reach the program late (USB
adapters, the event loop): a chunk stamped before ``clock() - lag`` is taken to have
arrived by then.

The monitor never sends. `watch` sees its ports only through `Listener`, which can open, read
and close a transport and has no way to write to it; ``uss monitor`` opens its ports through
it as well. A serial port is opened with RTS off, so an adapter that switches its RS-485
driver with RTS (`pyuss.transport.RS485Mode.RTS`: RTS on = sending) stays receiving; a
``bus://`` station joins listen-only (the command sees to that).

`replay` runs a capture through a monitor: frames of a monitor capture are paired and decoded
again, characters of a bus recording are framed first.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterator, Sequence

from pyuss._tasks import cancel_and_wait
from pyuss.monitor.core import Monitor
from pyuss.monitor.model import Exchange
from pyuss.monitor.records import Capture
from pyuss.transport.base import Chunk, Transport
from pyuss.transport.serialport import SerialTransport

__all__ = ["LAG", "TICK", "Listener", "replay", "watch"]

LAG = 0.05
"""How far behind the clock the monitor is told time has passed (seconds)."""
TICK = 0.02
"""How often a quiet port tells the monitor that time passes (seconds)."""


class Listener:
    """A transport the monitor listens to: open, read, close, and nothing to send with."""

    __slots__ = ("_transport",)

    def __init__(self, transport: Transport) -> None:
        if isinstance(transport, SerialTransport):
            transport.port.rts = False  # applied when the port opens
        self._transport = transport

    async def open(self) -> None:
        await self._transport.open()

    async def close(self) -> None:
        await self._transport.close()

    async def read(self, timeout: float | None = None) -> Chunk | None:
        return await self._transport.read(timeout)

    def clock(self) -> float:
        return self._transport.clock()

    @property
    def exact_timestamps(self) -> bool:
        """Whether the port stamps bytes with their time on the line (see
        `pyuss.transport.base.Transport.exact_timestamps`)."""
        return self._transport.exact_timestamps


async def watch(
    monitor: Monitor,
    transports: Sequence[Transport | Listener],
    on_exchanges: Callable[[list[Exchange]], None],
    stop: asyncio.Event,
    *,
    lag: float = LAG,
    tick: float = TICK,
) -> None:
    """Feed ``transports`` (port 0, port 1) to ``monitor`` until ``stop`` is set, handing
    every batch of finished exchanges to ``on_exchanges``; then report what is still open.
    A `pyuss.errors.TransportError` of a port ends the watch and is raised."""
    if len(transports) != monitor.ports:
        raise ValueError(f"the monitor has {monitor.ports} port(s), got {len(transports)}")
    listeners = [t if isinstance(t, Listener) else Listener(t) for t in transports]

    async def read(port: int, transport: Listener) -> None:
        while not stop.is_set():
            chunk = await transport.read(tick)
            if chunk is not None:
                out = monitor.feed(chunk.data, chunk.timestamp, chunk.errors, port=port)
            else:
                out = monitor.advance(transport.clock() - lag, port=port)
            if out:
                on_exchanges(out)

    tasks = [asyncio.create_task(read(i, t)) for i, t in enumerate(listeners)]
    stopper = asyncio.create_task(stop.wait())
    try:
        done, _ = await asyncio.wait([*tasks, stopper], return_when=asyncio.FIRST_COMPLETED)
        for task in done:
            if task is not stopper:
                task.result()  # a port failed: raise its error
    finally:
        for task in [*tasks, stopper]:
            task.cancel()
        for task in [*tasks, stopper]:
            await cancel_and_wait(task)
    out = monitor.finish()
    if out:
        on_exchanges(out)


def replay(capture: Capture, monitor: Monitor) -> Iterator[Exchange]:
    """The exchanges of ``capture`` as ``monitor`` decodes them, in order. Frames are taken
    in time order, whatever their order in the file (pcapng allows any, and merged or edited
    captures have them)."""
    for chunk in capture.chunks:
        yield from monitor.feed(chunk.data, chunk.timestamp, chunk.errors)
    for record in sorted(capture.records, key=lambda r: r.frame.start):
        yield from monitor.add_frame(record.frame, record.layout)
    yield from monitor.finish()
