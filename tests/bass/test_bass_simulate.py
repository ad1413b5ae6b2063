"""``uss simulate --profile baumueller`` with its BASS side, as a user runs it: one process, the
USS line on one TCP port and the BASS ring on another (or a serial device), reached with
pyserial, ``uss bass``, ``uss read``/``uss write`` and the USS master - one drive behind two
interfaces. The simulator is stopped with SIGTERM and must end cleanly: POSIX systems only."""

from __future__ import annotations

import asyncio
import json
import os
import select
import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import serial

from bass.protocol_recording import recorded
from pyuss.bass.codec import BassAnswer, BassRequest, decode_answer
from pyuss.bass.master import BassMaster
from pyuss.cli.main import main
from pyuss.master import Master, SpontaneousMessage
from pyuss.transport import PtyPort, open_transport
from support.paths import load_vectors
from support.processes import TCP, line_within

TIMEOUT = 20  # generous: real ptys and a second process on a loaded machine
PORT_OPTIONS = ("--timeout", "5")
BASS_TCP = ("--bass-tcp", "127.0.0.1:0")
STOPPED = pytest.mark.posix("stops uss simulate with SIGTERM and checks it ended cleanly")


class Simulator:
    def __init__(self, proc: subprocess.Popen[str], uss: str, bass: str) -> None:
        self.proc = proc
        self.uss = uss
        self.bass = bass
        self.stderr = ""


@contextmanager
def simulate(*args: str) -> Iterator[Simulator]:
    """``uss simulate --profile baumueller ARGS``: its first line (USS) and second (BASS)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", "simulate", "--profile", "baumueller", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    try:
        lines = [line_within(proc.stdout, TIMEOUT, "uss simulate printed no device")]
        lines.append(proc.stdout.readline().strip())  # "" if it ended
        assert all(lines), proc.communicate(timeout=TIMEOUT)[1]
        sim = Simulator(proc, *lines)
        yield sim
    finally:
        proc.send_signal(signal.SIGTERM)
        _, sim_err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0, sim_err
    sim.stderr = sim_err


def uss(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def bass_json(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, dict[str, object]]:
    code, out, _ = uss(capsys, "bass", *args, *PORT_OPTIONS, "--json")
    return code, json.loads(out)


def _line(url: str) -> serial.SerialBase:
    """The line ``tcp://HOST:PORT`` of the simulator, as pyserial opens it."""
    assert url.startswith("tcp://"), url
    return serial.serial_for_url(f"socket://{url.removeprefix('tcp://')}", timeout=TIMEOUT)


@STOPPED
def test_both_document_vectors_byte_for_byte_and_the_uss_side_sees_them(
    capsys: pytest.CaptureFixture[str],
) -> None:
    vectors = [v["line"].replace("\\r\\n", "\r\n").encode() for v in load_vectors("bass")["lines"]]
    with simulate(*TCP, *BASS_TCP, "--address", "0") as sim:
        assert sim.uss.startswith("tcp://") and sim.bass.startswith("tcp://")
        assert sim.uss != sim.bass
        with _line(sim.bass) as port:
            port.write(vectors[0])  # ID 2 = 1D4Ch = 75.00 %
            assert port.read_until(b"\n") == vectors[0]  # the echo, byte for byte
            assert port.read_until(b"\n") == BassAnswer.value(0, 2, 0x1D4C).encode()
            port.write(vectors[1])  # read ID 51
            assert port.read_until(b"\n") == vectors[1]
            answer = decode_answer(port.read_until(b"\n"))
            assert (answer.address, answer.ident, answer.is_error) == (0, 51, False)
        code, out, _ = uss(
            capsys, "read", "0", "2", "--port", sim.uss, "--profile", "baumueller", "--json"
        )
        assert code == 0
        [value] = json.loads(out)["parameters"]
        assert (value["pnu"], value["raw"], value["value"], value["unit"]) == (2, [7500], 75.0, "%")
    assert "BASS requests answered: drive 0: 2" in sim.stderr


@STOPPED
def test_a_ring_of_three_drives_in_address_order(capsys: pytest.CaptureFixture[str]) -> None:
    with simulate(*TCP, *BASS_TCP, "--address", "3", "--address", "1", "--address", "2") as sim:
        port = ("--port", sim.bass)
        for address in (1, 2, 3):
            code, result = bass_json(capsys, "read", str(address), "170", *port)
            assert code == 0
            assert result["value"] == address << 4 | 1  # RUN, the drive's address
            code, result = bass_json(capsys, "read", str(address), "171", *port)
            assert (code, result["value"], result["data"]) == (0, 9600, "2580")
        code, result = bass_json(capsys, "write", "2", "2", "-7500", *port)
        assert (code, result["ok"], result["data"]) == (0, True, "E2B4")
        code, out, _ = uss(capsys, "bass", "read", "2", "2", "--signed", *port, *PORT_OPTIONS)
        assert (code, out) == (0, "-7500 (0xE2B4)\n")
        code, result = bass_json(capsys, "read", "1", "2", *port)
        assert result["value"] == 0  # each drive has its own parameters
        code, out, err = uss(
            capsys, "bass", "read", "9", "170", *port, "--timeout", "0.5", "--retries", "0"
        )
        assert (code, out) == (1, "")
        assert "echo but no answer from drive 9" in err
    assert "ring of drives 1, 2, 3" in sim.stderr
    assert "BASS requests answered: drive 1: 3, drive 2: 4, drive 3: 2" in sim.stderr


@STOPPED
def test_write_authority_set_over_uss_holds_for_bass(capsys: pytest.CaptureFixture[str]) -> None:
    with simulate(*TCP, *BASS_TCP, "--address", "1") as sim:
        on_uss = ("--port", sim.uss, "--profile", "baumueller", *PORT_OPTIONS)
        on_bass = ("--port", sim.bass)
        assert uss(capsys, "write", "1", "126", "0", "--raw", *on_uss)[0] == 0  # 126 bit 0 = 0
        code, result = bass_json(capsys, "write", "1", "2", "100", *on_bass)
        assert (code, result) == (
            1,
            {
                "ok": False,
                "address": 1,
                "id": 2,
                "error": {
                    "type": "BassRefusal",
                    "message": "drive 1 refused ID 2: error 5: parameter is write-protected",
                    "exit_code": 1,
                    "number": 5,
                    "meaning": "parameter is write-protected",
                },
            },
        )
        code, result = bass_json(capsys, "write", "1", "126", "1", *on_bass)
        assert (code, result["error"]["number"]) == (
            1,
            5,
        )  # BASS cannot give itself the authority back
        code, result = bass_json(capsys, "read", "1", "170", *on_bass)
        assert result["value"] == 0x0010  # STOP, address 1
        code, out, _ = uss(capsys, "read", "1", "170", *on_uss, "--json")
        assert json.loads(out)["parameters"][0]["value"] == 0x0010  # the same word over USS
        assert uss(capsys, "write", "1", "126", "1", "--raw", *on_uss)[0] == 0
        code, result = bass_json(capsys, "write", "1", "2", "100", *on_bass)
        assert (code, result["value"]) == (0, 100)
        code, result = bass_json(capsys, "read", "1", "170", *on_bass)
        assert result["value"] == 0x0011  # RUN


@STOPPED
async def test_uss_master_sees_a_bass_write_as_a_spontaneous_message() -> None:
    """C 4.2.1.2 through both lines of one ``uss simulate``: the drive answers USS jobs 40
    telegrams late, so the master's job is open when a BASS write of the active parameter 2
    comes; the master gets it through its callback, acknowledges it, and the job goes on."""
    with simulate(*TCP, *BASS_TCP, "--address", "4", "--latency", "40") as sim:
        events: list[object] = []
        async with Master(sim.uss, baud=9600, profile="baumueller", layout="3,2") as bus:
            drive = bus.drive(4)
            drive.on_spontaneous(events.append)
            job = asyncio.create_task(drive.read(61, timeout=60))
            job.add_done_callback(lambda _: events.append("job done"))
            for _ in range(4):
                await drive.next_update(timeout=TIMEOUT)
            async with open_transport(sim.bass, baud=9600, parity="N") as line:
                await BassMaster(line, timeout=5).write(4, 2, 7500)
            assert await asyncio.wait_for(job, 60) == 2000
            spontaneous = drive.diagnostics().jobs.spontaneous
    assert len(events) == 2 and events[1] == "job done", events
    message = events[0]
    assert isinstance(message, SpontaneousMessage)
    assert (message.address, message.pnu, message.value) == (4, 2, 7500)
    assert spontaneous == 1


@STOPPED
def test_both_interfaces_over_tcp(capsys: pytest.CaptureFixture[str]) -> None:
    with simulate("--tcp", "127.0.0.1:0", "--bass-tcp", "127.0.0.1:0", "--address", "6") as sim:
        assert sim.uss.startswith("tcp://127.0.0.1:") and sim.bass.startswith("tcp://127.0.0.1:")
        assert sim.uss != sim.bass
        code, result = bass_json(capsys, "read", "6", "170", "--port", sim.bass)
        assert (code, result["value"]) == (0, 0x0061)
    assert "BASS (RS-232, 9600 baud 8N1) on tcp://127.0.0.1:" in sim.stderr


@pytest.mark.pty
async def test_bass_side_on_a_serial_device() -> None:
    """``--bass-serial DEVICE``: the simulator opens a serial device (here the far end of a pty
    this test holds, as a PC's null-modem cable would be) at 9600 8N1."""
    async with PtyPort(baud=9600) as pc:
        assert isinstance(pc, PtyPort)
        with simulate(*TCP, "--bass-serial", pc.device_path, "--address", "2") as sim:
            assert sim.bass == pc.device_path
            assert await BassMaster(pc, timeout=5).read(2, 170) == 0x0021
    assert f"BASS (RS-232, 9600 baud 8N1) on {pc.device_path}" in sim.stderr


@pytest.mark.parametrize(
    "args",
    [
        ["--profile", "generic", "--pty", "--bass-pty"],
        ["--profile", "bass", "--pty", "--bass-pty"],
        ["--profile", "baumueller", "--pty", "--bass-tcp", "nowhere"],
        ["--profile", "baumueller", "--pty", "--bass-serial", " "],
        ["--profile", "baumueller", "--tcp", ":5555", "--bass-tcp", "127.0.0.1:5555"],
        ["--profile", "baumueller", "--pty", "--bass-pty", *(f"--address={a}" for a in range(17))],
    ],
)
def test_bad_bass_options_exit_2_with_one_line(
    args: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = uss(capsys, "simulate", *args)
    assert (code, out) == (2, "")
    assert err.startswith("uss simulate: --") and err.count("\n") == 1, err


RECORDING_MAIN = (
    "import sys, serial; serial.protocol_handler_packages.append('bass'); "
    "from pyuss.cli.main import main; sys.exit(main(sys.argv[1:]))"
)


@pytest.mark.parametrize(
    ("args", "lines"),
    [
        (["--profile", "baumueller", *TCP, "--bass-serial"], 2),
        (["--profile", "bass", "--serial"], 1),
    ],
)
@pytest.mark.pty
def test_the_simulators_bass_serial_line_is_8n1_at_9600(
    args: list[str], lines: int, tmp_path: Path
) -> None:
    """Baumueller manual 1: the drives' side of the RS-232 line is 8N1 at 9600 baud too, whatever
    the
    USS side uses. The PC is the far end of a pty; the simulator opens the device through
    ``recording://`` (`bass.protocol_recording`), which notes the frame a pty cannot show."""
    import tty

    record = tmp_path / "settings"
    pc_end, device = os.openpty()
    try:
        tty.setraw(device)
        url = f"recording://{os.ttyname(device)}?record={record}"
        proc = subprocess.Popen(
            [sys.executable, "-c", RECORDING_MAIN, "simulate", *args, url, "--address", "2"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=os.environ | {"PYTHONPATH": str(Path(__file__).parents[1])},
        )
        try:
            assert proc.stdout is not None
            printed = [proc.stdout.readline().strip() for _ in range(lines)]
            assert printed[-1] == url, proc.communicate(timeout=TIMEOUT)[1]
            request = BassRequest.read(2, 170).encode()
            os.write(pc_end, request)
            back = b""
            while back.count(b"\n") < 2:
                ready, _, _ = select.select([pc_end], [], [], TIMEOUT)
                assert ready, "no echo and answer"
                back += os.read(pc_end, 64)
        finally:
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=TIMEOUT)
    finally:
        os.close(pc_end)
        os.close(device)
    assert proc.returncode == 0, err
    assert back == request + BassAnswer.value(2, 170, 0x21).encode()
    assert recorded(str(record))[-1] == [9600, 8, "N", 1]
