"""The master commands for real: ``uss simulate --pty`` in another process, the commands in this
one (or in a process of their own for signals), exit codes and JSON."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

from pyuss.cli.main import main

BAUD = "38400"


@pytest.fixture(scope="module")
def sim() -> Iterator[str]:
    """A generic drive at address 5 (PKW 3, PZD 2) behind a pty; yields the device path."""
    process = subprocess.Popen(
        [
            *(sys.executable, "-m", "pyuss.cli.main", "simulate", "--profile", "generic"),
            *("--address", "5", "--layout", "3,2", "--baud", BAUD, "--pty"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    path = process.stdout.readline().strip()
    assert path.startswith("/dev/"), process.stderr.read() if process.stderr else path
    try:
        yield path
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:  # pragma: no cover
            process.kill()


def uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def common(path: str) -> list[str]:
    return ["--port", path, "--baud", BAUD, "--layout", "3,2"]


def test_read_values_and_a_refused_one(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = uss(capsys, "read", "5", "52", "999", *common(sim))
    assert code == 1
    assert "P52 = 16384 (4000h)" in out
    assert "P999: drive refused the job (PNU 999): error 0: illegal parameter number" in err
    code, out, _ = uss(capsys, "read", "5", "52", "P683[1]", *common(sim), "--json")
    assert code == 0
    data = json.loads(out)
    assert data["parameters"][0] == {"pnu": 52, "index": None, "value": 0x4000}
    assert data["parameters"][1] == {"pnu": 683, "index": 1, "value": 5}  # its address


def test_write_then_read_back(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = uss(capsys, "write", "5", "18", "0x7000", *common(sim))
    assert (code, out.strip()) == (0, "P18 = 28672 (7000h)")
    code, out, _ = uss(capsys, "read", "5", "18", *common(sim), "--json")
    assert json.loads(out)["parameters"][0]["value"] == 0x7000
    code, out, _ = uss(capsys, "write", "5", "18", "5", "--eeprom", *common(sim), "--json")
    assert code == 0 and json.loads(out)["value"] == 5


def test_bad_input_exits_2_with_one_line(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = uss(capsys, "write", "5", "18", "70000", *common(sim))  # double word, PKW 3
    assert code == 2 and "double words need PKW 4" in err and len(err.splitlines()) == 1
    code, _, err = uss(capsys, "read", "5", "abc", *common(sim))
    assert code == 2 and "PNU or PNU.INDEX" in err
    code, _, err = uss(capsys, "read", "5", "52", "--port", sim, "--layout", "9,9")
    assert code == 2 and "PKW count" in err
    code, _, err = uss(capsys, "write", "5", "18", "nan", *common(sim))
    assert code == 2 and "finite" in err
    with pytest.raises(SystemExit) as info:
        main(["read", "40", "52", "--port", sim])
    assert info.value.code == 2
    code, _, err = uss(capsys, "read", "5", "52", "--port", sim, "--baud", "1234")
    assert code == 2 and "1234" in err


def test_a_missing_port_fails_with_exit_1(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = uss(capsys, "read", "5", "52", "--port", "/dev/nonexistent-uss-port")
    assert code == 1 and "cannot open" in err and len(err.splitlines()) == 1


def test_describe_element_and_fixed_layout_walk(
    sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = uss(capsys, "describe", "5", "52", *common(sim))
    assert code == 0
    assert "lower limit" in out and "identifier" in out
    code, out, _ = uss(capsys, "describe", "5", "52", "--element", "7", *common(sim), "--json")
    assert code == 0 and json.loads(out)["elements"][0]["words"] == [0x5FFF]
    code, _, err = uss(capsys, "describe", "5", "52", "--element", "255", *common(sim))
    assert code == 1 and "error 103" in err


def test_mirror_and_a_silent_address(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = uss(capsys, "mirror", "5", "--count", "3", *common(sim))
    assert code == 0 and "3 of 3 came back unchanged" in out
    code, out, _ = uss(capsys, "mirror", "9", *common(sim), "--json")
    assert code == 1 and json.loads(out)["tries"][0]["ok"] is False


def test_scan_finds_the_drive(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = uss(capsys, "scan", "--port", sim, "--baud", BAUD, "--address", "4-6", "--json")
    assert code == 0
    found = json.loads(out)
    assert [(f["address"], f["layout"], f["baud"]) for f in found] == [(5, "3,2", 38400)]
    code, out, _ = uss(capsys, "scan", "--port", sim, "--baud", BAUD, "--address", "7")
    assert code == 1 and "no drive answered" in out
    code, _, err = uss(capsys, "scan", "--port", sim, "--address", "30-40")
    assert code == 2 and "0..31" in err


def test_run_for_a_while_then_off(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert uss(capsys, "write", "5", "462", "1", *common(sim))[0] == 0  # ramp 0.1 s
    assert uss(capsys, "write", "5", "464", "1", *common(sim))[0] == 0
    code, out, _ = uss(
        capsys,
        "run",
        "5",
        "--setpoint",
        "20",
        "--duration",
        "1",
        "--interval",
        "0.05",
        *common(sim),
        "--json",
    )
    assert code == 0
    samples = [json.loads(line) for line in out.splitlines()]
    assert any(s.get("state") == "operation enabled" for s in samples)
    assert any(s.get("actual_percent") == pytest.approx(20.0, abs=0.01) for s in samples)
    assert samples[-1]["state"] != "operation enabled"  # switched off at the end


def test_run_stops_cleanly_on_sigterm(sim: str) -> None:
    process = subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", "run", "5", "--setpoint", "10", *common(sim)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert process.stdout is not None
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        if "operation enabled" in process.stdout.readline():
            break
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert out.strip().splitlines()[-1].startswith("ready to switch on")
