"""docs/commissioning.md runs as written: every command of its session against a fresh
simulated MICROMASTER 4 behind a pty, printing what the page shows."""

from __future__ import annotations

import io
from collections.abc import Iterator
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from commission.session import matches, run_step, steps
from pyuss.cli.main import main
from support.paths import ROOT
from support.processes import simulator_pty

PAGE = ROOT / "docs" / "commissioning.md"


@pytest.fixture
def micromaster() -> Iterator[str]:
    with simulator_pty("--profile", "micromaster4", "--address", "3") as path:
        yield path


def uss(argv: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = int(exc.code or 0)
    return code, out.getvalue() + err.getvalue()


def test_the_commissioning_session_runs_as_written(
    micromaster: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    session = steps(PAGE)
    commands = [s.command for s in session]
    for needed in (
        "uss params",
        "uss backup",
        "uss write",
        "uss diff",
        "uss restore",
        "uss status",
    ):
        assert any(c.startswith(needed) for c in commands), needed
    for step in session:
        if step.command.startswith("uss simulate"):
            continue  # the fixture's simulator
        got = run_step(step, tmp_path, micromaster, uss)
        assert matches(step.expected, got), f"$ {step.command}\n" + "\n".join(got)
