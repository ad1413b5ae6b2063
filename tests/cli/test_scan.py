"""``uss scan`` as a user runs it: drives printed as they are found, ``--first``, the time
left, Ctrl+C keeping what was found (typed on the terminal of a pty), and the note that a pty
has no baud rate."""

from __future__ import annotations

import json
import os
import re
import select
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

from support.processes import simulator, simulator_pty

BAUD = "38400"
"""The rate scanned; TCP and a pty have none, so the simulator's own does not matter."""
USS = [sys.executable, "-m", "pyuss.cli.main"]


@pytest.fixture(scope="module")
def sim() -> Iterator[str]:
    """Generic drives at addresses 2 and 9 (PKW 3, PZD 2) on TCP; its ``tcp://`` URL."""
    with simulator("--address", "2", "--address", "9", "--layout", "3,2") as url:
        yield url


@pytest.fixture(scope="module")
def pty_sim() -> Iterator[str]:
    """The drives of `sim` behind a pty; its device path."""
    with simulator_pty("--address", "2", "--address", "9", "--layout", "3,2") as path:
        yield path


def _in_a_terminal(argv: list[str]) -> tuple[int, int]:
    """``uss ARGV`` with a pty as its terminal; the pid and the terminal's master side."""
    import pty

    pid, fd = pty.fork()
    if pid == 0:  # pragma: no cover - the child
        os.execv(sys.executable, [*USS, *argv])
    return pid, fd


def _read_until(fd: int, pattern: str, seen: bytearray, timeout: float = 60) -> bool:
    """Read the terminal into ``seen`` until ``pattern`` (a regex) matches, or EOF."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pattern and re.search(pattern, seen.decode(errors="replace")):
            return True
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(fd, 4096)
            except OSError:  # EIO: the child closed the terminal
                return False
            if not chunk:
                return False
            seen += chunk
    return False


def _finish(pid: int, fd: int, seen: bytearray) -> int:
    _read_until(fd, "", seen)
    os.close(fd)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status)


ROW_2 = r"\n\s+2\s+38400\s+3,2\s"


@pytest.mark.pty
def test_a_drive_is_printed_when_found_and_ctrl_c_keeps_it(sim: str) -> None:
    pid, fd = _in_a_terminal(["scan", "--port", sim, "--baud", BAUD])
    seen = bytearray()
    try:
        assert _read_until(fd, ROW_2, seen), seen.decode(errors="replace")
        # the scan goes on (addresses 3..31 are left): the drive was printed as found
        assert _read_until(fd, r"\d+ s left", seen), seen.decode(errors="replace")
        assert os.waitpid(pid, os.WNOHANG) == (0, 0)
    finally:
        os.write(fd, b"\x03")  # Ctrl+C typed on the terminal
    code = _finish(pid, fd, seen)
    text = seen.decode(errors="replace")
    assert code == 130, text
    assert re.search(ROW_2, text)
    assert "interrupted; 1 drive found so far" in text
    assert "Traceback" not in text


@pytest.mark.pty
def test_ctrl_c_with_json_prints_the_drives_found_so_far(sim: str) -> None:
    pid, fd = _in_a_terminal(["scan", "--port", sim, "--baud", BAUD, "--json"])
    seen = bytearray()
    try:
        # the bar counts probes: address 2 answered the 13th (and the 14th, the variable-length
        # check); from the 15th on the scan is past it
        assert _read_until(fd, r"\] (1[5-9]|[2-9]\d)/192", seen), seen.decode(errors="replace")
    finally:
        os.write(fd, b"\x03")
    code = _finish(pid, fd, seen)
    text = seen.decode(errors="replace")
    assert code == 130, text
    line = next(part for part in text.splitlines() if part.startswith("["))
    assert [f["address"] for f in json.loads(line)] == [2]


def test_first_stops_at_the_first_drive(sim: str) -> None:
    done = subprocess.run(
        [*USS, "scan", "--port", sim, "--baud", BAUD, "--first", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert [f["address"] for f in json.loads(done.stdout)] == [2]  # 9 answers too


@pytest.mark.pty
@pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="uss scan tells a pty by Linux's device numbers"
)
def test_on_a_pty_the_note_says_rates_cannot_be_told_apart(pty_sim: str) -> None:
    done = subprocess.run(
        [*USS, "scan", "--port", pty_sim, "--baud", "9600,19200", "--address", "2", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert [f["baud"] for f in json.loads(done.stdout)] == [9600, 19200]  # both "answer"
    assert "pseudo-terminal" in done.stderr
    assert "cannot be told apart" in done.stderr


@pytest.mark.parametrize("text", ["3-", "-1", "a", "1,,2"])
def test_a_bad_address_range_is_answered_with_an_example_that_is_right(text: str) -> None:
    done = subprocess.run(
        [*USS, "scan", "--port", "/dev/no-such-port", "--address", text],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2 and not done.stdout
    assert done.stderr == (
        f"uss scan: --address {text!r}: expected addresses 0..31 and ranges, e.g. 0-31 or 1,5,7-9\n"
    )


def test_a_response_time_no_line_could_give_is_not_printed(
    sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # over TCP the answer is read long before a line at 300 baud could have brought it
    # (the simulator answers at its own rate): no response time was measured, none is shown
    from pyuss.cli.main import main

    argv = ["scan", "--port", sim, "--baud", "300", "--address", "2", "--layout", "3,2"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    (row,) = [line for line in out.splitlines() if line.split()[:1] == ["2"]]
    assert row.split()[4:] == ["-", "-", "-", "-"], row  # response, profile, firmware, family
    assert main([*argv, "--json"]) == 0
    (found,) = json.loads(capsys.readouterr().out)
    assert found["response_time"] is None
    code = main(["mirror", "2", "--port", sim, "--baud", "300", "--layout", "3,2", "--count", "1"])
    out = capsys.readouterr().out
    assert code == 0 and out.startswith("mirror 1: ok, 14 bytes, response -, round trip "), out
