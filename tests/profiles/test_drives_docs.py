"""docs/drives.md stays true: its commands and its quick-commissioning script run as written."""

from __future__ import annotations

import contextlib
import io
import re
import shlex
import signal
import subprocess
import sys
from pathlib import Path

from support.processes import line_within

DOC = Path(__file__).resolve().parents[2] / "docs" / "drives.md"
TIMEOUT = 30


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)


def _argv(command: str) -> list[str]:
    words = shlex.split(command)
    if words[0] == "uss":
        return [sys.executable, "-m", "pyuss.cli.main", *words[1:]]
    assert words[0] == "python"
    return [sys.executable, *words[1:]]


def test_the_console_examples_run_as_written() -> None:
    # the coverage example is run by tests/profiles/test_manual_lists.py
    blocks = [b for b in _blocks("console") if "pyuss.profiles.coverage" not in b]
    assert len(blocks) == 2  # the V20's and the G120C's BICO input
    for block in blocks:
        _run_console(block)


def _run_console(block: str) -> None:
    steps: list[tuple[str, list[str]]] = []
    for line in block.splitlines():
        if line.startswith("$ "):
            steps.append((line[2:], []))
        else:
            steps[-1][1].append(line)
    background: list[subprocess.Popen[str]] = []
    try:
        for command, expected in steps:
            if command.endswith(" &"):
                proc = subprocess.Popen(
                    _argv(command[:-2]), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
                )
                background.append(proc)
                assert line_within(proc.stdout, TIMEOUT, command), command
                continue
            done = subprocess.run(
                _argv(command), capture_output=True, text=True, timeout=TIMEOUT, check=False
            )
            assert done.returncode == 0, (command, done.stderr)
            for line in expected:
                assert line in done.stdout.splitlines(), (command, line, done.stdout)
            if command.startswith("uss scan"):
                assert "SINAMICS V20" in done.stdout
    finally:
        for proc in background:
            proc.send_signal(signal.SIGTERM)
            proc.communicate(timeout=TIMEOUT)


def test_the_quick_commissioning_script_runs() -> None:
    (example,) = _blocks("python")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(example, str(DOC), "exec"), {"__name__": "__main__"})
    assert out.getvalue().strip() == "P0010 = 0, r0313 = 2"
    text = DOC.read_text(encoding="utf-8")
    assert "It prints `P0010 = 0, r0313 = 2`" in text
