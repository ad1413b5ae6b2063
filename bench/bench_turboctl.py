"""pyuss against turboctl: the CPU a script pays per exchange, on the same simulator.

turboctl (PyPI ``turboctl``, installed by ``bench/requirements.txt``) controls a Leybold
TURBOVAC pump over USS with one fixed telegram: 24 characters, PKW 4 + PZD 6 words, address 0,
19200 baud by default, over a pyserial port; each call of ``turboctl.telegram.api`` writes one
request and reads its answer. One ``uss simulate --pty`` (generic profile, the drive profile of
the USS specification: its parameter 1 is an unsigned 16-bit word as turboctl's parameter 1 is,
so both read it) serves drive 0 with that layout at 19200 baud, and each client runs in a
process of its own, one after the other, on that pty:

- ``turboctl cyclic``: ``api.status(conn)`` in a loop (a telegram with "no job");
- ``turboctl acyclic``: ``api.read_parameter(conn, 1)`` in a loop;
- ``pyuss cyclic``: `pyuss.master.sync.Master` in acyclic mode, ``bus.exchange(0)`` per call:
  one telegram when the script asks for it, as turboctl sends;
- ``pyuss acyclic``: ``drive.read_raw(1)`` per call;
- the same two with the asyncio `pyuss.master.Master` (``await``), for comparison;
- ``alternate``: each client reads parameters 1 and 2 in turn (no goal): answers that cannot
  be confused, so pyuss sends each job at once, one telegram per read as turboctl.

Each client makes its calls for `SECONDS` (after `WARM_UP` calls) and prints its own CPU time
(`time.process_time`, the whole process: the threads of pyuss's serial port and sync facade
included) and wall time per call, and the telegrams it sent. Reading the same parameter
again, pyuss sends "no job" in between until the drive answers "no response" (an old answer
is never taken for a new job, USS specification C 4.2.1.1), so its parameter read is two
telegrams, turboctl's one (it takes the answer that comes): the goal is per call, what the
script pays, and the CPU per telegram is shown beside. Goal: pyuss's CPU per call at most 0.7
of turboctl's, cyclic and acyclic (sync facade); a pair that misses it is measured again, up
to three times in all (`common.best_of`).

The wall time per telegram is shown against the wire's limit at 19200 baud: request + start
pause + answer + start pause, 24 + 2 + 24 + 2 characters of 11 bits (USS specification
A 5.1.2, A 5.2.1.1). A pty carries no timing: the simulator paces the requests it reads and
writes each answer at once (docs/slave.md), so a client can go under the limit.

``python bench/bench_turboctl.py`` runs it alone; ``--quick`` (or ``USS_BENCH_QUICK=1``)
gives each client a second.
"""

from __future__ import annotations

import importlib.util
import itertools
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from common import Figure, best_of, pty_drives

from pyuss.protocol.timing import char_time

if TYPE_CHECKING:
    from pyuss.master.blocking import Master as BlockingMaster
    from pyuss.master.sync import Master as SyncMaster

BAUD = 19200
"""turboctl's default (its ``SERIAL_KWARGS``)."""
ADDRESS = 0
"""turboctl's telegrams always carry address 0."""
LAYOUT = "4,6"
TELEGRAM = 24
PNU = 1
QUICK = "--quick" in sys.argv or os.environ.get("USS_BENCH_QUICK") == "1"
SECONDS = 1.0 if QUICK else 3.0
WARM_UP = 20
GOAL = 0.7
CLIENTS = ("turboctl", "pyuss-blocking", "pyuss", "pyuss-asyncio")
MODES = ("cyclic", "acyclic", "alternate")
ALTERNATE = (1, 2)
"""Parameters read in turn in mode ``alternate``: unsigned 16-bit words in turboctl's list,
16-bit words of the generic profile."""
T = TypeVar("T")
INSTALL = "pip install -r bench/requirements.txt"


class Window:
    """The measured calls of a client: counted for `SECONDS` from its making."""

    def __init__(self) -> None:
        self.calls = 0
        self.cpu = time.process_time()
        self.wall = time.perf_counter()
        self.end = self.wall + SECONDS

    def more(self) -> bool:
        """Whether to make one call more (and count it)."""
        if time.perf_counter() >= self.end:
            return False
        self.calls += 1
        return True

    def result(self, telegrams: int) -> dict[str, float]:
        """Calls, CPU and wall seconds since the start, and the calls' telegrams of
        ``telegrams`` sent in all (the warm-up's taken off at the same rate)."""
        cpu, wall = time.process_time() - self.cpu, time.perf_counter() - self.wall
        share = telegrams * self.calls / (self.calls + WARM_UP)
        return {"calls": self.calls, "cpu": cpu, "wall": wall, "telegrams": share}


def _call(mode: str, status: Callable[[], T], read: Callable[[int], T]) -> Callable[[], T]:
    """What a client calls once per call in ``mode``: ``status()``, ``read(PNU)``, or ``read``
    of the parameters of `ALTERNATE` in turn."""
    if mode == "cyclic":
        return status
    if mode == "acyclic":
        return partial(read, PNU)
    pnus = itertools.cycle(ALTERNATE)
    return lambda: read(next(pnus))


def _turboctl(port: str, mode: str) -> dict[str, float]:
    import serial
    from turboctl.telegram import api

    # turboctl's own settings (its SERIAL_KWARGS) but no parity: a pty keeps none, and an 8E1
    # open of a pty whose settings are already 19200 8N1 is refused (`pyuss.transport.serialport`)
    with serial.Serial(port, baudrate=BAUD, parity=serial.PARITY_NONE, timeout=1) as conn:
        call = _call(mode, partial(api.status, conn), partial(api.read_parameter, conn))
        for _ in range(WARM_UP):
            call()
        window = Window()
        while window.more():
            call()
        return window.result(window.calls + WARM_UP)


def _pyuss(port: str, mode: str) -> dict[str, float]:
    from pyuss.master import ACYCLIC
    from pyuss.master.sync import Master

    return _pyuss_calls(Master(port, baud=BAUD, layout=LAYOUT, mode=ACYCLIC), mode)


def _pyuss_blocking(port: str, mode: str) -> dict[str, float]:
    from pyuss.master.blocking import Master

    return _pyuss_calls(Master(port, baud=BAUD, layout=LAYOUT), mode)


def _pyuss_calls(master: SyncMaster | BlockingMaster, mode: str) -> dict[str, float]:
    """A script's calls of ``master`` (the sync facade or the blocking master)."""
    with master as bus:
        drive = bus.drive(ADDRESS)
        call = _call(mode, partial(bus.exchange, ADDRESS), drive.read_raw)
        for _ in range(WARM_UP):
            call()
        window = Window()
        while window.more():
            call()
        return window.result(drive.counts().exchanges)


async def _pyuss_asyncio_run(port: str, mode: str) -> dict[str, float]:
    from pyuss.master import ACYCLIC, Master

    async with Master(port, baud=BAUD, layout=LAYOUT, mode=ACYCLIC) as bus:
        drive = bus.drive(ADDRESS)
        call = _call(mode, partial(bus.exchange, ADDRESS), drive.read_raw)
        for _ in range(WARM_UP):
            await call()
        window = Window()
        while window.more():
            await call()
        return window.result(drive.counts().exchanges)


def _pyuss_asyncio(port: str, mode: str) -> dict[str, float]:
    from pyuss.loop import run

    return run(_pyuss_asyncio_run(port, mode))


RUNNERS = {
    "turboctl": _turboctl,
    "pyuss-blocking": _pyuss_blocking,
    "pyuss": _pyuss,
    "pyuss-asyncio": _pyuss_asyncio,
}


def _client(client: str, port: str, mode: str) -> dict[str, float]:
    """One client in a process of its own; its figures per call."""
    out = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), client, port, mode],
        capture_output=True,
        text=True,
        check=True,
        timeout=SECONDS + 60,
        env={**os.environ, "USS_BENCH_QUICK": "1" if QUICK else ""},
    )
    r = json.loads(out.stdout.splitlines()[-1])
    return {
        "cpu": r["cpu"] / r["calls"],
        "wall": r["wall"] / r["calls"],
        "telegrams": r["telegrams"] / r["calls"],
        "calls": r["calls"],
    }


Results = dict[str, dict[str, float]]
"""Each client's figures per call."""


def _ratio(results: Results) -> float:
    """pyuss's CPU per call (the blocking master, a script's) over turboctl's."""
    return results["pyuss-blocking"]["cpu"] / results["turboctl"]["cpu"]


def _mode(port: str, mode: str, limit: float) -> list[Figure]:
    """The three clients in ``mode`` on ``port``: their rows printed, the figures."""
    goal = None if mode == "alternate" else GOAL

    def pair() -> Results:
        return {client: _client(client, port, mode) for client in ("turboctl", "pyuss-blocking")}

    results, runs = best_of(pair, lambda r: -_ratio(r), lambda r: goal is None or _ratio(r) <= goal)
    results["pyuss"] = _client("pyuss", port, mode)
    results["pyuss-asyncio"] = _client("pyuss-asyncio", port, mode)
    base = results["turboctl"]["cpu"]
    for client in CLIENTS:
        r = results[client]
        wall = r["wall"] / r["telegrams"]
        print(
            f"{client:<14} {mode:<9} {r['calls']:>6.0f} {r['telegrams']:>8.2f} "
            f"{r['cpu'] * 1e6:>6.0f} us {r['cpu'] / r['telegrams'] * 1e6:>5.0f} us "
            f"{wall * 1000:>6.2f} ms {limit / wall:>10.2f} {r['cpu'] / base:>11.2f}"
            + (f"  (best of {runs} runs)" if runs > 1 and client == "pyuss-blocking" else "")
        )
    sync, turbo = results["pyuss-blocking"], results["turboctl"]
    what = "exchange" if mode == "cyclic" else "parameter read"
    label = {"alternate": f"P{ALTERNATE[0]} and P{ALTERNATE[1]} in turn"}.get(mode, mode)
    figures = [
        Figure(f"pyuss/turboctl CPU per {what} ({label}, blocking)", _ratio(results), goal, False),
        Figure(f"pyuss/turboctl CPU per {what} ({label}, sync)", results["pyuss"]["cpu"] / base),
        Figure(
            f"pyuss/turboctl CPU per {what} ({label}, asyncio)",
            results["pyuss-asyncio"]["cpu"] / base,
        ),
    ]
    if sync["telegrams"] > 1.5 * turbo["telegrams"]:
        per_telegram = (sync["cpu"] / sync["telegrams"]) / (turbo["cpu"] / turbo["telegrams"])
        figures.append(Figure(f"pyuss/turboctl CPU per telegram ({label}, blocking)", per_telegram))
    if goal is not None:
        name = f"pyuss {mode} pty {BAUD} baud: wire limit / wall time per telegram"
        figures.append(Figure(name, limit / (sync["wall"] / sync["telegrams"])))
    return figures


def main() -> list[Figure]:
    if importlib.util.find_spec("turboctl") is None:
        print(f"turboctl is not installed: left out ({INSTALL} installs it; make bench does)")
        return []
    from importlib.metadata import version

    limit = (2 * TELEGRAM + 4) * char_time(BAUD)
    print(
        f"turboctl {version('turboctl')}; uss simulate --pty, drive {ADDRESS}, PKW 4 + PZD 6, "
        f"{BAUD} baud; wire limit {limit * 1000:.2f} ms per telegram; "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    print(
        f"{'client':<14} {'mode':<9} {'calls':>6} {'tel/call':>8} {'CPU/call':>9} "
        f"{'CPU/tel':>8} {'wall/tel':>9} {'limit/wall':>10} {'vs turboctl':>11}"
    )
    with pty_drives(BAUD, 1, layout=LAYOUT, addresses=(ADDRESS,)) as port:
        return [figure for mode in MODES for figure in _mode(port, mode, limit)]


if __name__ == "__main__":
    if len(sys.argv) == 4:  # a client: CLIENT PORT MODE
        print(json.dumps(RUNNERS[sys.argv[1]](sys.argv[2], sys.argv[3])))
    else:
        from common import table

        print(table(main()))
