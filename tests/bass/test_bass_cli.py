"""``uss bass`` as a user runs it: a simulated ring in its own process, reached over TCP and a
pty, read and written with ``uss bass read`` / ``uss bass write``."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial

from bass.protocol_recording import recorded
from pyuss.bass.codec import BassAnswer, BassLineReader, BassRequest
from pyuss.cli.main import main

TIMEOUT = 20


class Ring:
    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "pyuss.cli.main", "bass", "ring", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert self.proc.stdout is not None
        self.where = self.proc.stdout.readline().strip()

    def stop(self, sig: signal.Signals = signal.SIGTERM) -> tuple[int, str]:
        self.proc.send_signal(sig)
        _, err = self.proc.communicate(timeout=TIMEOUT)
        return self.proc.returncode, err


@pytest.fixture
def tcp_ring() -> Iterator[Ring]:
    ring = Ring("--listen", "tcp-listen://127.0.0.1:0", "--drives", "1,2,0x10", "--locked", "2")
    try:
        assert ring.where.startswith("tcp://127.0.0.1:"), ring.proc.stderr
        yield ring
    finally:
        if ring.proc.poll() is None:
            ring.stop()


def uss(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(["bass", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_read_and_write_over_tcp(tcp_ring: Ring, capsys: pytest.CaptureFixture[str]) -> None:
    port = ("--port", tcp_ring.where, "--timeout", "5")
    assert uss(capsys, "read", "1", "170", *port) == (0, "17 (0x0011)\n", "")
    code, out, _ = uss(capsys, "read", "0x10", "171", *port, "--json")
    assert code == 0
    assert json.loads(out) == {
        "ok": True,
        "address": 16,
        "id": 171,
        "value": 9600,
        "data": "2580",
        "attempts": 1,
    }
    assert uss(capsys, "write", "1", "2", "-7500", *port)[0] == 0
    assert uss(capsys, "read", "1", "2", "--signed", *port)[1] == "-7500 (0xE2B4)\n"
    assert uss(capsys, "read", "1", "2", *port)[1] == "58036 (0xE2B4)\n"


def test_refusals_exit_1_with_number_and_meaning(
    tcp_ring: Ring, capsys: pytest.CaptureFixture[str]
) -> None:
    port = ("--port", tcp_ring.where, "--timeout", "5")
    code, out, err = uss(capsys, "write", "2", "2", "5", *port, "--json")
    assert (code, err) == (1, "")
    assert json.loads(out) == {
        "ok": False,
        "address": 2,
        "id": 2,
        "error": {
            "type": "BassRefusal",
            "message": "drive 2 refused ID 2: error 5: parameter is write-protected",
            "exit_code": 1,
            "number": 5,
            "meaning": "parameter is write-protected",
        },
    }
    code, out, err = uss(capsys, "write", "2", "2", "5", *port)
    assert err == "uss bass write: drive 2 refused ID 2: error 5: parameter is write-protected\n"
    code, out, err = uss(capsys, "write", "1", "171", "19200", *port)
    assert (code, out) == (1, "")
    assert "error 4: data cannot be changed" in err


def test_no_answer_exits_1(tcp_ring: Ring, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = uss(
        capsys, "read", "9", "170", "--port", tcp_ring.where, "--timeout", "0.3", "--retries", "0"
    )
    assert (code, out) == (1, "")
    assert err.startswith("uss bass read: echo but no answer from drive 9")
    assert err.count("\n") == 1
    code, out, err = uss(capsys, "read", "1", "170", "--port", "/dev/nonexistent-bass")
    assert (code, out) == (1, "")
    assert err.startswith("uss bass read: cannot open serial port /dev/nonexistent-bass")
    assert err.count("\n") == 1
    code, out, err = uss(capsys, "read", "1", "170", "--port", "/dev/nonexistent-bass", "--json")
    data = json.loads(out)
    assert (code, err) == (1, "") and (data["ok"], data["address"], data["id"]) == (False, 1, 170)
    assert data["error"]["message"].startswith("cannot open serial port /dev/nonexistent-bass")
    code, out, err = uss(capsys, "read", "1", "70000", "--port", "/dev/null", "--json")
    assert (code, err) == (2, "")
    assert json.loads(out)["error"] == {
        "type": "ConfigError",
        "message": "ID 70000 is outside 0..65535",
        "exit_code": 2,
    }


@pytest.mark.pty
def test_ring_on_a_pty_read_with_a_serial_port(capsys: pytest.CaptureFixture[str]) -> None:
    ring = Ring("--pty", "--drives", "7")
    try:
        assert ring.where.startswith("/dev/"), ring.proc.stderr
        assert (
            uss(capsys, "write", "7", "2", "7500", "--port", ring.where, "--timeout", "5")[0] == 0
        )
        code, out, _ = uss(capsys, "read", "7", "2", "--port", ring.where, "--timeout", "5")
        assert (code, out) == (0, "7500 (0x1D4C)\n")
    finally:
        code, err = ring.stop(signal.SIGINT)
    assert code == 0, err
    assert "drive 7: 2" in err


@pytest.mark.pty
@pytest.mark.parametrize("action", [["read", "1", "170"], ["write", "1", "170", "0"]])
def test_the_line_is_opened_8n1_at_9600(
    action: list[str],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
) -> None:
    """Baumueller manual 1: 8 data bits, no parity, 1 stop bit, 9600 baud - not USS's 8E1. The
    drive is
    the far end of a pty; the line is opened through ``recording://``, which notes the frame
    (`bass.protocol_recording`: a pty cannot show it)."""
    import tty

    monkeypatch.setattr(serial, "protocol_handler_packages", ["bass"])
    record = tmp_path / "settings"
    pc_end, device = os.openpty()

    def drive() -> None:
        reader = BassLineReader()
        while not (items := reader.feed(os.read(pc_end, 64))):
            pass
        os.write(pc_end, items[0].raw + BassAnswer.value(1, 170, 0x11).encode())

    answering = threading.Thread(target=drive, daemon=True)
    try:
        tty.setraw(device)
        answering.start()
        url = f"recording://{os.ttyname(device)}?record={record}"
        code, _, err = uss(capsys, *action, "--port", url, "--timeout", "5")
        answering.join(TIMEOUT)
    finally:
        os.close(pc_end)
        os.close(device)
    assert code == 0, err
    assert recorded(str(record))[-1] == [9600, 8, "N", 1]


@pytest.mark.pty
def test_ring_keeps_serving_and_stops_cleanly_while_nobody_reads_its_pty() -> None:
    """A PC that sends and never reads fills the pty: the ring's output is lost with a warning,
    it keeps serving, and SIGTERM in the middle of a stuck write is still a clean end."""
    import tty

    ring = Ring("--pty", "--drives", "1")
    fd = os.open(ring.where, os.O_RDWR | os.O_NOCTTY)
    sending = threading.Event()
    sending.set()

    def flood() -> None:
        burst = BassRequest.read(1, 170).encode() * 100
        with contextlib.suppress(OSError):  # the ring has gone: the pty hangs up
            while sending.is_set():
                os.write(fd, burst)

    sender = threading.Thread(target=flood, daemon=True)
    try:
        tty.setraw(fd)
        sender.start()
        assert ring.proc.stderr is not None
        while "the ring's output is lost" not in (line := ring.proc.stderr.readline()):
            assert line, "the ring ended"
        code, err = ring.stop()
    finally:
        sending.clear()
        os.close(fd)
        sender.join(TIMEOUT)
        if ring.proc.poll() is None:
            ring.stop()
    assert code == 0, err
    assert "Traceback" not in err
    assert "requests answered: drive 1: " in err


@pytest.mark.parametrize(
    "args",
    [
        ["read", "256", "170", "--port", "tcp://127.0.0.1:9"],
        ["read", "x", "170", "--port", "tcp://127.0.0.1:9"],
        ["read", "1", "0x10000", "--port", "tcp://127.0.0.1:9"],
        ["read", "1", "170", "--port", "tcp://127.0.0.1"],
        ["read", "1", "170", "--port", "tcp://127.0.0.1:9", "--timeout", "0"],
        ["read", "1", "170", "--port", "tcp://127.0.0.1:9", "--retries", "-1"],
        ["read", "1", "170", "--port", "tcp://127.0.0.1:9", "--baud", "0"],
        ["write", "1", "2", "3", "--port", "tcp://127.0.0.1:9", "--baud", "9601"],
        ["write", "1", "2", "0x10000", "--digits", "4", "--port", "tcp://127.0.0.1:9"],
        ["write", "1", "2", "0x100000000", "--port", "tcp://127.0.0.1:9"],
        ["write", "1", "2", "1.5", "--port", "tcp://127.0.0.1:9"],
        ["ring", "--drives", "1,2"],
        ["ring", "--pty", "--drives", ",".join(str(a) for a in range(17))],
        ["ring", "--pty", "--drives", "1,1"],
        ["ring", "--pty", "--drives", "1", "--locked", "2"],
        ["ring", "--listen", "tcp://127.0.0.1:0"],
        ["ring", "--pty", "--duration", "0"],
    ],
)
def test_bad_input_exits_2_with_one_line(
    args: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = uss(capsys, *args)
    assert (code, out) == (2, "")
    assert err.startswith("uss bass ") and err.count("\n") == 1, err
