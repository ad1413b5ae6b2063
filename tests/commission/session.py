"""Runs the console sessions of a docs page as written: ``$ uss ...`` lines through the ``uss``
command (in this process), ``$ head``/``$ grep`` lines through the shell, and compares what they
print with the lines that follow in the page. A line ``$ uss simulate ... &`` is the
simulator the test started; its device stands in the page as ``/dev/pts/7``. ``...`` in the
expected output stands for any lines; dates print as they are and are compared as ``DATE``.
A page's ``## `` sections can run apart, each against its own simulator."""

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


def sections(page: Path) -> dict[str, str]:
    """The text of each ``## `` section of ``page`` by its title (the text before the first one
    under ``""``)."""
    parts = re.split(r"^## (.+)\n", page.read_text(encoding="utf-8"), flags=re.M)
    return {"": parts[0]} | dict(zip(parts[1::2], parts[2::2], strict=True))


def steps(page: Path, only: str | None = None, without: tuple[str, ...] = ()) -> list[Step]:
    """The session of ``page``: of its section titled ``only`` if given, else of every section
    but those titled in ``without``."""
    texts = sections(page)
    for title in (only, *without):
        assert title is None or title in texts, f"{page.name} has no section {title!r}"
    chosen = (
        [texts[only]] if only is not None else [t for k, t in texts.items() if k not in without]
    )
    found: list[Step] = []
    for block in BLOCK.findall("".join(chosen)):
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
