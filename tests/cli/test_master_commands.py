"""The master commands for real: ``uss simulate --tcp`` in another process, the commands in this
one (or in a process of their own for signals and terminals), exit codes and JSON."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

from pyuss.cli.main import main
from pyuss.protocol.layout import Layout
from support.buses import SimulatorThread
from support.processes import simulator

BAUD = "38400"


@pytest.fixture(scope="module")
def sim() -> Iterator[str]:
    """A generic drive at address 5 (PKW 3, PZD 2) on TCP; yields its ``tcp://`` URL."""
    with simulator(
        *("--profile", "generic", "--address", "5", "--layout", "3,2", "--baud", BAUD)
    ) as url:
        yield url


def uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def common(path: str) -> list[str]:
    return ["--port", path, "--baud", BAUD, "--layout", "3,2", "--profile", "generic"]


def test_read_values_and_a_refused_one(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = uss(capsys, "read", "5", "52", "999", *common(sim))
    assert code == 1
    assert "P52 = 16384 (Load display)" in out  # int16, no unit
    assert "P999: drive refused the job (P999): error 0: illegal parameter number; check" in err
    code, out, _ = uss(capsys, "read", "5", "52", "P683[1]", *common(sim), "--json")
    assert code == 0
    data = json.loads(out)
    first, second = data["parameters"]
    assert (first["pnu"], first["index"], first["value"], first["raw"]) == (
        52,
        None,
        0x4000,
        [0x4000],
    )
    assert (first["name"], first["type"], first["unit"]) == ("Load display", "int16", "")
    assert (second["pnu"], second["index"], second["value"]) == (683, 1, 5)  # its address


def test_write_then_read_back(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = uss(capsys, "write", "5", "18", "0x7000", *common(sim))
    assert (code, out.strip()) == (0, "P18 = 28672 (Fixed setpoint)")
    code, out, _ = uss(capsys, "read", "5", "18", *common(sim), "--json")
    assert json.loads(out)["parameters"][0]["value"] == 0x7000
    code, out, _ = uss(capsys, "write", "5", "18", "5", "--eeprom", *common(sim), "--json")
    assert code == 0 and json.loads(out)["value"] == 5


def test_bad_input_exits_2_with_one_line(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = uss(capsys, "write", "5", "18", "70000", *common(sim))  # P18 is int16
    assert code == 2 and "P18: 70000 does not fit int16" in err and len(err.splitlines()) == 1
    code, _, err = uss(capsys, "write", "5", "18", "70000", "--raw", "--dword", *common(sim))
    assert code == 2 and "double words need PKW 4" in err and len(err.splitlines()) == 1
    code, _, err = uss(capsys, "read", "5", "abc", *common(sim))
    assert code == 2 and "'abc' is not a parameter number" in err
    code, out, err = uss(capsys, "write", "5", "P18x", "5", *common(sim))
    assert (code, out) == (2, "")
    assert err == (
        "uss write: 'P18x' is not a parameter number (for example r0021, P1120, 21 or 947.1)\n"
    )
    code, _, err = uss(capsys, "read", "5", "52", "--port", sim, "--layout", "9,9")
    assert code == 2 and "PKW count" in err
    code, _, err = uss(capsys, "write", "5", "107", "nan", *common(sim))
    assert code == 2 and "'nan' is not a number" in err
    with pytest.raises(SystemExit) as info:
        main(["read", "40", "52", "--port", sim])
    assert info.value.code == 2
    code, _, err = uss(capsys, "read", "5", "52", "--port", sim, "--baud", "1234")
    assert code == 2 and "1234" in err
    code, out, err = uss(capsys, "mirror", "5", "--data", "00" * 300, *common(sim))
    assert code == 2 and "252" in err and len(err.splitlines()) == 1 and not out
    for setpoint in ("inf", "nan", "300"):
        code, out, err = uss(capsys, "run", "5", "--setpoint", setpoint, *common(sim))
        assert code == 2 and len(err.splitlines()) == 1 and not out, err
    code, out, err = uss(capsys, "run", "5", "--setpoint", "10", "--port", sim, "--layout", "3,0")
    assert code == 2 and "PZD2" in err and len(err.splitlines()) == 1 and not out


def test_a_missing_port_fails_with_exit_1(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = uss(capsys, "read", "5", "52", "--port", "/dev/nonexistent-uss-port")
    assert code == 1 and "cannot open" in err and len(err.splitlines()) == 1


def test_describe_element_and_fixed_layout_walk(
    sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = uss(capsys, "describe", "5", "52", *common(sim))
    assert code == 0
    assert "lower limit" in out and "identifier" in out
    code, again, _ = uss(capsys, "describe", "5", "r0052", *common(sim))  # any spelling
    assert (code, again) == (0, out) and out.startswith("P52: parameter description")
    code, out, err = uss(capsys, "describe", "5", "52.1", *common(sim))
    assert (code, out) == (2, "") and "'52.1': a description is the whole parameter's" in err
    code, out, _ = uss(capsys, "describe", "5", "52", "--element", "7", *common(sim), "--json")
    assert code == 0 and json.loads(out)["elements"][0]["words"] == [0x5FFF]
    code, _, err = uss(capsys, "describe", "5", "52", "--element", "255", *common(sim))
    assert code == 1 and "error 103" in err
    code, out, _ = uss(capsys, "describe", "5", "52", "--element", "255", *common(sim), "--json")
    error = json.loads(out)["error"]
    assert code == 1 and (error["type"], error["number"]) == ("DriveRefusal", 103)


def test_failures_with_json_are_json(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = uss(capsys, "write", "5", "999", "1", *common(sim), "--json")
    data = json.loads(out)
    assert code == 1 and (data["pnu"], data["error"]["number"]) == (999, 0)
    assert data["error"]["meaning"] == "illegal parameter number"
    code, out, _ = uss(capsys, "write", "9", "18", "1", *common(sim), "--json", "--timeout", "0.3")
    assert code == 1 and json.loads(out)["error"]["type"] == "JobTimeout"
    code, out, err = uss(capsys, "write", "5", "18", "x", *common(sim), "--json")
    assert code == 2 and not err  # bad input is the same JSON error object, exit code 2
    error = json.loads(out)["error"]
    assert (error["exit_code"], error["message"]) == (2, "P18: 'x' is not a number of its kind")
    assert error["type"] == "ValueRefused"  # a ConfigError


def test_mirror_and_a_silent_address(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = uss(capsys, "mirror", "5", "--count", "3", *common(sim))
    assert code == 0 and "3 of 3 came back unchanged" in out
    code, out, _ = uss(capsys, "mirror", "9", *common(sim), "--json")
    assert code == 1 and json.loads(out)["tries"][0]["ok"] is False


def test_scan_finds_the_drive(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    rates = f"{BAUD},{BAUD}"  # a rate given twice is probed once
    code, out, _ = uss(capsys, "scan", "--port", sim, "--baud", rates, "--address", "4-6", "--json")
    assert code == 0
    found = json.loads(out)
    assert [(f["address"], f["layout"], f["baud"]) for f in found] == [(5, "3,2", 38400)]
    code, _, err = uss(capsys, "scan", "--port", sim, "--profile", "6se21", "--layout", "4,2")
    assert code == 2 and "6se21" in err and len(err.splitlines()) == 1
    code, out, _ = uss(capsys, "scan", "--port", sim, "--baud", BAUD, "--address", "7")
    assert code == 1 and "no drive answered" in out
    code, _, err = uss(capsys, "scan", "--port", sim, "--address", "30-40")
    assert code == 2 and "0..31" in err


def test_run_for_a_while_then_off(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert uss(capsys, "write", "5", "462", "0.1", *common(sim))[0] == 0  # ramp 0.1 s
    assert uss(capsys, "write", "5", "464", "0.1 s", *common(sim))[0] == 0
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


@pytest.mark.posix("stops uss run with SIGTERM")
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


def _in_a_terminal(argv: list[str]) -> tuple[int, int]:
    """Start ``uss ARGV`` with a pty as its controlling terminal, as a shell would; returns
    the child's pid and the terminal's master side (``\\x03`` written to it is Ctrl+C)."""
    import pty

    pid, fd = pty.fork()
    if pid == 0:  # pragma: no cover - the child
        os.execv(sys.executable, [sys.executable, "-m", "pyuss.cli.main", *argv])
    return pid, fd


def _read_until(fd: int, text: str, seen: bytearray, timeout: float = 60) -> bool:
    """Read the terminal into ``seen`` until ``text`` shows after the last mark, or EOF."""
    deadline = time.monotonic() + timeout
    start = len(seen)
    while time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(fd, 4096)
            except OSError:  # EIO: the child closed the terminal
                return False
            if not chunk:
                return False
            seen += chunk
            if text and text.encode() in seen[start:]:
                return True
    return False


def _finish(pid: int, fd: int, seen: bytearray) -> int:
    _read_until(fd, "", seen)
    os.close(fd)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status)


def _screen(seen: bytearray) -> list[str]:
    """What stays on the terminal: each line as its last carriage return left it."""
    text = seen.decode(errors="replace").replace("\r\n", "\n")
    return [line.split("\r")[-1] for line in text.split("\n") if line.split("\r")[-1].strip()]


@pytest.mark.pty
def test_run_in_a_terminal_switches_off_on_ctrl_c(
    sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    for pnu in ("462", "464"):  # ramp times 0.1 s
        assert uss(capsys, "write", "5", pnu, "1", *common(sim))[0] == 0
    pid, fd = _in_a_terminal(["run", "5", "--setpoint", "10", *common(sim)])
    seen = bytearray()
    assert _read_until(fd, "operation enabled", seen), seen.decode(errors="replace")
    assert b"\r" in seen  # one line that updates itself
    os.write(fd, b"\x03")  # Ctrl+C typed on the terminal
    code = _finish(pid, fd, seen)
    assert code == 130, seen.decode(errors="replace")
    assert _screen(seen)[-1].startswith("ready to switch on")  # OFF1, ramped down, stopped
    assert "Traceback" not in seen.decode(errors="replace")
    code, out, _ = uss(capsys, "read", "5", "552", *common(sim), "--json")
    word = json.loads(out)["parameters"][0]["value"]
    assert code == 0 and not word & 0x0004  # the drive itself: operation no longer enabled


@pytest.mark.pty
def test_run_a_second_ctrl_c_coasts_the_drive_down(
    sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert uss(capsys, "write", "5", "462", "1", *common(sim))[0] == 0  # up in 0.1 s
    assert uss(capsys, "write", "5", "464", "600", *common(sim))[0] == 0  # down in 60 s
    try:
        pid, fd = _in_a_terminal(["run", "5", "--setpoint", "100", *common(sim)])
        seen = bytearray()
        assert _read_until(fd, "actual  100.00 %", seen), seen.decode(errors="replace")
        os.write(fd, b"\x03")  # OFF1: the drive ramps down slowly ...
        assert _read_until(fd, "actual   99.", seen), seen.decode(errors="replace")
        os.write(fd, b"\x03")  # ... and a second Ctrl+C coasts it down at once (OFF2)
        code = _finish(pid, fd, seen)
    finally:
        uss(capsys, "write", "5", "464", "1", *common(sim))
    assert code == 130, seen.decode(errors="replace")
    assert _screen(seen)[-1].startswith("switch-on inhibited")  # after OFF2 (C Table 5.5)


@pytest.mark.pty
def test_scan_in_a_terminal_shows_a_progress_bar(sim: str) -> None:
    pid, fd = _in_a_terminal(["scan", "--port", sim, "--baud", BAUD, "--address", "4-6"])
    seen = bytearray()
    code = _finish(pid, fd, seen)
    text = seen.decode(errors="replace")
    assert code == 0, text
    bars = [part for part in text.replace("\n", "\r").split("\r") if part.startswith("scanning [")]
    assert len(bars) > 3  # it moves
    # 3 addresses x 6 probe lengths, complete at the end, with the time left
    assert "] 18/18, 0 s left" in bars[-1]
    assert "#" * 30 in bars[-1]
    assert any(line.split()[:3] == ["5", BAUD, "3,2"] for line in _screen(seen))


@pytest.mark.parametrize("name", ["scan", "read", "write", "describe", "mirror", "run"])
def test_every_command_takes_the_shared_options_and_documents_exit_codes(
    name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as info:
        main([name, "--help"])
    assert info.value.code == 0
    text = capsys.readouterr().out
    for option in ("--port", "--baud", "--profile", "--layout", "--json"):
        assert option in text
    assert "exit codes:" in text and "130" in text


def test_run_ends_with_exit_1_when_the_drive_stops_answering() -> None:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        port = ["--port", sim.paths[0], "--baud", str(sim.baud), "--layout", "3,2"]
        # no --duration: it runs until something ends it
        argv = ["run", "5", "--setpoint", "10", "--timeout", "0.5", *port]
        process = subprocess.Popen(
            [sys.executable, "-m", "pyuss.cli.main", *argv],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                if sim.call(lambda s: s.engines[5].drive.running):
                    break
                time.sleep(0.05)
            sim.call(lambda s: s.bus.make_dead("drive5", 600))  # it stops answering
            _, err = process.communicate(timeout=60)
        finally:
            if process.poll() is None:  # pragma: no cover - it hung: fail below
                process.kill()
                process.wait()
    assert process.returncode == 1, err
    assert "slave 5 does not send" in err
