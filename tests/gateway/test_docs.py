"""The examples of docs/gateway.md run as printed: the worked example (on a free port instead
of 5020) and the face added through the registry."""

from __future__ import annotations

import re
import subprocess
import sys

from support.network import free_port
from support.paths import ROOT


def _example(section: str) -> tuple[str, str]:
    """The page and the one Python block of its section ``## SECTION``."""
    text = (ROOT / "docs" / "gateway.md").read_text(encoding="utf-8")
    body = text.split(f"\n## {section}\n", 1)[1].split("\n## ", 1)[0]
    (code,) = re.findall(r"```python\n(.*?)```", body, re.S)
    return text, code


def test_the_worked_example_runs_as_written() -> None:
    text, code = _example("Worked example")
    code = code.replace("5020", str(free_port()))
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert "operation enabled: True state 5" in result.stdout
    assert "P107 50.0 Hz" in result.stdout
    assert "It prints `operation enabled: True state 5` and `P107 50.0 Hz`." in text


def test_the_face_added_through_the_registry_runs_as_written() -> None:
    text, code = _example("Adding a face")
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.splitlines() == ["hi bus/drive5", "[('hello', 'stdout')]", "goodbye"]
    assert "It prints `hi bus/drive5`, `[('hello', 'stdout')]` and `goodbye`." in text
