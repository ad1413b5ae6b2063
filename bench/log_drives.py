"""The CSV log of every drive of a plant: `pyuss.datalog` as ``uss log`` uses it, for many drives.

``python bench/log_drives.py URL,URL,... DRIVES,DRIVES,... BAUD SECONDS DIRECTORY`` opens a
cyclic master per bus (``bus://`` URLs, a count of drives per bus, PKW 4 + PZD 2, the generic
profile) and logs the status word and the actual values of every drive into a CSV file of its
own in DIRECTORY, each with the `pyuss.datalog.DataLogger` and `pyuss.datalog.CsvLog` of
``uss log`` (which logs one drive, on a master of its own: a line has one master), at `RATE`
rows a second: more than a drive answers, so every answer is a row. It runs on the event loop
of ``uss log`` (`pyuss.loop`). It prints one JSON line: the drives' answers a second and the
process's CPU time per answer, over SECONDS after a second of warm-up, and the rows written.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import sys
import time
from pathlib import Path

from pyuss.datalog import CsvLog, DataLogger, parse_values
from pyuss.loop import run
from pyuss.master import CYCLIC, Drive, Master

RATE = 1000.0
"""Rows a second asked of each drive's log: at 38400 baud a drive alone on its bus answers
some 97 times a second, so each answer gives a row."""


async def measure(
    urls: list[str], sizes: list[int], baud: int, seconds: float, directory: Path
) -> dict[str, float]:
    quantities = parse_values(["status", "actual"])
    async with contextlib.AsyncExitStack() as stack:
        drives: list[list[Drive]] = []
        for url in urls:
            master = Master(url, baud=baud, profile="generic", layout="4,2", mode=CYCLIC)
            await stack.enter_async_context(master)
            drives.append([master.drive(address) for address in range(1, sizes[len(drives)] + 1)])
        loggers = [
            (bus, DataLogger(d, quantities, rate=RATE))
            for bus, handles in enumerate(drives, start=1)
            for d in handles
        ]
        await asyncio.gather(*(logger.prepare() for _, logger in loggers))  # a job per drive
        stop = asyncio.Event()
        tasks = []
        for bus, logger in loggers:
            path = directory / f"line{bus}-drive{logger.drive.address}.csv"
            log = CsvLog(path, logger.header())
            stack.callback(log.close)
            tasks.append(asyncio.create_task(logger.run(log, stop)))

        def answers() -> int:
            return sum(d.diagnostics().answers for handles in drives for d in handles)

        await asyncio.sleep(1.0)
        count, cpu, wall = answers(), time.process_time(), time.perf_counter()
        await asyncio.sleep(seconds)
        count = answers() - count
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        stop.set()
        results = await asyncio.gather(*tasks)
    return {
        "answers_per_s": count / wall,
        "cpu_us": cpu / max(1, count) * 1e6,
        "rows": sum(r.rows for r in results),
    }


def main() -> None:
    urls, sizes = sys.argv[1].split(","), [int(n) for n in sys.argv[2].split(",")]
    baud, seconds, directory = int(sys.argv[3]), float(sys.argv[4]), Path(sys.argv[5])
    print(json.dumps(run(measure(urls, sizes, baud, seconds, directory))))


if __name__ == "__main__":
    main()
