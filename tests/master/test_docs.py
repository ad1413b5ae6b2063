"""The script examples of README.md and docs/master.md run as printed (against a simulated
drive behind a pty instead of /dev/ttyUSB0)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from conftest import ROOT
from master.conftest import SimulatorThread
from pyuss.master import sync
from pyuss.protocol.layout import Layout

BLOCK = re.compile(r"```python\n(.*?)```", re.S)


def blocks(name: str) -> list[str]:
    return BLOCK.findall((ROOT / name).read_text(encoding="utf-8"))


@pytest.mark.parametrize(
    ("name", "number"), [("README.md", 0), ("docs/master.md", 0), ("docs/master.md", 1)]
)
def test_script_examples_run(name: str, number: int, capsys: pytest.CaptureFixture[str]) -> None:
    code = blocks(name)[number]
    with SimulatorThread([(5, "generic", Layout(3, 2))], baud=19200) as sim:
        with sync.Master(sim.paths[0], baud=19200, layout="3,2") as bus:
            bus.drive(5).write(462, 0.1)  # a short ramp (0.1 s), so that the example finishes soon
        source = code.replace('"/dev/ttyUSB0"', repr(sim.paths[0]))
        exec(compile(source, f"{name} example {number}", "exec"), {"__name__": "__main__"})
    assert "16384" in capsys.readouterr().out
    assert Path(name).suffix == ".md"
