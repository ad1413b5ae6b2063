"""Runs the console sessions of a docs page as written: ``$ uss ...`` lines through the ``uss``
command (in this process), ``$ head``/``$ grep`` lines through the shell, and compares what they
print with the lines that follow in the page. A line ``$ uss simulate ... &`` is the
simulator the test started; its device stands in the page as ``/dev/pts/7``. ``...`` in the
expected output stands for any lines; dates print as they are and are compared as ``DATE``."""

from __future__ import annotations

import re
import shlex
import subprocess
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

DEVICE = "/dev/pts/7"
DATE = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00")
BLOCK = re.compile(r"```console\n(.*?)```", re.S)


@dataclass
class Step:
    command: str
    expected: list[str] = field(default_factory=list)


def steps(page: Path) -> list[Step]:
    found: list[Step] = []
    for block in BLOCK.findall(page.read_text(encoding="utf-8")):
        for line in block.splitlines():
            if line.startswith("$ "):
                found.append(Step(line[2:]))
            elif found:
                found[-1].expected.append(line)
    return found


def matches(expected: list[str], got: list[str]) -> bool:
    pattern = "\n".join(
        ".*?" if line == "..." else re.escape(DATE.sub("DATE", line)) for line in expected
    )
    text = "\n".join(DATE.sub("DATE", line) for line in got)
    return re.fullmatch(pattern.replace("\n.*?\n", "(\n.*)?\n"), text, re.S) is not None


def run_step(
    step: Step, cwd: Path, device: str, uss: Callable[[list[str]], tuple[int, str]]
) -> list[str]:
    """The lines ``step`` prints (stdout, then stderr)."""
    command = step.command.replace(DEVICE, device)
    argv = shlex.split(command.split(" #")[0])
    if argv[0] == "uss":
        _code, out = uss(argv[1:])
    else:
        done = subprocess.run(command, shell=True, cwd=cwd, capture_output=True, text=True)
        out = done.stdout + done.stderr
    return [line.rstrip() for line in out.replace(device, DEVICE).splitlines()]
