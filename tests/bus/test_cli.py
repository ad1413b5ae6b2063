"""``uss bus`` as a user runs it: a separate process, ptys and sockets, stopped by a signal
(POSIX systems)."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import serial

from pyuss.cli.main import main

TIMEOUT = 20


def _start(*args: str, command: str = "bus") -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", command, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _lines(proc: subprocess.Popen[str], n: int) -> list[str]:
    assert proc.stdout is not None
    return [proc.stdout.readline().strip() for _ in range(n)]


@pytest.mark.pty
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ptys_carry_bytes_until_stopped(tmp_path: Path, sig: signal.Signals) -> None:
    record = tmp_path / "wire.jsonl"
    proc = _start("--baud", "19200", "--pty", "2", "--record", str(record))
    try:
        paths = _lines(proc, 2)
        assert all(p.startswith("/dev/") for p in paths), paths
        with (
            serial.Serial(paths[0], 19200, parity="E", timeout=TIMEOUT) as master,
            serial.Serial(paths[1], 19200, parity="E", timeout=TIMEOUT) as slave,
        ):
            master.write(bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55"))
            assert slave.read(14).hex() == "020c05103400000000047e000055"
            slave.write(b"\x02\x02\x00\x00")
            assert master.read(4) == b"\x02\x02\x00\x00"
    finally:
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err
    assert "18 characters, 0 collisions" in err
    lines = record.read_text().splitlines()
    assert json.loads(lines[0])["baud"] == 19200
    assert [json.loads(line)["from"] for line in lines[1:]] == ["pty1"] * 14 + ["pty2"] * 4


@pytest.mark.posix("stops uss bus with SIGINT and checks it ended cleanly")
def test_tcp_and_bus_endpoints_are_printed_and_a_stop_with_stations_on_is_quiet() -> None:
    proc = _start("--tcp", "127.0.0.1:0", "--bus-tcp", "127.0.0.1:0", "--duration", "30")
    err = ""
    try:
        tcp, bus = _lines(proc, 2)
        assert tcp.startswith("tcp://127.0.0.1:")
        assert bus.startswith("bus://127.0.0.1:")
        port = int(tcp.rsplit(":", 1)[1])
        with (
            serial.serial_for_url(f"socket://127.0.0.1:{port}", timeout=TIMEOUT) as a,
            serial.serial_for_url(f"socket://127.0.0.1:{port}", timeout=TIMEOUT) as b,
        ):
            # Wait until the bus has both stations: b's bytes must reach a.
            a.timeout = 0.2
            for _ in range(100):
                b.write(b"\x02")
                if a.read(1) == b"\x02":
                    break
            a.timeout = TIMEOUT
            a.reset_input_buffer()
            b.write(b"\x02\x02\x00\x00")
            assert a.read(4) == b"\x02\x02\x00\x00"
            # stopped while both stations are still connected
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=TIMEOUT)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0
    # the summary, and no traceback of a station's connection ended by the stop
    [summary] = err.splitlines()
    assert summary.startswith("uss bus: ") and "0 collisions" in summary, err


def _connected(sock: socket.socket) -> bool:
    """Whether the bus still holds ``sock`` (it has sent nothing, so nothing is to be read)."""
    sock.setblocking(False)
    try:
        return sock.recv(1) != b""
    except BlockingIOError:
        return True
    except OSError:
        return False


@pytest.mark.posix("stops uss bus and uss simulate with SIGTERM and checks they ended cleanly")
def test_silent_raw_connections_never_lock_out_a_simulator_or_a_bus_master() -> None:
    """40 raw TCP connections that connect and stay silent: 32 hold every sending place (B 1),
    the last 8 in the places of the first 8. Then a ``uss simulate --bus`` joins and a
    ``bus://`` master (``uss read``) is answered, each in the place of the silent raw station
    that came first; the other silent raw stations stay connected."""
    proc = _start("--tcp", "127.0.0.1:0", "--bus-tcp", "127.0.0.1:0", "--duration", "120")
    idle: list[socket.socket] = []
    sim: subprocess.Popen[str] | None = None
    try:
        tcp, bus = _lines(proc, 2)
        host, port = tcp.removeprefix("tcp://").rsplit(":", 1)
        idle = [socket.create_connection((host, int(port)), timeout=TIMEOUT) for _ in range(40)]
        time.sleep(2)
        sim = _start("--bus", bus.removeprefix("bus://"), "--address", "5", command="simulate")
        assert sim.stdout is not None
        assert sim.stdout.readline().strip() == bus  # printed once it is on the bus
        read = subprocess.run(
            [sys.executable, "-m", "pyuss.cli.main", "read", "--port", bus, "5", "52"],
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
        assert read.returncode == 0, read.stderr
        assert read.stdout.startswith("P52 = 16384")
        assert sum(_connected(sock) for sock in idle) == 32 - 2
    finally:
        if sim is not None:
            sim.send_signal(signal.SIGTERM)
            sim.communicate(timeout=TIMEOUT)
        for sock in idle:
            sock.close()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err
    assert sim.returncode == 0


@pytest.mark.pty
def test_echo_for_the_named_station_only() -> None:
    proc = _start("--baud", "38400", "--pty", "2", "--echo", "pty1", "--duration", "60")
    try:
        paths = _lines(proc, 2)
        with (
            serial.Serial(paths[0], 38400, parity="E", timeout=TIMEOUT) as one,
            serial.Serial(paths[1], 38400, parity="E", timeout=TIMEOUT) as two,
        ):
            one.write(b"\x02\x02\x00\x00")
            assert two.read(4) == b"\x02\x02\x00\x00"
            assert one.read(4) == b"\x02\x02\x00\x00"  # pty1 hears itself
            two.write(b"\x02\x02\x01\x01")
            assert one.read(4) == b"\x02\x02\x01\x01"
            one.write(b"\x02\x02\x02\x02")
            assert two.read(4) == b"\x02\x02\x02\x02"  # pty2 did not hear itself before
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err


def test_a_bus_that_cannot_start_leaves_no_recording(tmp_path: Path) -> None:
    record = tmp_path / "wire.jsonl"
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        proc = _start("--tcp", f"127.0.0.1:{port}", "--record", str(record), "--duration", "5")
        _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 1
    assert f"cannot listen on 127.0.0.1:{port}" in err
    assert len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("args", "words"),
    [
        ([], "nothing to serve"),
        (["--pty", "33"], "--pty 33: give 0..32 ptys"),
        (["--pty", "-1"], "--pty -1: give 0..32 ptys"),
        (["--pty", "1", "--baud", "14400"], "14400 is not a USS baud rate"),
        (["--pty", "1", "--fault", "flip:p=7"], "probability"),
        (["--tcp", "127.0.0.1"], "HOST:PORT"),
        (["--pty", "1", "--record", "/nonexistent/dir/x.jsonl"], "cannot write a recording"),
        (["--pty", "1", "--duration", "0"], "--duration"),
        (["--pty", "2", "--duration", "1", "--fault", "deaf:station=pty9,at=1,for=1"], "'pty9'"),
        (["--pty", "2", "--duration", "1", "--fault", "flip:station=master,p=0.1"], "'master'"),
        (["--tcp", "127.0.0.1:0", "--duration", "1", "--fault", "dead:station=pty1"], "'pty1'"),
        (["--pty", "2", "--duration", "1", "--echo", "pty1,pty3"], "--echo: no station 'pty3'"),
        (["--pty", "2", "--duration", "1", "--echo", "master"], "--echo: no station 'master'"),
        (["--pty", "2", "--bus-tcp", "127.0.0.1:0", "--echo", "m"], "--echo: no station 'm'"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    args: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bus", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err
    assert len(err.splitlines()) == 1
