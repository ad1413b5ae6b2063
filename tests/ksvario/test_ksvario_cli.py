"""`uss ksvario`: gsd, address, read/write in-process and over TCP with the built-in DP master;
its simulator on a pty and stopped by signals."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from ksvario_sim import SlaveThread

from pyuss.cli.main import main
from pyuss.ksvario.address import Address
from pyuss.ksvario.coupler import Coupler
from pyuss.ksvario.gsd import parse_gsd

LISTEN = "tcp-listen://127.0.0.1:0"
"""Where the simulated coupler is served: a free loopback port, reached as ``tcp://``."""


def test_gsd_to_stdout_and_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ksvario", "gsd"]) == 0
    assert parse_gsd(capsys.readouterr().out).ident_number == 0x1030
    target = tmp_path / "PMA_1030.gsd"
    assert main(["ksvario", "gsd", "--output", str(target)]) == 0
    assert parse_gsd(target.read_text(encoding="ascii")).ident_number == 0x1030
    assert [p.name for p in tmp_path.iterdir()] == ["PMA_1030.gsd"]


def test_gsd_into_missing_folder_is_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["ksvario", "gsd", "-o", str(tmp_path / "no" / "x.gsd")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_address(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ksvario", "address", "fix1:ch1:0x96"]) == 0
    out = capsys.readouterr().out
    assert "4496h" in out and "channel 1" in out and "892Ch" in out


@pytest.mark.parametrize(
    "argv",
    [
        ["ksvario", "read", "0xZZZZ", "--sim"],
        ["ksvario", "read", "0x4496", "0", "--sim"],
        ["ksvario", "write", "0x4496", "abc", "--sim"],
        ["ksvario", "read", "0x4496", "--sim", "--modules", "A.2"],
        ["ksvario", "read", "0x4496", "--port", "x", "--station", "200"],
        ["ksvario", "read", "0x4496", "--port", "x", "--baud", "1234"],
        ["ksvario", "read", "0x4496", "--sim", "--timeout", "-1"],
        ["ksvario", "write", "0x4496", "1", "--sim", "--timeout", "0"],
        ["ksvario", "simulate", "--pty", "--baud", "1234"],
        ["ksvario", "simulate", "--pty", "--baud", "38400"],  # a USS rate, not a DP one
        # values the channel cannot carry are bad input before any line is opened
        ["ksvario", "write", "0x4496", "99999", "--port", "x"],
        ["ksvario", "write", "0x8CD2", "1e40", "--port", "x"],
        ["ksvario", "write", "0x10", "ABCDE", "--format", "compact", "--port", "x"],
        ["ksvario", "write", "0x10", "300", "--format", "char", "--port", "x"],
        ["ksvario", "read", "0x4496", "--port", "x", "--modules", "A.7,B.1"],  # no A.1
        ["ksvario", "read", "0x4496", "--port", "x", "--baud", "31250"],  # no line carries it
    ],
)
def test_bad_input_exits_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("uss ksvario:") and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["ksvario", "address", "zz"], "'zz' is not a number"),
        (["ksvario", "read", "fix1:ch1:qq", "--sim"], "'qq' is not a number"),
        (["ksvario", "write", "0x4496", "abc", "--sim"], "'abc' is not an integer"),
        (["ksvario", "write", "0x8CD2", "abc", "--sim"], "'abc' is not a real number"),
    ],
)
def test_bad_numbers_are_named_in_plain_words(
    argv: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and "literal" not in err, err


def test_read_and_write_in_process(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ksvario", "read", "0x4496", "--sim"]) == 0
    assert capsys.readouterr().out.strip() == "4496h  1000 (100)"
    assert main(["ksvario", "write", "0xFD09", "1.5", "2", "--sim"]) == 0
    assert "done_ok" in capsys.readouterr().out


def test_rows_count_from_the_address_typed(capsys: pytest.CaptureFixture[str]) -> None:
    """An odd float address (as FD09h in example 4.5.4) is shown as typed; rows go on in steps
    of two address words (one float each). Pb1 of channel 1 (datum 96h) is 100 here."""
    assert main(["ksvario", "read", "0x892D", "3", "--sim", "--format", "real3"]) == 0
    assert capsys.readouterr().out.splitlines() == ["892Dh  100", "892Fh  0", "8931h  0"]


def test_result_error_exits_1(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ksvario", "read", "0x05FF", "4", "--sim"]) == 1
    assert "bad address" in capsys.readouterr().err


def test_read_write_over_tcp_with_the_dp_master(capsys: pytest.CaptureFixture[str]) -> None:
    coupler = Coupler()
    coupler.set(Address.channel(2, 0x69), 42.5)
    with SlaveThread(coupler, 7, LISTEN) as sim:
        assert main(["ksvario", "read", "0x8CD2", "2", "--port", sim.device, "--station", "7"]) == 0
        assert capsys.readouterr().out.splitlines() == ["8CD2h  42.5", "8CD4h  900"]
        argv = ["ksvario", "write", "0x3E9A", "45", "--port", sim.device, "--station", "7"]
        assert main([*argv, "--modules", "A.1,B.1"]) == 0
    assert coupler.get(Address.channel(30, 0x9A)) == 45.0


def test_absent_station_fails_with_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    with SlaveThread(Coupler(), 7, LISTEN) as sim:
        argv = ["ksvario", "read", "0x4496", "--port", sim.device, "--station", "9"]
        assert main(argv) == 1
    assert "did not answer" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("serve", "read"),
    [
        (["ksvario", "simulate", "--pty", "--station", "3"], ["--station", "3"]),
        # ``uss simulate --profile ksvario`` serves one DP station (addresses up to 125)
        (
            ["simulate", "--profile", "ksvario", "--pty", "--address", "100", "--baud", "93750"],
            ["--station", "100", "--baud", "93750"],
        ),
    ],
    ids=["uss ksvario simulate", "uss simulate --profile ksvario"],
)
@pytest.mark.pty
def test_simulator_prints_the_device_first_and_answers(serve: list[str], read: list[str]) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", *serve],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        device = proc.stdout.readline().strip()
        assert device.startswith("/dev/")
        assert main(["ksvario", "read", "0x4496", "--port", device, *read]) == 0
    finally:
        proc.terminate()
        proc.wait(10)


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--address", "126"], "DP station addresses are 0..125"),
        (["--address", "5", "--baud", "500000"], "do not carry"),
        (["--address", "5", "--params", "x.toml"], "does not take --params"),
        (["--address", "5", "--layout", "3,2", "--read-only"], "--layout, --read-only"),
    ],
)
def test_uss_simulate_profile_ksvario_bad_input(
    extra: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", "--profile", "ksvario", "--pty", *extra]) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1, err


_BACKGROUND = (
    '"$0" -m pyuss.cli.main "$@" < /dev/null > "$OUT" 2> "$ERR" & echo $!; wait $!; echo "rc=$?"'
)
"""How a shell script starts a simulator: in the background, without job control, so the
shell leaves SIGINT (and SIGQUIT) ignored in it; stdin from /dev/null."""


@pytest.mark.posix("a shell script (sh) starts the simulator and kill sends it the signal")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize(
    "argv",
    [
        ["ksvario", "simulate", "--port", LISTEN],
        ["simulate", "--profile", "ksvario", "--tcp", "127.0.0.1:0", "--address", "5"],
        ["simulate", "--tcp", "127.0.0.1:0", "--address", "5"],
    ],
    ids=["uss ksvario simulate", "uss simulate --profile ksvario", "uss simulate"],
)
def test_a_simulator_started_in_the_background_stops_cleanly(
    argv: list[str], sig: signal.Signals, tmp_path: Path
) -> None:
    out, err = tmp_path / "out", tmp_path / "err"
    out.touch()
    err.touch()
    shell = subprocess.Popen(
        ["sh", "-c", _BACKGROUND, sys.executable, *argv],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "OUT": str(out), "ERR": str(err)},
    )
    assert shell.stdout is not None
    pid = int(shell.stdout.readline())
    try:
        deadline = time.monotonic() + 20
        while not out.read_text().strip() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert out.read_text().startswith("tcp://127.0.0.1:"), err.read_text()
        os.kill(pid, sig)
        rest, _ = shell.communicate(timeout=20)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
        shell.kill()
        shell.wait()
    assert rest.strip() == "rc=0", err.read_text()
    assert "Traceback" not in err.read_text()
