"""KS VARIO: parameter channel jobs and whole-cache multiplexer transfers, in-process."""

from __future__ import annotations

import asyncio
import time

from pyuss.ksvario.coupler import CacheSelection, Coupler
from pyuss.ksvario.dp.fdl import Frame, FrameReceiver
from pyuss.ksvario.master import KsVarioMaster, LocalLink
from pyuss.ksvario.modules import Configuration


async def _run() -> None:
    sel = CacheSelection(
        free_read=tuple((1, d) for d in range(120)), per_channel_read=tuple(range(32))
    )
    for modules in (["A.1", "A.3"], ["A.1", "A.6"], ["A.1", "A.2", "B.5", "B.5", "B.5"]):
        coupler = Coupler(selection=sel)
        conf = Configuration(modules)
        coupler.configure(conf)
        master = KsVarioMaster(LocalLink(coupler), conf)
        t0 = time.perf_counter()
        await master.read_cache(1, 1080)
        dt = time.perf_counter() - t0
        print(
            f"read 1080 cache words via {modules[1]:4}: "
            f"{master.cycles:5} cycles, {dt * 1e3:7.1f} ms"
        )
    before = master.cycles
    t0 = time.perf_counter()
    jobs = 200
    for _ in range(jobs):
        await master.read(0x8CD2, 4)
    dt = time.perf_counter() - t0
    print(
        f"parameter channel: {jobs} reads of 4 reals in {dt * 1e3:.1f} ms "
        f"({dt / jobs * 1e6:.0f} us per job, "
        f"{(master.cycles - before) / jobs:.0f} bus cycles per job)"
    )


def main() -> None:
    asyncio.run(_run())
    raw = Frame(0x68, 5, 2, 0x5D, bytes(32)).encode() * 2000
    rx = FrameReceiver()
    t0 = time.perf_counter()
    n = len(rx.feed(raw))
    dt = time.perf_counter() - t0
    print(f"FDL receiver: {n} frames in {dt * 1e3:.1f} ms ({len(raw) / dt / 1e6:.1f} MB/s)")


if __name__ == "__main__":
    main()
