"""Traffic generators for the monitor's tests: a scripted master and scripted slaves on the
virtual bus (2-wire: one bus; 4-wire: one bus per direction), recorded character by character.

They are not the thing under test: they only make real traffic, with the bus's seeded fault
injection, for the monitor to decode.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from pyuss.bus import FaultPlan, Recorder, VirtualBus
from pyuss.monitor import Exchange, Monitor
from pyuss.protocol import AddressMode, Layout, Pkw, Received, Receiver, Telegram
from pyuss.protocol.timing import char_time
from pyuss.transport.base import Chunk, Transport

REQ_52 = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")  # C 8.1 example 2
ANS_52 = bytes.fromhex("02 0C 05 10 34 00 00 40 00 02 31 00 00 5C")
LAYOUT = Layout(3, 2)


def request(address: int, pkw: Pkw | None, control: int = 0x047E, setpoint: int = 0) -> bytes:
    """A normal request with layout 3,2."""
    return Telegram(address, 0, LAYOUT.pack(pkw, (control, setpoint))).encode()


def answer(address: int, pkw: Pkw | None, status: int = 0x0231, actual: int = 0) -> bytes:
    """A normal answer with layout 3,2."""
    return Telegram(address, 0, LAYOUT.pack(pkw, (status, actual))).encode()


Answer = Callable[[Telegram], bytes | None]


def echo_job(status: int = 0x0231, actual: int = 0x1000) -> Answer:
    """A slave that answers every job with "parameter value (word)" = 1234 for its PNU."""

    def reply(tg: Telegram) -> bytes | None:
        job = LAYOUT.unpack(tg.data).pkw
        assert job is not None
        pkw = Pkw(0) if job.id == 0 else Pkw(1, job.pnu, values=(1234,))
        return answer(tg.address, pkw, status, actual)

    return reply


@dataclass
class Slave:
    """A slave at ``address``: ``reply`` makes its answer (None: no answer), sent ``delay``
    seconds after the request; ``broadcasts``: it answers broadcasts too (a fault);
    ``mirror``: it returns mirror telegrams unchanged (A 5.3) instead of calling ``reply``."""

    address: int
    reply: Answer = field(default_factory=echo_job)
    delay: float = 0.002
    broadcasts: bool = False
    mirror: bool = True


async def _slave_loop(station: Transport, out: Transport, slaves: Sequence[Slave]) -> None:
    rx = Receiver(station.baud)
    while True:
        chunk = await station.read(0.01)
        events = rx.feed(chunk.data, chunk.timestamp, chunk.errors) if chunk else []
        for event in events:
            if not isinstance(event, Received):
                continue
            tg = event.telegram
            for slave in slaves:
                if tg.mode.is_broadcast and not slave.broadcasts:
                    continue
                if not tg.mode.is_broadcast and slave.address != tg.address:
                    continue
                if slave.mirror and tg.mode is AddressMode.MIRROR:
                    data: bytes | None = event.raw
                else:
                    data = slave.reply(tg)
                if data is not None:
                    await asyncio.sleep(slave.delay)
                    await out.write(data)
                break


async def _master(
    tx: Transport,
    rx_station: Transport,
    bus: VirtualBus,
    requests: Sequence[bytes],
    wait: float,
    pause: float,
) -> None:
    rx = Receiver(tx.baud)
    for data in requests:
        await tx.write(data)
        await bus.drain()
        deadline = rx_station.clock() + wait
        while (left := deadline - rx_station.clock()) > 0:
            chunk = await rx_station.read(left)
            if chunk is not None and rx.feed(chunk.data, chunk.timestamp, chunk.errors):
                break
        await asyncio.sleep(pause)
        rx.reset()


@dataclass
class Line:
    """What a run produced: the chunks each monitor port heard (absolute monotonic times)."""

    baud: int
    ports: list[list[Chunk]]
    buses: list[VirtualBus]


async def drive(
    tx_bus: VirtualBus,
    rx_bus: VirtualBus,
    requests: Sequence[bytes],
    slaves: Sequence[Slave],
    *,
    wait: float = 0.06,
    pause: float = 0.01,
) -> None:
    """The master sends ``requests`` on ``tx_bus``; ``slaves`` answer on ``rx_bus`` (the same
    bus for a 2-wire line). Stations are attached for the run and detached after it."""
    four_wire = rx_bus is not tx_bus
    master = tx_bus.attach("master")
    slave_in = tx_bus.attach("slave")
    slave_out = rx_bus.attach("slave") if four_wire else slave_in
    master_in = rx_bus.attach("master") if four_wire else master
    stations = list({id(s): s for s in (master, slave_in, slave_out, master_in)}.values())
    for station in stations:
        await station.open()
    task = asyncio.create_task(_slave_loop(slave_in, slave_out, slaves))
    try:
        await _master(master, master_in, tx_bus, requests, wait, pause)
        await tx_bus.drain()
        await rx_bus.drain()
        await asyncio.sleep(0.01)
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
        for station in stations:
            await station.close()


async def run_line(
    requests: Sequence[bytes],
    slaves: Sequence[Slave],
    *,
    baud: int = 38400,
    faults: FaultPlan | None = None,
    faults_rx: FaultPlan | None = None,
    seed: int = 1,
    four_wire: bool = False,
    wait: float = 0.06,
    pause: float = 0.01,
) -> Line:
    """Run the master's ``requests`` against ``slaves`` and record the line(s)."""
    tx_bus = VirtualBus(baud, faults=faults, seed=seed)
    rx_bus = VirtualBus(baud, faults=faults_rx, seed=seed) if four_wire else tx_bus
    buses = [tx_bus, rx_bus] if four_wire else [tx_bus]
    recorders = [Recorder().attach(bus) for bus in buses]
    try:
        await drive(tx_bus, rx_bus, requests, slaves, wait=wait, pause=pause)
    finally:
        for bus in buses:
            await bus.close()
    ports = []
    for recorder, bus in zip(recorders, buses, strict=True):
        chunks = recorder.recording().chunks()
        ports.append([Chunk(c.data, c.timestamp + bus.epoch, c.errors) for c in chunks])
    return Line(baud, ports, buses)


def decode(line: Line, **options: object) -> tuple[list[Exchange], Monitor]:
    """Feed a recorded line to a monitor in arrival order; every exchange it reports."""
    monitor = Monitor(line.baud, four_wire=len(line.ports) == 2, **options)  # type: ignore[arg-type]
    feed = sorted(
        (
            (chunk.timestamp, port, chunk)
            for port, chunks in enumerate(line.ports)
            for chunk in chunks
        ),
        key=lambda item: (item[0], item[1]),
    )
    out: list[Exchange] = []
    for _, port, chunk in feed:
        out += monitor.feed(chunk.data, chunk.timestamp, chunk.errors, port=port)
    out += monitor.finish()
    return out, monitor


@dataclass
class Wire:
    """Feeds a monitor chunks at chosen times (seconds), as a transport stamps them."""

    monitor: Monitor
    t: float = 100.0
    out: list[Exchange] = field(default_factory=list)

    def send(self, data: bytes, gap: float, port: int = 0) -> float:
        """Idle ``gap`` seconds after the last byte, then ``data`` back to back; returns the
        start of its first byte."""
        start = self.t + gap
        self.t = start + len(data) * char_time(self.monitor.baud)
        self.out += self.monitor.feed(data, self.t, port=port)
        return start

    def finish(self) -> list[Exchange]:
        self.out += self.monitor.finish()
        return self.out
