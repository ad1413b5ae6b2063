"""docs/commissioning.md runs as written: every command of its session against a fresh
simulated MICROMASTER 4 behind a pty, and the SINAMICS V20 walkthrough against a fresh
simulated V20, printing what the page shows. The page's simulators run with ``--pty`` and its
session uses head, grep and sed: POSIX systems."""

from __future__ import annotations

import io
from collections.abc import Iterator
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from commission.session import Step, matches, run_step, steps
from pyuss.cli.main import main
from support.paths import ROOT
from support.processes import simulator_pty

PAGE = ROOT / "docs" / "commissioning.md"
V20 = "A SINAMICS V20 from factory settings to a running motor"


@pytest.fixture
def micromaster() -> Iterator[str]:
    with simulator_pty("--profile", "micromaster4", "--address", "3") as path:
        yield path


@pytest.fixture
def v20() -> Iterator[str]:
    with simulator_pty("--profile", "sinamics-v20", "--address", "5") as path:
        yield path


def uss(argv: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = int(exc.code or 0)
    return code, out.getvalue() + err.getvalue()


@pytest.mark.pty
def test_the_commissioning_session_runs_as_written(
    micromaster: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    session = steps(PAGE, without=(V20,))
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
    run_session(session, tmp_path, micromaster)


@pytest.mark.pty
def test_a_v20_goes_from_factory_settings_to_a_running_motor_as_written(
    v20: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    session = steps(PAGE, only=V20)
    commands = [s.command.split(" --port")[0] for s in session]
    for needed in (
        "uss write 5 P0010 30",
        "uss write 5 P0970 1",
        "uss write 5 P0010 1",
        "uss write 5 P0700.0 5",
        "uss write 5 P1000.0 5",
        "uss write 5 P3900 1",
        "uss status 5",
        "uss backup 5 -o v20.toml",
        "uss run 5 --setpoint 50%",
        "uss diff 5 v20.toml",
        "uss restore 5 v20.toml --yes",
    ):
        assert any(c.startswith(needed) for c in commands), needed
    assert commands.index("uss write 5 P3900 1") < commands.index("uss backup 5 -o v20.toml")
    assert all("--profile sinamics-v20" in s.command for s in session if s.command[:4] == "uss ")
    run_session(session, tmp_path, v20)


def run_session(session: list[Step], cwd: Path, device: str) -> None:
    for step in session:
        if step.command.startswith("uss simulate"):
            continue  # the fixture's simulator
        got = run_step(step, cwd, device, uss)
        assert matches(step.expected, got), f"$ {step.command}\n" + "\n".join(got)
