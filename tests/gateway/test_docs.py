"""The worked example of docs/gateway.md runs as printed (on a free port instead of 5020)."""

from __future__ import annotations

import re
import subprocess
import sys

from support.network import free_port
from support.paths import ROOT


def test_the_worked_example_runs_as_written() -> None:
    text = (ROOT / "docs" / "gateway.md").read_text(encoding="utf-8")
    (code,) = re.findall(r"```python\n(.*?)```", text, re.S)
    code = code.replace("5020", str(free_port()))
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert "operation enabled: True state 5" in result.stdout
    assert "P107 50.0 Hz" in result.stdout
    assert "It prints `operation enabled: True state 5` and `P107 50.0 Hz`." in text
