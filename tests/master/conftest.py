"""Fixtures for master tests: a virtual bus with scripted slaves."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import Any

from master.scripted import ScriptedSlave
from pyuss.bus import FaultPlan, Recorder, VirtualBus
from pyuss.drive.simulated import SimulatedDrive
from pyuss.master import Master
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.receiver import Received, Receiver
from pyuss.slave import JobLatency, SlaveEngine, SlaveServer


@dataclass
class Setup:
    bus: VirtualBus
    master: Master
    slaves: dict[int, ScriptedSlave]
    recorder: Recorder | None


LAYOUT_32 = Layout(3, 2)


@asynccontextmanager
async def scripted_bus(
    addresses: Sequence[int] = (5,),
    *,
    baud: int = 38400,
    layout: Layout = LAYOUT_32,
    faults: FaultPlan | None = None,
    record: bool = False,
    **master_options: Any,
) -> AsyncIterator[Setup]:
    """A bus at ``baud`` with one scripted slave per address and a started master."""
    bus = VirtualBus(baud, faults=faults)
    recorder = Recorder().attach(bus) if record else None
    slaves = {a: await ScriptedSlave(bus, a, layout).start() for a in addresses}
    master = Master(bus.attach("master"), layout=layout, **master_options)
    try:
        async with master:
            yield Setup(bus, master, slaves, recorder)
    finally:
        for slave in slaves.values():
            await slave.stop()
        await bus.close()


def line_telegrams(recorder: Recorder, baud: int, sender: str = "master") -> list[Received]:
    """The telegrams ``sender`` put on the line, decoded from the recording (times in seconds
    since the bus started)."""
    receiver = Receiver(baud)
    out: list[Received] = []
    for record in recorder.records:
        if record.sender != sender:
            continue
        for event in receiver.feed(bytes((record.byte,)), record.t):
            if isinstance(event, Received):
                out.append(event)
    return out


@dataclass
class SimSetup:
    bus: VirtualBus
    master: Master
    engines: dict[int, SlaveEngine]
    recorder: Recorder | None


@asynccontextmanager
async def simulated_bus(
    drives: Sequence[tuple[int, str, Layout | None]],
    *,
    baud: int = 38400,
    record: bool = False,
    faults: FaultPlan | None = None,
    latency: JobLatency | None = None,
    **master_options: Any,
) -> AsyncIterator[SimSetup]:
    """A virtual bus with simulated drives ``(address, profile, layout)`` - each served by its
    own `SlaveServer` station, as separate devices on a line are - and a started master."""
    bus = VirtualBus(baud, faults=faults)
    recorder = Recorder().attach(bus) if record else None
    stop = asyncio.Event()
    engines: dict[int, SlaveEngine] = {}
    tasks = []
    for address, profile, layout in drives:
        drive = SimulatedDrive.from_profile(profile)
        engine = SlaveEngine(
            address, drive, get_profile(profile), layout=layout, latency=latency, failure_time=0
        )
        engines[address] = engine
        server = SlaveServer(bus.attach(f"drive{address}"), engine)
        tasks.append(asyncio.create_task(server.run(stop)))
    master = Master(bus.attach("master"), **master_options)
    try:
        async with master:
            yield SimSetup(bus, master, engines, recorder)
    finally:
        stop.set()
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        for engine in engines.values():
            engine.close()
        await bus.close()
