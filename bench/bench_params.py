"""Backup time of 200 parameters against the wire time of its jobs.

A simulated drive (the generic profile's file plus 200 uint16 parameters P1000..P1199, fixed
layout PKW 4 + PZD 2: 16-character telegrams) on the virtual bus at 9600 and 187500 baud; the
master in acyclic mode, as ``uss backup`` runs it, takes a backup of the 200 parameters
(`pyuss.commission.backup.take`: one "read" job each, answers typed through the parameter
book). The wire time of those jobs is what the line needs at the least: per job request + start
pause (the shortest response delay, A 5.2.1.1) + answer + start pause (before the next request,
A 5.1.2) = 16 + 2 + 16 + 2 = 36 character times of 11 bits. Goal: the backup within 1.5 times
the wire time. Master, bus and simulator share one event loop and CPU, so the figure is a floor
for a master talking to a real drive.
"""

from __future__ import annotations

import asyncio
import logging
import time

from pyuss.bus import VirtualBus
from pyuss.commission.backup import take
from pyuss.drive import SimulatedDrive
from pyuss.drive.loader import parse_database
from pyuss.master import ACYCLIC, Master
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.timing import char_time
from pyuss.slave import SlaveEngine, SlaveServer

COUNT = 200
FIRST = 1000
LAYOUT = Layout(4, 2)
TELEGRAM = 16
JOB_CHARS = TELEGRAM + 2 + TELEGRAM + 2
GOAL = 1.5

PARAMS = '[profile]\nextends = "generic"\nname = "bench"\n' + "".join(
    f'[[parameter]]\npnu = {pnu}\nname = "Value {pnu}"\ntype = "uint16"\ndefault = {pnu}\n'
    for pnu in range(FIRST, FIRST + COUNT)
)


async def _measure(baud: int) -> tuple[float, float, int]:
    db = parse_database(PARAMS, "bench")
    profile = get_profile("generic")
    bus = VirtualBus(baud)
    station = bus.attach("drive")
    await station.open()
    engine = SlaveEngine(
        3, SimulatedDrive(db, now=station.clock()), profile, layout=LAYOUT, failure_time=0
    )
    stop = asyncio.Event()
    server = asyncio.create_task(SlaveServer(station, engine).run(stop))
    try:
        async with Master(bus.attach("master"), layout=LAYOUT, mode=ACYCLIC) as master:
            drive = master.drive(3)
            drive.use_params(db)
            await drive.read(FIRST)  # the first answer known: no "no job" at the start
            pnus = list(range(FIRST, FIRST + COUNT))
            start = time.monotonic()
            backup = await take(drive, pnus=pnus)
            elapsed = time.monotonic() - start
            assert len(backup.entries) == COUNT and not backup.failed
            telegrams = drive.diagnostics().exchanges
    finally:
        stop.set()
        await server
        await bus.close()
    wire = COUNT * JOB_CHARS * char_time(baud)
    return elapsed, wire, telegrams


def main() -> None:
    logging.getLogger("pyuss").setLevel(logging.ERROR)
    print(f"backup of {COUNT} parameters (uint16, layout {LAYOUT}, acyclic), goal <= {GOAL}x wire")
    for baud in (9600, 187500):
        elapsed, wire, telegrams = asyncio.run(_measure(baud))
        ratio = elapsed / wire
        verdict = "ok" if ratio <= GOAL else "above goal"
        print(
            f"  {baud:>6} baud: {elapsed:7.3f} s, wire {wire:7.3f} s, ratio {ratio:5.2f}"
            f" ({verdict}), {telegrams} telegrams, {elapsed / COUNT * 1000:6.2f} ms/parameter"
        )


if __name__ == "__main__":
    main()
