"""pyuss's commands and API open a real ``uss simulate --pty`` whatever another program did to
the device before: pyserial at 8N1 or 8E1, pyuss's own ``?rs485=kernel`` (which a pty cannot
do), a program killed while it held the device. Commands run as a user runs them, each in a
process of its own: a port that cannot be opened is one line on stderr and exit code 1."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator

import pytest

from pyuss.master.sync import Master
from support.processes import simulator_pty
from transport.helpers import even_8e1, killed_holder, plain_8n1

pytestmark = [
    pytest.mark.pty,
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux ptys"),
]

BAUD = "9600"
WAIT = 60.0


@pytest.fixture(scope="module")
def sim() -> Iterator[str]:
    """A generic drive at address 5 (PKW 3, PZD 2) behind a pty, in a process of its own."""
    with simulator_pty(
        *("--profile", "generic", "--address", "5", "--layout", "3,2", "--baud", BAUD)
    ) as path:
        yield path


def uss(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pyuss.cli.main", *argv],
        capture_output=True,
        text=True,
        timeout=WAIT,
        check=False,
    )


def common(path: str) -> list[str]:
    return ["--port", path, "--baud", BAUD, "--layout", "3,2"]


def cannot_open(path: str, *argv: str) -> None:
    """``?rs485=kernel`` on a pty: the port truly cannot be opened. One line, exit code 1."""
    done = uss(*argv, "--port", f"{path}?rs485=kernel", "--baud", BAUD)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "kernel RS-485 mode" in lines[0], done.stderr


def read_52(path: str, *extra: str) -> subprocess.CompletedProcess[str]:
    done = uss("read", "5", "52", *common(path), *extra)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    return done


def test_commands_open_the_pty_whatever_other_programs_did(sim: str) -> None:
    plain_8n1(sim)  # as the README's pyserial example does
    assert "P52 = 16384" in read_52(sim).stdout
    even_8e1(sim)
    assert json.loads(read_52(sim, "--json").stdout)["parameters"][0]["value"] == 0x4000
    cannot_open(sim, "read", "5", "52", "--layout", "3,2")
    done = uss("mirror", "5", *common(sim))
    assert done.returncode == 0, done.stderr
    killed_holder(sim)
    done = uss("scan", "--address", "5", "--port", sim, "--baud", BAUD, "--json")
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    cannot_open(sim, "mirror", "5")
    plain_8n1(sim)
    done = uss("monitor", "--port", sim, "--baud", BAUD, "--duration", "0.3")
    assert done.returncode == 0, done.stderr
    assert "listening on" in done.stderr
    cannot_open(sim, "monitor", "--duration", "0.3")
    killed_holder(sim)
    even_8e1(sim)
    assert "P52 = 16384" in read_52(sim).stdout


def test_the_sync_api_opens_the_pty_whatever_other_programs_did(sim: str) -> None:
    for other in (plain_8n1, even_8e1, killed_holder, even_8e1):
        other(sim)
        with Master(sim, baud=int(BAUD)) as bus:
            assert bus.drive(5, layout="3,2").read(52) == 0x4000


@pytest.mark.parametrize(
    "command", [["read", "5", "52"], ["mirror", "5"], ["scan"], ["monitor", "--duration", "1"]]
)
def test_with_json_a_port_that_cannot_be_opened_is_one_error_and_exit_1(
    sim: str, command: list[str]
) -> None:
    done = uss(*command, "--port", f"{sim}?rs485=kernel", "--baud", BAUD, "--json")
    assert done.returncode == 1
    assert "Traceback" not in done.stderr
    lines = (done.stdout + done.stderr).strip().splitlines()
    assert len(lines) == 1 and "kernel RS-485 mode" in lines[0], lines
    if done.stdout.strip():  # the JSON error object of the commands
        assert "kernel RS-485 mode" in json.dumps(json.loads(done.stdout)["error"])


@pytest.mark.parametrize("command", [["read", "5", "52"], ["mirror", "5"], ["scan"]])
def test_a_port_that_cannot_be_opened_is_one_line_and_exit_1(sim: str, command: list[str]) -> None:
    cannot_open(sim, *command)
    missing = uss(*command, "--port", "/dev/does-not-exist-uss", "--baud", BAUD)
    assert missing.returncode == 1
    assert "Traceback" not in missing.stderr
    assert len(missing.stderr.strip().splitlines()) == 1
    assert "/dev/does-not-exist-uss" in missing.stderr
