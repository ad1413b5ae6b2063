"""Start-up: how long ``uss --help``, ``uss decode`` and ``uss read`` take as whole processes,
beyond the interpreter's own start (``python -c pass``).

Each is run 7 times and the quickest run counts (the machine's other load only ever adds; a
command over its goal gets up to two more rounds of 7). The
modules are compiled first (as an installed package has them), so the figure is what a user
sees from the second run on. ``uss read`` reads P52 of a simulated drive through ``uss bus``
at 187500 baud: its figure includes opening the line, the parameter job (a few milliseconds on
the wire) and closing.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import time
from pathlib import Path

from common import Figure, best_of, bus_and_drives

RUNS = 7
GOAL = 0.150
HEX = "02 0C 05 10 34 00 00 00 00 04 7E 00 00 55"


def _uss() -> list[str]:
    script = Path(sys.executable).with_name("uss")
    return [str(script)] if script.exists() else [sys.executable, "-m", "pyuss.cli.main"]


def _quickest(argv: list[str], env: dict[str, str]) -> float:
    best = float("inf")
    for _ in range(RUNS):
        began = time.perf_counter()
        done = subprocess.run(argv, capture_output=True, env=env, check=False)
        best = min(best, time.perf_counter() - began)
        if done.returncode not in (0, 1):
            raise RuntimeError(f"{argv} failed: {done.stderr.decode(errors='replace')}")
    return best


def main() -> list[Figure]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    uss = _uss()
    figures = []
    with bus_and_drives(187500, 1) as url:
        commands = {
            "uss --help": [*uss, "--help"],
            "uss decode": [*uss, "decode", HEX, "--layout", "3,2"],
            "uss read": [*uss, "read", "1", "52", "--port", url, "--baud", "187500"],
        }
        for argv in commands.values():  # compile once, as an installed package is
            subprocess.run(argv, capture_output=True, env=env, check=False)
        bare = _quickest([sys.executable, "-c", "pass"], env)
        print(f"python -c pass: {bare * 1000:.0f} ms")
        for label, argv in commands.items():
            took, runs = best_of(
                functools.partial(_quickest, argv, env),
                lambda t: -t,
                lambda t: t - bare <= GOAL,
            )
            own = took - bare
            print(
                f"{label:<12} {took * 1000:6.0f} ms, {own * 1000:4.0f} ms of its own"
                + (f" (best of {runs} rounds)" if runs > 1 else "")
            )
            figures.append(
                Figure(f"{label}: start of its own", own * 1000, GOAL * 1000, False, "ms", 0)
            )
    return figures


if __name__ == "__main__":
    from common import table

    print(table(main()))
