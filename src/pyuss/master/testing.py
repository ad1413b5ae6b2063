"""Simulated drives for trying a master without hardware.

`simulated_drives` puts simulated drives (`pyuss.drive.SimulatedDrive` served by
`pyuss.slave.SlaveEngine`) on a `pyuss.bus.VirtualBus`, each from a station of its own as real
devices are, or all from one station that answers every address (``one_station=True``, as
``uss simulate`` serves them: one receiver of the line instead of one per drive, for demos and
benchmarks with many drives); a `pyuss.master.Master` on another station of the same bus then
talks to them with the line timing of the specification::

    bus = VirtualBus(38400)
    async with simulated_drives(bus, [(5, "generic", Layout(3, 2))]) as engines:
        async with Master(bus.attach("master"), layout="3,2") as master:
            print(await master.drive(5).read(52))

``engines`` maps each address to its engine; ``engines[5].drive`` is the simulated drive, to
change values "on its panel" (``drive.update(pnu, value)``) or look at its state. `uss demo`
and the tests of the master use it.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Sequence

from pyuss.bus import VirtualBus
from pyuss.drive.simulated import SimulatedDrive
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.slave import JobLatency, SlaveEngine, SlaveServer

__all__ = ["simulated_drives"]


@contextlib.asynccontextmanager
async def simulated_drives(
    bus: VirtualBus,
    drives: Sequence[tuple[int, str, Layout | None]],
    *,
    latency: JobLatency | None = None,
    failure_time: float = 0.0,
    one_station: bool = False,
) -> AsyncIterator[dict[int, SlaveEngine]]:
    """Serve ``drives`` - ``(address, profile name, layout or None for the profile's)`` - on
    ``bus`` until the block ends. ``latency``: how late the drives answer new parameter jobs;
    ``failure_time``: their telegram failure time in seconds (0: not watched); ``one_station``:
    one station (named ``drives``) answers every address."""
    stop = asyncio.Event()
    engines: dict[int, SlaveEngine] = {}
    tasks = []
    try:
        for address, profile, layout in drives:
            engine = SlaveEngine(
                address,
                SimulatedDrive.from_profile(profile),
                get_profile(profile),
                layout=layout,
                latency=latency,
                failure_time=failure_time,
            )
            engines[address] = engine
            if not one_station:
                server = SlaveServer(bus.attach(f"drive{address}"), engine)
                tasks.append(asyncio.create_task(server.run(stop)))
        if one_station and engines:
            server = SlaveServer(bus.attach("drives"), *engines.values())
            tasks.append(asyncio.create_task(server.run(stop)))
        yield engines
    finally:
        stop.set()
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        for engine in engines.values():
            engine.close()
