"""Master throughput and parameter-job latency on the virtual bus.

For 9600, 38400 and 187500 baud and 1 or 31 simulated drives (generic profile, PKW 3 + PZD 2,
14-character telegrams; one `SlaveServer` serves all drives, as a simulator process would):

- Exchanges per second in cyclic operation, against the wire limit of the specification: one
  exchange is at least request + start pause (the shortest response delay, A 5.2.1.1) + answer
  + start pause (before the next request, A 5.1.2) = 14 + 2 + 14 + 2 = 32 character times. The
  simulator's real turnaround (end of request to start of answer, from the master's response
  time statistics) is shown separately, with the limit it leaves.
- Parameter-job latency: jobs ("read P52" / "read P18" alternately, so that no "no job" guard
  is needed between them) submitted one after the other to one drive while the master cycles;
  from submission to answer, median and 99th percentile in milliseconds and in poll cycles.

Everything runs on one event loop in one process: master, bus and simulator share the CPU, so
the figures are a floor for a master talking to real drives.
"""

from __future__ import annotations

import asyncio
import logging
import statistics
import time

from pyuss.bus import VirtualBus
from pyuss.drive import SimulatedDrive
from pyuss.master import Master
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.timing import char_time
from pyuss.slave import SlaveEngine, SlaveServer

LAYOUT = Layout(3, 2)
PROFILE = get_profile("generic")
TELEGRAM = 14
RUN_SECONDS = 1.5
JOB_SECONDS = 4.0
"""Time given to the job latency measurement (at least 8 and at most 40 jobs)."""


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[max(0, min(len(ordered) - 1, round(q * len(ordered)) - 1))]


async def _measure(baud: int, drives: int) -> dict[str, float]:
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
            handles = [master.drive(a) for a in range(1, drives + 1)]
            await handles[-1].next_update(timeout=10)
            before = sum(s.exchanges for s in master.diagnostics().slaves)
            start = time.monotonic()
            await asyncio.sleep(RUN_SECONDS)
            elapsed = time.monotonic() - start
            diag = master.diagnostics()
            exchanges = sum(s.exchanges for s in diag.slaves) - before
            turnaround = statistics.median(
                s.response_time.median for s in diag.slaves if s.response_time.count
            )
            target = handles[0]
            latencies = []
            cycle = master.cycle_stats().achieved.mean
            jobs = max(8, min(40, int(JOB_SECONDS / cycle)))
            for n in range(jobs):
                t0 = time.monotonic()
                await target.read((52, 18)[n % 2])
                latencies.append(time.monotonic() - t0)
            timeouts = sum(s.timeouts for s in master.diagnostics().slaves)
    finally:
        stop.set()
        server.cancel()
        await asyncio.gather(server, return_exceptions=True)
        await bus.close()
    ct = char_time(baud)
    wire = (2 * TELEGRAM + 4) * ct
    real = 2 * TELEGRAM * ct + 2 * ct + turnaround
    return {
        "rate": exchanges / elapsed,
        "limit": 1 / wire,
        "turnaround": turnaround,
        "limit_real": 1 / real,
        "cycle": cycle,
        "job_median": statistics.median(latencies),
        "job_p99": _percentile(latencies, 0.99),
        "timeouts": timeouts,
    }


def main() -> None:
    logging.getLogger("pyuss").setLevel(logging.ERROR)
    print(
        f"{'baud':>6} {'drives':>6} {'exch/s':>8} {'wire limit':>10} {'ratio':>6}  "
        f"{'turnaround':>10} {'limit w/ it':>11} {'ratio':>6}  {'cycle':>8}  "
        f"{'job median':>15} {'job p99':>15}"
    )
    for baud in (9600, 38400, 187500):
        for drives in (1, 31):
            r = asyncio.run(_measure(baud, drives))
            cycle = r["cycle"]
            print(
                f"{baud:>6} {drives:>6} {r['rate']:>8.1f} {r['limit']:>10.1f} "
                f"{r['rate'] / r['limit']:>6.2f}  {r['turnaround'] * 1000:>8.2f}ms "
                f"{r['limit_real']:>11.1f} {r['rate'] / r['limit_real']:>6.2f}  "
                f"{cycle * 1000:>6.1f}ms  "
                f"{r['job_median'] * 1000:>7.1f}ms {r['job_median'] / cycle:>4.1f}cyc "
                f"{r['job_p99'] * 1000:>7.1f}ms {r['job_p99'] / cycle:>4.1f}cyc"
                + (f"  ({int(r['timeouts'])} timeouts)" if r["timeouts"] else "")
            )


if __name__ == "__main__":
    main()
