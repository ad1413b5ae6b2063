"""``uss simulate`` as a user runs it: a separate process on TCP, a virtual bus or a pty.

Most tests stop it as a user does, by a signal (SIGTERM, SIGINT), and check that it ended
cleanly: POSIX systems only."""

from __future__ import annotations

import importlib.util
import json
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import serial

from pyuss.cli.main import main
from slave.harness import frame
from support.processes import TCP, line_within
from test_userfile import bad_files, refuses

TIMEOUT = 20
READ_P52 = frame(5, "1034 0000 0000 047E 0000")  # C 8.1 example 2
ANSWER_P52 = "02 0C 05 10 34 00 00 40 00 02 31 00 00 5C"
STOPPED = pytest.mark.posix("stops uss simulate with a signal and checks it ended cleanly")


def _start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _first_line(proc: subprocess.Popen[str]) -> str:
    return line_within(proc.stdout, TIMEOUT, "uss simulate printed nothing")


def _line(url: str) -> serial.SerialBase:
    """The line ``tcp://HOST:PORT`` of a simulator or a bus, as pyserial opens it."""
    assert url.startswith("tcp://"), url
    return serial.serial_for_url(f"socket://{url.removeprefix('tcp://')}", timeout=TIMEOUT)


@contextmanager
def simulate(*args: str, stop: signal.Signals = signal.SIGTERM) -> Iterator[tuple[str, list[str]]]:
    """Run ``uss simulate ARGS``; yield the first line it prints and (afterwards) its stderr."""
    proc = _start("simulate", *args)
    err: list[str] = []
    try:
        first = _first_line(proc)
        assert first, proc.stderr.read() if proc.stderr else ""
        yield first, err
    finally:
        proc.send_signal(stop)
        _, stderr = proc.communicate(timeout=TIMEOUT)
        err.append(stderr)
    assert proc.returncode == 0, stderr


def _read_telegram(port: serial.SerialBase) -> bytes:
    head = port.read(2)
    assert len(head) == 2, "no answer"
    return head + port.read(head[1])


@pytest.mark.pty
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_pty_first_line_is_the_device_and_it_stops_cleanly(sig: signal.Signals) -> None:
    with (
        simulate("--pty", "--address", "5", "--layout", "3,2", stop=sig) as (path, err),
        serial.Serial(path, 9600, parity="E", timeout=TIMEOUT) as port,
    ):
        assert path.startswith("/dev/")
        port.write(READ_P52)
        assert _read_telegram(port).hex(" ").upper() == ANSWER_P52
    assert "1 telegrams received, 1 answered" in err[0]


@STOPPED
def test_each_exchange_is_logged_at_debug_level() -> None:
    proc = _start("-vv", "simulate", *TCP, "--address", "5", "--layout", "3,2")
    try:
        with _line(_first_line(proc)) as port:
            port.write(READ_P52)
            assert _read_telegram(port).hex(" ").upper() == ANSWER_P52
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err
    assert (
        "normal adr 5: PKW 1034 0000 0000, PZD 047E 0000 -> "
        "normal adr 5: PKW 1034 0000 4000, PZD 0231 0000"
    ) in err  # the exchange, decoded (pyuss.slave)
    assert "rx t=" in err and "tx t=" in err  # the raw frames (pyuss.wire)
    assert ANSWER_P52 in err


@STOPPED
def test_several_addresses_on_one_line(tmp_path: Path) -> None:
    store = tmp_path / "drive{address}.store"
    with (
        simulate(*TCP, "--address", "1", "--address", "2", "--store", str(store)) as (url, _),
        _line(url) as port,
    ):
        for address in (1, 2):
            port.write(frame(address, "E012 0000 0007 047E 0000"))  # ID 14: P18 = 7, EEPROM
            answer = _read_telegram(port)
            assert answer[2] == address
            assert answer[3:7] == bytes.fromhex("1012 0000")
    assert (tmp_path / "drive1.store").exists()
    assert (tmp_path / "drive2.store").exists()


@STOPPED
def test_tcp_server_and_a_stop_with_a_peer_connected_is_quiet() -> None:
    args = ("--tcp", "127.0.0.1:0", "--address", "5", "--layout", "3,2")
    sock = None
    try:
        with simulate(*args, stop=signal.SIGINT) as (url, err):
            assert url.startswith("tcp://127.0.0.1:")
            port = int(url.rsplit(":", 1)[1])
            sock = socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT)
            sock.sendall(READ_P52)
            data = b""
            while len(data) < 14:
                chunk = sock.recv(64)
                assert chunk
                data += chunk
        # stopped while the peer is still connected: its summary lines, no traceback
    finally:
        if sock is not None:
            sock.close()
    assert data.hex(" ").upper() == ANSWER_P52
    lines = err[0].splitlines()
    assert [line.split(":")[0] for line in lines] == ["uss simulate"] * 2, err[0]


@STOPPED
def test_a_peer_that_floods_the_line_and_leaves_costs_later_masters_at_most_a_telegram() -> None:
    """100 KiB take 117 s on a 9600-baud wire. A peer that writes them and leaves: one
    telegram's worth waits on the simulated line, the rest is dropped (and said so), and the
    next master, ``uss read`` in a process of its own, is answered within its normal timeout."""
    args = ("--tcp", "127.0.0.1:0", "--baud", "9600", "--address", "5", "--layout", "3,2")
    with simulate(*args) as (url, err):
        host, port = url.removeprefix("tcp://").rsplit(":", 1)
        with socket.create_connection((host, int(port)), timeout=TIMEOUT) as sock:
            sock.sendall(bytes(100 * 1024))
        command = ("read", "--port", url, "--baud", "9600", "5", "52")
        read = subprocess.run(
            [sys.executable, "-m", "pyuss.cli.main", *command],
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
    assert read.returncode == 0, read.stderr
    assert read.stdout.startswith("P52 = 16384")
    assert "bytes dropped" in err[0]


@STOPPED
def test_station_of_a_virtual_bus() -> None:
    bus = _start("bus", "--baud", "19200", "--tcp", "127.0.0.1:0", "--bus-tcp", "127.0.0.1:0")
    try:
        assert bus.stdout is not None
        raw = bus.stdout.readline().strip()
        endpoint = bus.stdout.readline().strip().removeprefix("bus://")
        with (
            simulate("--bus", endpoint, "--baud", "19200", "--address", "5", "--layout", "3,2") as (
                first,
                _,
            ),
            _line(raw) as port,
        ):
            assert first == f"bus://{endpoint}"
            port.write(READ_P52)
            assert _read_telegram(port).hex(" ").upper() == ANSWER_P52
    finally:
        bus.send_signal(signal.SIGTERM)
        bus.communicate(timeout=TIMEOUT)


@STOPPED
def test_a_simulator_that_runs_the_bus_itself_serves_masters_and_monitors() -> None:
    """--bus-tcp: the drives sit on a bus of the simulator's own; a master and a monitor in
    other processes join it over bus:// and see the same exchange."""
    with simulate(
        "--bus-tcp", "127.0.0.1:0", "--baud", "187500", "--address", "3", "--address", "17"
    ) as (
        url,
        _,
    ):
        assert url.startswith("bus://127.0.0.1:") and not url.endswith(":0")
        monitor = _start("monitor", "--port", url, "--baud", "187500", "--json")
        try:
            time.sleep(1.0)  # the monitor joins the bus
            for address in ("3", "17"):
                read = subprocess.run(
                    [
                        sys.executable,
                        "-m",
                        "pyuss.cli.main",
                        "read",
                        "--port",
                        url,
                        "--baud",
                        "187500",
                        address,
                        "52",
                        "--json",
                    ],
                    capture_output=True,
                    text=True,
                    timeout=TIMEOUT,
                )
                assert read.returncode == 0, read.stderr
                assert json.loads(read.stdout)["parameters"][0]["value"] == 0x4000
        finally:
            monitor.send_signal(signal.SIGINT)
            out, _ = monitor.communicate(timeout=TIMEOUT)
        seen = [json.loads(line) for line in out.splitlines()]
        assert {e.get("address") for e in seen} >= {3, 17}


@STOPPED
def test_several_simulators_join_one_bus_each_under_its_own_name(tmp_path: Path) -> None:
    """Station names default to simulate-ADDRESSES, so a second simulator process is not
    refused; --name chooses one. The recording shows who answered."""
    record = tmp_path / "wire.jsonl"
    bus = _start(
        *("bus", "--baud", "19200", "--tcp", "127.0.0.1:0", "--bus-tcp", "127.0.0.1:0"),
        *("--record", str(record)),
    )
    try:
        assert bus.stdout is not None
        raw = bus.stdout.readline().strip()
        endpoint = bus.stdout.readline().strip().removeprefix("bus://")
        common = ("--bus", endpoint, "--baud", "19200", "--layout", "3,2")
        with (
            simulate(*common, "--address", "5"),
            simulate(*common, "--address", "6", "--name", "conveyor"),
            _line(raw) as port,
        ):
            for address in (5, 6):
                time.sleep(0.01)  # a master keeps the start pause after the last answer (A 5.1.2)
                port.write(frame(address, "1034 0000 0000 047E 0000"))
                assert _read_telegram(port)[2] == address
    finally:
        bus.send_signal(signal.SIGTERM)
        bus.communicate(timeout=TIMEOUT)
    senders = {json.loads(line).get("from") for line in record.read_text().splitlines()[1:]}
    assert {"simulate-5", "conveyor"} <= senders


@STOPPED
def test_parameter_file_and_read_only(tmp_path: Path) -> None:
    params = tmp_path / "conveyor.toml"
    params.write_text(
        '[profile]\nname = "conveyor"\nextends = "generic"\n\n'
        '[[parameter]]\npnu = 60\nname = "Belt length"\ntype = "uint16"\ndefault = 1234\n'
    )
    with (
        simulate(*TCP, "--address", "5", "--params", str(params), "--read-only") as (url, _),
        _line(url) as port,
    ):
        port.write(frame(5, "103C 0000 0000 0000 0000"))  # read P60 (variable layout)
        assert _read_telegram(port)[3:9] == bytes.fromhex("103C 0000 04D2")
        port.write(frame(5, "203C 0000 0001 0000 0000"))  # write: no authority
        assert _read_telegram(port)[3] >> 4 == 8


@STOPPED
def test_power_cycle_eeprom_writes_survive_a_kill(tmp_path: Path) -> None:
    """The simulator is killed (no clean stop) right after answering an EEPROM write: the value
    was on disk before the answer, so it is there after a restart; a RAM write is not."""
    store = tmp_path / "drive5.store"
    args = ("simulate", *TCP, "--address", "5", "--layout", "3,2", "--store", str(store))
    first = _start(*args)
    try:
        with _line(_first_line(first)) as port:
            port.write(frame(5, "E012 0000 1234 047E 0000"))  # ID 14: P18 = 1234h, EEPROM
            assert _read_telegram(port)[3:9] == bytes.fromhex("1012 0000 1234")
            port.write(frame(5, "21C1 0000 0007 047E 0000"))  # ID 2: P449 = 7, RAM only
            assert _read_telegram(port)[3:9] == bytes.fromhex("11C1 0000 0007")
    finally:
        first.kill()
        first.communicate(timeout=TIMEOUT)
    with simulate(*args[1:]) as (url, _), _line(url) as port:
        port.write(frame(5, "1012 0000 0000 047E 0000"))
        assert _read_telegram(port)[3:9] == bytes.fromhex("1012 0000 1234")
        port.write(frame(5, "11C1 0000 0000 047E 0000"))
        assert _read_telegram(port)[3:9] == bytes.fromhex("11C1 0000 FE0C")  # factory -500
    assert [p.name for p in tmp_path.iterdir()] == ["drive5.store"]  # no temporary file left


def test_a_damaged_store_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "drive.store"
    store.write_bytes(b"pyuss-drive-store 1 sha256=" + b"0" * 64 + b" bytes=2\n{}")
    code = main(["simulate", *TCP, "--store", str(store), "--duration", "5"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1
    assert "drive.store" in err and "corrupt" in err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ([*TCP, "--address", "40"], "addresses are 0..31"),
        ([*TCP, "--address", "3", "--address", "3"], "each address may be given once"),
        ([*TCP, "--layout", "5,2"], "PKW count must be 0, 3, 4 or 127"),
        ([*TCP, "--profile", "nope"], "unknown profile 'nope'"),
        ([*TCP, "--baud", "1234"], "not a USS baud rate"),
        ([*TCP, "--profile", "6se21", "--layout", "4,2"], "fixed layout 3,2 only"),
        ([*TCP, "--address", "1", "--address", "2", "--store", "x"], "{address}"),
        (["--tcp", "localhost"], "HOST:PORT"),
        ([*TCP, "--response-delay", "50"], "outside the window"),
        ([*TCP, "--params", "/nonexistent.toml"], "cannot read parameter file"),
        ([*TCP, "--failure-time", "inf"], "--failure-time inf: must be a number of seconds"),
        ([*TCP, "--failure-time", "-1"], "--failure-time -1.0: must be a number of seconds"),
        ([*TCP, "--latency-time", "nan"], "--latency-time must be numbers >= 0"),
        ([*TCP, "--latency", "-2"], "--latency-time must be numbers >= 0"),
        (
            [*TCP, "--profile", "micromaster420", "--baud", "115200"],
            "a micromaster420 drive does not run at 115200 baud (P2010.",
        ),
        ([*TCP, "--baud", "115200"], "a generic drive does not run at 115200 baud (P684.1:"),
        ([*TCP, "--failure-time", "7"], "takes 0..6.5 s (P687.1)"),
        ([*TCP, "--profile", "nord", "--failure-time", "0.25"], "steps of 0.1 s (P513)"),
        ([*TCP, "--name", "x"], "--name: a station name is for --bus and --bus-tcp only"),
        (["--bus-tcp", "localhost"], "--bus-tcp 'localhost': expected HOST:PORT"),
        (["--bus-tcp", "192.0.2.1:0"], "--bus-tcp: cannot listen on 192.0.2.1:0"),
        (["--bus-tcp", ":0", "--profile", "bass"], "a BASS ring is RS-232"),
        (["--bus-tcp", ":0", "--profile", "ksvario"], "start uss bus --bus-tcp and use --bus"),
        (["--bus", "127.0.0.1:1", "--name", "a+b"], "--name 'a+b': give a non-empty name"),
        (
            [*TCP, "--profile", "bass", "--params", "x.toml", "--read-only"],
            "profile bass does not take --params, --read-only (USS drive options)",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", *args, "--duration", "5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert message in err


def test_a_parameter_file_that_is_none_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for params, message in bad_files(tmp_path, "parameter file"):
        for command in (["simulate", *TCP, "--duration", "5"], ["params"]):
            assert main([*command, "--params", str(params)]) == 2
            line, *more = capsys.readouterr().err.splitlines()
            assert not more and refuses(line.removeprefix(f"uss {command[0]}: "), params, message)


def test_a_layout_from_the_parameter_file_the_profile_refuses_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    params = tmp_path / "mine.toml"
    params.write_text('[profile]\nname = "mine"\nextends = "generic"\n')  # P685.1 = 127
    assert main(["simulate", *TCP, "--profile", "baumueller", "--params", str(params)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "not v,2 (the layout of the parameter file's interface parameters P685.1" in err


def test_stops_by_itself_after_duration() -> None:
    proc = _start("simulate", *TCP, "--duration", "0.3")
    out, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err
    assert out.splitlines()[0].startswith("tcp://127.0.0.1:")


@STOPPED
def test_other_protocols_plug_in_by_profile() -> None:
    """``--profile ksvario`` runs the KS VARIO simulator where it is installed."""
    if importlib.util.find_spec("pyuss.ksvario.simulate") is None:
        proc = _start("simulate", "--profile", "ksvario", *TCP, "--duration", "5")
        _, err = proc.communicate(timeout=TIMEOUT)
        assert proc.returncode == 2
        assert "KS VARIO simulator is not installed" in err
        return
    with simulate("--profile", "ksvario", *TCP, "--address", "5") as (url, _):
        assert url.startswith("tcp://127.0.0.1:")


def test_serial_port_by_pyserial_url() -> None:
    proc = _start("simulate", "--serial", "loop://", "--duration", "0.3", "--address", "5")
    out, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err
    assert out.splitlines()[0] == "loop://"


@STOPPED
def test_bass_ring_plugs_in_by_profile() -> None:
    """``--profile bass``: a BASS ring; Baumueller manual 1.1 example 2 reads ID 51 of drive 0."""
    request = b"#00003C0033FD\r\n"
    with (
        simulate("--profile", "bass", *TCP, "--address", "0") as (url, _),
        _line(url) as port,
    ):
        port.write(request)
        assert port.read_until(b"\n") == request  # the drive echoes the request first
        answer = port.read_until(b"\n")
    assert answer.startswith(b"#00") and answer.endswith(b"\r\n")


def _ask(port: serial.SerialBase, net: str) -> bytes:
    """Send a PKW 3, PZD 2 request to drive 5 and return the answer's PWE word."""
    port.write(frame(5, net))
    return _read_telegram(port)[7:9]


@STOPPED
def test_interface_parameters_show_what_is_in_force() -> None:
    """C 3.1, C 3.2: P684.1 shows the rate the line runs at (7 = 19200 baud), P687.1 the
    telegram failure time in force (300 ms)."""
    args = (*TCP, "--address", "5", "--layout", "3,2", "--baud", "19200")
    with simulate(*args, "--failure-time", "0.3") as (url, err), _line(url) as port:
        baud = _ask(port, "62AC 0001 0000 047E 0000")  # ID 6: P684 index 1
        failure = _ask(port, "62AF 0001 0000 047E 0000")  # ID 6: P687 index 1
    assert baud == bytes.fromhex("0007")
    assert failure == bytes.fromhex("012C")
    assert "19200 baud" in err[0]


@STOPPED
def test_a_stored_baud_rate_is_the_rate_of_the_next_start(tmp_path: Path) -> None:
    """Two drives share the line, so its rate stays while it runs: a RAM write is refused
    (error 1), an EEPROM write is stored, and the next start without --baud runs at it and
    shows it."""
    store = str(tmp_path / "drive{address}.store")
    args = (*TCP, "--address", "5", "--layout", "3,2", "--store", store)
    with simulate(*args, "--address", "6") as (url, err), _line(url) as port:
        port.write(frame(5, "72AC 0001 0007 047E 0000"))  # ID 7: P684.1 = 7, RAM
        assert _read_telegram(port)[3:9] == bytes.fromhex("72AC 0001 0001")  # refused, error 1
        port.write(frame(5, "C2AC 0001 0007 047E 0000"))  # ID 12: P684.1 = 7, EEPROM
        assert _read_telegram(port)[3:9] == bytes.fromhex("42AC 0001 0007")
    assert "9600 baud" in err[0]
    with simulate(*args) as (url, err), _line(url) as port:
        baud = _ask(port, "62AC 0001 0000 047E 0000")
    assert baud == bytes.fromhex("0007")
    assert "19200 baud" in err[0]


@pytest.mark.parametrize(
    ("argv", "lines"),
    [
        (["simulate", "--tcp", ":0"], 1),
        (["simulate", "--profile", "ksvario", "--tcp", "127.0.0.1:0"], 1),
        (["simulate", "--profile", "bass", "--tcp", ":0"], 1),
        (["simulate", "--profile", "baumueller", "--tcp", ":0", "--bass-tcp", ":0"], 2),
        (["ksvario", "simulate", "--port", "tcp-listen://127.0.0.1:0"], 1),
        (["bass", "ring", "--listen", "tcp-listen://127.0.0.1:0"], 1),
        (["bus", "--tcp", "127.0.0.1:0", "--bus-tcp", "127.0.0.1:0"], 2),
    ],
    ids=lambda v: " ".join(v) if isinstance(v, list) else str(v),
)
@STOPPED
def test_a_server_on_port_0_prints_the_port_it_listens_on(argv: list[str], lines: int) -> None:
    proc = _start(*argv)
    try:
        printed = [_first_line(proc)]
        assert proc.stdout is not None
        printed += [proc.stdout.readline().strip() for _ in range(lines - 1)]  # printed at once
        tcp = [line for line in printed if "://" in line]
        assert tcp, printed
        for url in tcp:
            host, port = url.split("://", 1)[1].rsplit(":", 1)
            assert int(port) > 0, url
            socket.create_connection((host, int(port)), timeout=TIMEOUT).close()
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err


def _recv(sock: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = sock.recv(256)
        assert chunk, f"connection closed after {data!r}"
        data += chunk
    return data


def _uss_master(host: str, port: int) -> None:
    with socket.create_connection((host, port), timeout=TIMEOUT) as sock:
        sock.sendall(READ_P52)
        assert _recv(sock, 14).hex(" ").upper() == ANSWER_P52


def _bass_master(host: str, port: int) -> None:
    request = b"#00003C0033FD\r\n"  # Baumueller 1.1 example 2: read ID 51 of drive 0
    with socket.create_connection((host, port), timeout=TIMEOUT) as sock:
        sock.sendall(request)
        data = _recv(sock, len(request) + 1)
        while data.count(b"\n") < 2:
            data += _recv(sock, 1)
    assert data.startswith(request) and data.endswith(b"\r\n")


def _ksvario_master(host: str, port: int) -> None:
    assert main(["ksvario", "read", "0x4496", "--port", f"tcp://{host}:{port}"]) == 0


@pytest.mark.parametrize(
    ("argv", "master"),
    [
        (["simulate", "--tcp", ":0", "--address", "5", "--layout", "3,2"], _uss_master),
        (["bass", "ring", "--listen", "tcp-listen://127.0.0.1:0", "--drives", "0"], _bass_master),
        (["ksvario", "simulate", "--port", "tcp-listen://127.0.0.1:0"], _ksvario_master),
    ],
    ids=["uss simulate --tcp", "uss bass ring", "uss ksvario simulate"],
)
@STOPPED
def test_idle_tcp_clients_never_lock_a_master_out(argv: list[str], master: Any) -> None:
    """One idle client, and then as many as the server has places (8): a master that
    connects after them is still served (several peers; the one silent longest gives way)."""
    proc = _start(*argv)
    idle: list[socket.socket] = []
    try:
        host, port = _first_line(proc).split("://", 1)[1].rsplit(":", 1)
        idle.append(socket.create_connection((host, int(port)), timeout=TIMEOUT))
        master(host, int(port))
        idle += [socket.create_connection((host, int(port)), timeout=TIMEOUT) for _ in range(8)]
        master(host, int(port))
    finally:
        for sock in idle:
            sock.close()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, err
