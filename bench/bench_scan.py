"""``uss scan`` speed: addresses 0-31 with every layout the profile allows, at one rate.

``uss bus`` and ``uss simulate`` (two generic drives, addresses 3 and 17, PKW 3 + PZD 2) run as
processes, the scan on a master over ``bus://`` in this one. The wire time of the probes is
what the line needs for them at the least: each request with the start pause before it, and
its answer or, for an address that stays silent, the response window (20 ms, A 5.2.1.1).
The goal: the scan takes at most 1.3 times that (a scan that misses it is run again, up to
three times in all, and the best counts). A silent address is the bulk of it: the
master waits its response window plus its latency on the virtual bus (4 ms) for each layout.
"""

from __future__ import annotations

import functools
import logging
import time

from common import Figure, best_of, bus_and_drives

from pyuss.loop import run
from pyuss.master.scan import Progress, probe_layouts, scan
from pyuss.profiles import get_profile
from pyuss.transport.url import open_transport

BAUDS = (9600, 187500)
GOAL = 1.3


def _scan(baud: int) -> tuple[float, float, list[int], int]:
    """One scan: (seconds, wire time of its probes, addresses found, probes)."""
    with bus_and_drives(baud, 0, addresses=(3, 17)) as url:
        seen: list[Progress] = []
        began = time.monotonic()
        found = run(
            scan(
                lambda b: open_transport(url, baud=b),
                [baud],
                range(32),
                on_progress=seen.append,
            )
        )
        took = time.monotonic() - began
    return took, seen[-1].wire, [f.address for f in found], seen[-1].done


def main() -> list[Figure]:
    logging.getLogger("pyuss").setLevel(logging.ERROR)
    figures = []
    layouts = len(probe_layouts(get_profile("generic")))
    for baud in BAUDS:
        (took, wire, found, probes), runs = best_of(
            functools.partial(_scan, baud), lambda r: -r[0] / r[1], lambda r: r[0] / r[1] <= GOAL
        )
        print(
            f"scan 0-31 at {baud:>6} baud, {layouts} layouts: {probes} probes, "
            f"found {found}, {took:.2f} s for {wire:.2f} s of wire time (x{took / wire:.2f})"
            + (f" (best of {runs} runs)" if runs > 1 else "")
        )
        figures.append(
            Figure(
                f"uss scan 0-31 at {baud} baud: time over the wire time of its probes",
                took / wire,
                GOAL,
                at_least=False,
            )
        )
    return figures


if __name__ == "__main__":
    from common import table

    print(table(main()))
