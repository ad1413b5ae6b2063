"""``uss demo``: the master against three simulated drives; it runs by itself and shows what
it promises."""

from __future__ import annotations

import pytest

from pyuss.cli.main import main


def test_demo_runs_and_shows_each_step(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    for address, layout in (("1", "v,2"), ("4", "3,2"), ("7", "v,2")):
        assert f"address {address}: layout {layout}" in out  # the scan found it
    assert "P52 = 16384 (Load display)   (C 8 example 2: 4000h)" in out
    assert "P52 lower limit = 5FFFh" in out
    assert "P7 text 3 = '300 BAUD'" in out
    assert "P2010.0 = 8 [38400 BAUD] (USS baudrate)" in out  # the bus's rate (C 3)
    assert "P1120 := 2.5 s -> P1120 = 2.50 s (Ramp-up time)" in out
    assert "P52 is now 1234h (acknowledged)" in out
    assert out.count("back unchanged") == 3
    assert "50.00 %" in out and "ready to switch on" in out
    assert "02 0C 01 10 34 00 00 00 00 00 00 00 00 2B" in out  # read P52, decoded from the line
    assert "Diagnostics:" in out


@pytest.mark.posix("pipes the output into head through the shell")
def test_a_reader_that_goes_away_ends_the_command_quietly() -> None:
    """`uss ... | head` must not end in a traceback when head stops reading."""
    import subprocess
    import sys

    proc = subprocess.run(
        f"{sys.executable} -m pyuss.cli.main demo | head -1",
        shell=True,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.stdout.startswith("A virtual RS-485 bus")
    assert "Traceback" not in proc.stderr, proc.stderr
