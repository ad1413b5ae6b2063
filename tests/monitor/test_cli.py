"""``uss monitor`` and ``uss wireshark`` as a user runs them: on captures, and for real on
``bus://`` stations, a pty and two ports of a 4-wire line, in a separate process."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from monitor.traffic import REQ_52, Slave, Wire, answer, drive, request
from pyuss.bus import VirtualBus
from pyuss.cli.main import main
from pyuss.cli.monitor_output import ProfileValues
from pyuss.monitor import (
    LayoutBook,
    Listener,
    Monitor,
    dissector_source,
    open_writer,
    read_capture,
)
from pyuss.protocol import Layout, Pkw
from pyuss.protocol.telegram import Telegram
from pyuss.transport.serialport import SerialTransport

BAUD = 38400
TIMEOUT = 30
JOBS = [REQ_52, request(5, Pkw(2, 18, values=(0x7000,))), request(5, Pkw(1, 99))]
EXCHANGE_KEYS = {
    "index",
    "time",
    "t",
    "error",
    "kind",
    "address",
    "mode",
    "layout",
    "layout_source",
    "request",
    "answer",
    "delay_ms",
    "problems",
    "unsure",
    "notes",
    "summary",
}
FRAME_KEYS = {
    "start",
    "end",
    "hex",
    "direction",
    "guessed",
    "port",
    "address",
    "mode",
    "fault",
    "detail",
    "telegram",
}


def _silent_for_99(tg: object) -> bytes | None:
    from monitor.traffic import echo_job

    job = Layout(3, 2).unpack(tg.data).pkw  # type: ignore[attr-defined]
    return None if job is not None and job.pnu == 99 else echo_job()(tg)  # type: ignore[arg-type]


SLAVES = [Slave(5, _silent_for_99, delay=0.004)]


def _capture(path: Path) -> None:
    monitor = Monitor(19200, layouts=LayoutBook(Layout(3, 2)))
    wire = Wire(monitor)
    wire.send(REQ_52, 0.01)
    wire.send(answer(5, Pkw(1, 52, values=(16384,))), 0.004)
    wire.send(request(5, Pkw(1, 53)), 0.01)
    bad = bytearray(answer(5, Pkw(1, 53, values=(1,))))
    bad[-1] ^= 0x10
    wire.send(bytes(bad), 0.004)
    wire.send(request(5, Pkw(1, 54)), 0.01)
    writer = open_writer(path, baud=19200, gap=monitor.gap)
    for ex in wire.finish():
        writer.write(ex)
    writer.close()


def test_read_prints_one_line_per_exchange(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "line.pcapng"
    _capture(path)
    assert main(["monitor", "--read", str(path)]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert len(lines) == 3
    assert lines[0].split()[0] == "0.000000"
    assert "adr 5" in lines[0] and "read P52 -> P52 = 16384 (4000h)" in lines[0]
    assert "4.000 ms" in lines[0] and "!!" not in lines[0]
    assert "!! bcc: BCC is" in lines[1]
    assert "!! no_answer: address 5 did not answer within 20.000 ms" in lines[2]
    assert err.splitlines()[0].startswith("adr   layout")
    assert err.splitlines()[1].startswith("5     3,2 given")


@pytest.mark.posix("time.tzset")
def test_wall_clock_times_and_colours(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TZ", "UTC")
    time.tzset()
    try:
        path = tmp_path / "line.pcapng"
        _capture(path)  # frames at 100 s after the epoch: 00:01:40 UTC
        args = ["monitor", "--read", str(path), "--time", "abs", "--color", "always"]
        assert main(args) == 0
        lines = capsys.readouterr().out.splitlines()
        assert [line.split()[0] for line in lines] == [
            "00:01:40.010000",
            "00:01:40.040042",
            "00:01:40.070083",
        ]
        assert "\x1b[" not in lines[0]  # nothing to highlight
        assert lines[1].endswith("\x1b[31m!! bcc: " + lines[1].split("!! bcc: ")[1])
        assert lines[1].endswith("\x1b[0m") and "\x1b[31m!! no_answer" in lines[2]
        assert main(["monitor", "--read", str(path), "--color", "never"]) == 0
        assert "\x1b[" not in capsys.readouterr().out
    finally:
        monkeypatch.delenv("TZ")
        time.tzset()


def test_read_json_and_convert(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "line.pcapng"
    _capture(path)
    out_path = tmp_path / "copy.jsonl"
    code = main(["monitor", "--read", str(path), "--json", "--count", "2", "-w", str(out_path)])
    assert code == 0
    items = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert len(items) == 2
    first, second = items
    assert set(first) == EXCHANGE_KEYS and set(first["request"]) == FRAME_KEYS
    assert first["kind"] == "exchange" and first["problems"] == []
    assert first["request"]["telegram"]["pkw"]["pnu"] == 52
    assert first["answer"]["telegram"]["pkw"]["values"] == [0, 16384][1:]
    assert first["answer"]["telegram"]["pzd1"]["kind"] == "status"
    assert first["delay_ms"] == pytest.approx(4.0, abs=0.001)  # durations are stored in µs
    assert second["problems"][0]["problem"] == "bcc"
    assert second["answer"]["fault"] == "bcc"
    copy = read_capture(out_path)
    assert len(copy.records) == 4  # two exchanges, four frames


def test_summary_view(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "line.pcapng"
    _capture(path)
    assert main(["monitor", "--read", str(path), "--summary"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:4] == ["adr", "layout", "req", "ans"]
    row = out[1].split()
    # address 5: 3 requests, 2 answers, 1 without answer; status bits 4 (BCC) and 7 (timeout)
    assert row[:2] == ["5", "3,2"] and row[3:6] == ["3", "2", "1"]
    assert "0090h" in out[1]


@pytest.mark.parametrize(
    ("args", "words"),
    [
        ([], "nothing to listen to"),
        (["--port", "/dev/null"], "--baud is needed"),
        (["--port", "x", "--baud", "1234"], "not a USS baud rate"),
        (["--port", "x", "--baud", "9600", "--layout", "3,3,3"], "bad layout"),
        (["--port", "x", "--baud", "9600", "-w", "out.txt"], "*.pcapng"),
        (["--port", "x", "--baud", "9600", "--linktype", "1"], "user link type"),
        (["--port", "x", "--baud", "19200", "--gap", "0.1"], "shorter than the start pause"),
        (["--port", "x", "--baud", "19200", "--tolerance", "-1"], "--tolerance -1.0: must be"),
        (["--port", "x", "--baud", "19200", "--tolerance", "nan"], "--tolerance nan: must be"),
        (["--port", "a", "--port", "b", "--port-rx", "c", "--baud", "9600"], "at most two"),
        (["--port", "a", "--read", "b"], "either --read"),
        (["--read", "/nonexistent/capture.pcapng"], "cannot read capture"),
        (["--read", "x", "--count", "0"], "--count 0"),
        (["--port", "tcp://", "--baud", "9600"], "HOST:PORT"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    args: list[str], words: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert main(["monitor", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err
    assert len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_bad_capture_files_are_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = tmp_path / "good.pcapng"
    _capture(good)
    data = good.read_bytes()
    files = {
        "cut.pcapng": (data[: len(data) // 2], "truncated"),
        "garbage.bin": (bytes(range(7, 250, 3)), "not a capture"),
        "wrong.jsonl": (b'{"format": "pyuss-bus-recording"}\n', ""),
        "text.txt": (b"hello\n", "not a capture"),
    }
    for name, (content, words) in files.items():
        path = tmp_path / name
        path.write_bytes(content)
        out = tmp_path / "out.pcapng"
        assert main(["monitor", "--read", str(path), "-w", str(out)]) == 2, name
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"uss monitor: {path}") or name in err, err
        assert words in err and len(err.splitlines()) == 1, err
        assert not out.exists()
        assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize(
    ("t", "start", "words"),
    [
        ("-Infinity", "0.0011", "bad record: t -inf is not a finite number"),
        ("Infinity", "0.0011", "bad record: t inf is not a finite number"),
        ("NaN", "0.0011", "bad record: t nan is not a finite number"),
        ("0.0009", "0.0003", "out of time order"),
    ],
)
def test_a_recording_with_bad_times_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], t: str, start: str, words: str
) -> None:
    # -Infinity ended in an OverflowError traceback; Infinity and NaN lost the byte, exit 0.
    path = tmp_path / "wire.jsonl"
    path.write_text(
        '{"format": "pyuss-bus-recording", "version": 1, "baud": 19200, "seed": 0}\n'
        '{"t": 0.001, "start": 0.0004, "from": "m", "byte": "02", "flags": []}\n'
        f'{{"t": {t}, "start": {start}, "from": "m", "byte": "0c", "flags": []}}\n'
    )
    assert main(["monitor", "--read", str(path)]) == 2
    out, err = capsys.readouterr()
    assert err.startswith(f"uss monitor: {path}:3: {words}"), err
    assert len(err.strip().splitlines()) == 1 and out == ""
    # With --json the same error, as one line: on stderr, or as a JSON error object.
    assert main(["monitor", "--read", str(path), "--json"]) == 2
    out, err = capsys.readouterr()
    lines = (out + err).strip().splitlines()
    assert len(lines) == 1 and f"{path}:3: {words}" in lines[0], lines
    if out:
        assert f"{path}:3: {words}" in json.dumps(json.loads(out)["error"])


def test_unreachable_port_fails_with_1(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["monitor", "--port", "/nonexistent/ttyUSB9", "--baud", "9600"]) == 1
    err = capsys.readouterr().err.strip()
    assert "uss monitor:" in err and len(err.splitlines()) == 1


async def _start(*args: str, expect: bytes = b"") -> asyncio.subprocess.Process:
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "pyuss.cli.main",
        "monitor",
        *args,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    assert proc.stderr is not None
    line = await asyncio.wait_for(proc.stderr.readline(), TIMEOUT)
    assert b"listening on" in line and expect in line, line
    return proc


async def _json_lines(proc: asyncio.subprocess.Process) -> tuple[list[dict[str, object]], str]:
    out, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
    assert proc.returncode == 0, err
    return [json.loads(line) for line in out.decode().splitlines()], err.decode()


def _check_exchanges(items: list[dict[str, object]]) -> None:
    assert [i["kind"] for i in items] == ["exchange", "exchange", "request"]
    assert [[p["problem"] for p in i["problems"]] for i in items] == [  # type: ignore[attr-defined]
        [],
        [],
        ["no_answer"],
    ]
    assert all(i["address"] == 5 for i in items)
    assert "read P52 -> P52 = 1234" in str(items[0]["summary"])
    assert "write P18 = 28672 (7000h) -> P18 = 1234" in str(items[1]["summary"])


async def test_live_on_a_bus_station_writes_a_capture(tmp_path: Path) -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    capture = tmp_path / "live.pcapng"
    proc = await _start(
        "--port", f"bus://{host}:{port}", "--baud", str(BAUD), "--json", "--count", "3",
        "--layout", "3,2", "-w", str(capture), expect=b"tolerance 0 ms",
    )  # fmt: skip
    await drive(bus, bus, JOBS, SLAVES)
    items, err = await _json_lines(proc)
    await bus.close()
    _check_exchanges(items)
    assert all(i["request"]["guessed"] for i in items)  # type: ignore[index]
    assert "adr" in err  # the summary table
    records = read_capture(capture).records
    assert [r.frame.raw for r in records[:2]] == [REQ_52, records[1].frame.raw]
    assert len(records) == 5


@pytest.mark.pty
async def test_live_on_a_pty_with_real_port_timing(tmp_path: Path) -> None:
    bus = VirtualBus(BAUD)
    (path,) = await bus.serve_pty(1)
    # The bus hands characters to the pty as its event loop gets round to it, so the pty's
    # timestamps are as coarse as a real adapter's, or worse when the machine is busy (stalls
    # of several milliseconds inside a telegram): the monitor judges a port that stamps bytes
    # when read with the tolerance of 20 ms, without being told.
    proc = await _start(
        "--port", path, "--baud", str(BAUD), "--json", "--count", "3",
        expect=b"tolerance 20 ms",
    )  # fmt: skip
    await asyncio.sleep(0.2)  # the monitor's reader is running
    await drive(bus, bus, JOBS, SLAVES)
    items, _ = await _json_lines(proc)
    await bus.close()
    _check_exchanges(items)
    # Layouts are inferred: the first exchange alone is a guess.
    assert items[0]["layout"] == "3,2"


@pytest.mark.pty
async def test_the_monitor_never_writes_to_its_port() -> None:
    # A pty pair of our own: whatever the monitor wrote to its end would come out of ours.
    ours, theirs = os.openpty()
    os.set_blocking(ours, False)
    try:
        proc = await _start("--port", os.ttyname(theirs), "--baud", str(BAUD), "--json")
        await asyncio.sleep(0.2)  # the port is open (raw mode: no echo by the tty)
        for data in (REQ_52, answer(5, Pkw(1, 52, values=(1234,)))) * 2:
            os.write(ours, data)
            await asyncio.sleep(0.01)
        assert proc.stdout is not None
        first = json.loads(await asyncio.wait_for(proc.stdout.readline(), TIMEOUT))
        assert "read P52 -> P52 = 1234" in first["summary"]
        await asyncio.sleep(0.3)
        with pytest.raises(BlockingIOError):
            os.read(ours, 100)  # nothing
        proc.send_signal(signal.SIGINT)
        _, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
        assert proc.returncode == 0, err
        with pytest.raises(BlockingIOError):
            os.read(ours, 100)
    finally:
        os.close(ours)
        os.close(theirs)


async def test_a_bus_station_is_listen_only_whatever_the_url_says() -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    url = f"bus://{host}:{port}?name=mon&listen_only=0"
    try:
        proc = await _start("--port", url, "--baud", str(BAUD), "--duration", "0.5")
        for _ in range(100):
            if "mon" in bus.stations:
                break
            await asyncio.sleep(0.01)
        assert bus.stations["mon"].listen_only
        _, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
        assert proc.returncode == 0, err
    finally:
        await bus.close()


def test_listener_cannot_send_and_opens_serial_ports_with_rts_off() -> None:
    transport = SerialTransport("loop://", baud=BAUD)
    assert transport.port.rts  # pyserial's default: RTS on when the port opens
    listener = Listener(transport)
    assert not hasattr(listener, "write") and not hasattr(listener, "_write")
    assert transport.port.rts is False

    async def run() -> None:
        await listener.open()
        try:
            assert transport.port.rts is False
        finally:
            await listener.close()

    asyncio.run(run())


async def test_live_four_wire_on_two_ports() -> None:
    tx, rx = VirtualBus(BAUD), VirtualBus(BAUD)
    tx_host, tx_port = await tx.serve_tcp(framed=True)
    rx_host, rx_port = await rx.serve_tcp(framed=True)
    proc = await _start(
        "--port", f"bus://{tx_host}:{tx_port}", "--port-rx", f"bus://{rx_host}:{rx_port}",
        "--baud", str(BAUD), "--json", "--count", "3", "--layout", "5=3,2",
    )  # fmt: skip
    await drive(tx, rx, JOBS, SLAVES)
    items, _ = await _json_lines(proc)
    await tx.close()
    await rx.close()
    _check_exchanges(items)
    first = items[0]
    assert first["request"]["port"] == 0 and first["answer"]["port"] == 1  # type: ignore[index]
    assert not first["request"]["guessed"]  # type: ignore[index]


async def test_live_summary_view_refreshes(tmp_path: Path) -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    try:
        proc = await _start(
            "--port", f"bus://{host}:{port}", "--baud", str(BAUD), "--layout", "3,2",
            "--summary", "--interval", "0.2", "--duration", "2",
        )  # fmt: skip
        await drive(bus, bus, JOBS, SLAVES)
        out, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
    finally:
        await bus.close()
    assert proc.returncode == 0, err
    tables = [t for t in out.decode().split("\n\n") if t.strip()]
    assert len(tables) >= 3  # refreshed every 0.2 s, and the last one at the end
    assert all(t.startswith("adr   layout") for t in tables)
    last = tables[-1].splitlines()
    row = last[1].split()
    # address 5: 3 requests, 2 answers, 1 without; 4 good frames + 1 timeout (A 5.2.3 bit 7)
    assert row[:2] == ["5", "3,2"] and row[3:6] == ["3", "2", "1"]
    assert "0080h" in last[1] and last[-1].startswith("line")
    assert not any(line.lstrip().startswith("0.0") for line in out.decode().splitlines())


@pytest.mark.posix("stops uss monitor with SIGINT")
async def test_sigint_is_a_normal_stop(tmp_path: Path) -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    capture = tmp_path / "live.jsonl"
    proc = await _start("--port", f"bus://{host}:{port}", "--baud", str(BAUD), "-w", str(capture))
    await drive(bus, bus, JOBS[:1], SLAVES)
    await asyncio.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    out, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
    await bus.close()
    assert proc.returncode == 0, err
    assert "read P52 -> P52 = 1234" in out.decode()
    assert len(read_capture(capture).records) == 2
    assert [p.name for p in tmp_path.iterdir()] == ["live.jsonl"]


def test_wireshark_path_and_install(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["wireshark", "path"]) == 0
    shipped = Path(capsys.readouterr().out.strip())
    assert shipped == dissector_source() and shipped.read_text().startswith("-- USS")
    target = tmp_path / "plugins"
    assert main(["wireshark", "install", "--dir", str(target)]) == 0
    out, err = capsys.readouterr()
    assert Path(out.strip()) == target / "uss.lua"
    assert (target / "uss.lua").read_bytes() == shipped.read_bytes()
    assert "installed" in err
    assert main(["wireshark", "install", "--dir", str(target)]) == 0
    assert "already up to date" in capsys.readouterr().err
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["wireshark", "install", "--dir", str(blocker / "sub")]) == 1
    assert "cannot install" in capsys.readouterr().err
    assert main(["wireshark", "install", "--dir", str(blocker)]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_wireshark_install_replaces_only_its_own_dissector(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    shipped = dissector_source().read_bytes()
    installed = tmp_path / "uss.lua"
    # An earlier version of pyuss's dissector is updated.
    installed.write_bytes(shipped.splitlines(keepends=True)[0] + b"-- older\n")
    assert main(["wireshark", "install", "--dir", str(tmp_path)]) == 0
    assert "updated" in capsys.readouterr().err
    assert installed.read_bytes() == shipped
    # Someone else's uss.lua is left alone, unless --force.
    theirs = b'local p = Proto("siemens_uss", "their USS dissector")\n'
    installed.write_bytes(theirs)
    assert main(["wireshark", "install", "--dir", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert "is not the pyuss dissector" in err and "--force" in err
    assert len(err.splitlines()) == 1
    assert installed.read_bytes() == theirs
    assert main(["wireshark", "install", "--dir", str(tmp_path), "--force"]) == 0
    assert "updated" in capsys.readouterr().err
    assert installed.read_bytes() == shipped
    assert sorted(p.name for p in tmp_path.iterdir()) == ["uss.lua"]


def test_a_reader_that_goes_away_ends_the_run_quietly(tmp_path: Path) -> None:
    monitor = Monitor(19200, layouts=LayoutBook(Layout(3, 2)))
    wire = Wire(monitor)
    for pnu in range(2000):
        wire.send(request(5, Pkw(1, pnu)), 0.01)
        wire.send(answer(5, Pkw(1, pnu, values=(pnu,))), 0.003)
    path = tmp_path / "big.jsonl"
    writer = open_writer(path, baud=19200)
    for ex in wire.finish():
        writer.write(ex)
    writer.close()
    proc = subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", "monitor", "--read", str(path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None
    assert b"read P0 -> P0 = 0" in proc.stdout.readline()
    proc.stdout.close()  # like `| head -1`
    _, err = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 0
    assert b"Traceback" not in err and b"BrokenPipe" not in err


def test_a_known_profile_shows_values_typed_and_scaled(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """With --profile the values of parameters show as the profile types them: a float ramp
    time in seconds, a state with its text; the words in hex after them."""
    path = tmp_path / "mm4.pcapng"
    layout = Layout(4, 2)
    monitor = Monitor(19200, layouts=LayoutBook(layout))
    wire = Wire(monitor)
    for job, reply in (
        (Pkw(1, 1120), Pkw(2, 1120, values=(0x4120, 0x0000))),  # 10.0 as a float
        (Pkw(1, 2), Pkw(1, 2, values=(0, 1))),  # a word in PWE2 of PKW 4
    ):
        wire.send(Telegram(3, 0, layout.pack(job, (0x047E, 0))).encode(), 0.01)
        wire.send(Telegram(3, 0, layout.pack(reply, (0x0231, 0))).encode(), 0.004)
    writer = open_writer(path, baud=19200, gap=monitor.gap)
    for ex in wire.finish():
        writer.write(ex)
    writer.close()
    assert main(["monitor", "--read", str(path), "--profile", "micromaster4"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "read P1120 -> P1120 = 10.00 s (41200000h)" in lines[0]
    assert "read r0002 -> r0002 = 1 [READY] (0001h)" in lines[1]
    # the control and status words' bits as a person reads them (pyuss.params.words)
    assert (
        "CW 047Eh(no OFF2, no OFF3, enable operation, ramp generator enabled, ramp generator "
        "running, setpoint enabled, control by PLC)" in lines[0]
    )
    assert "SW 0231h(ready to switch on, no OFF2, no OFF3, control requested)" in lines[0]
    assert "CW 047Eh SP" in lines[1] and "SW 0231h AV" in lines[1]  # nothing changed
    assert main(["monitor", "--read", str(path)]) == 0  # no profile: the words as numbers
    out = capsys.readouterr().out
    assert "P1120 = 1092616192 (41200000h)" in out
    assert "CW 047Eh(NO_OFF2 NO_OFF3 ENABLE_OPERATION" in out  # and the bits by their flags
    known = ProfileValues("micromaster4")
    known.actuals = (2,)  # a profile mapping PZD3 of the answers to P2
    assert known.process(False, 3, 1) == "1 [READY]" and known.process(True, 3, 1) is None
    v20 = ProfileValues("sinamics-v20")
    assert v20.bits(False, 0xEA31, 0xEA40) == (
        "+ready to switch on, +no OFF2, +no OFF3, -switch-on inhibited"
    )
    assert v20.bits(True, 0x0C7F, 0x047F) == "+reverse"  # the family's bit 11


def test_the_summary_names_the_receive_error_status_as_such(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The A 5.2.3 error status word is no status word of a drive: its column says so."""
    path = tmp_path / "line.pcapng"
    _capture(path)
    assert main(["monitor", "--read", str(path), "--summary"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "rx errors" in header and "status" not in header


def _v20_reply(tg: Telegram) -> bytes | None:
    """A SINAMICS V20 answering array reads with their page kept in IND (r2110 is PNU 110
    on IND page 1) and everything else with 1234."""
    job = Layout(3, 2).unpack(tg.data).pkw
    assert job is not None
    if job.id == 6:
        return answer(tg.address, Pkw(4, job.pnu, index=job.index, values=(7,)))
    return answer(tg.address, Pkw(1, job.pnu, values=(1234,)))


@pytest.mark.pty
async def test_a_capture_reads_back_as_the_live_lines_were(tmp_path: Path) -> None:
    """What `uss monitor` printed live on a pty (stamps when read) is what `uss monitor --read`
    prints of the capture it wrote, line for line: the same times and delays to the
    microsecond, and the profile it decoded with, so that PNU 110 on IND page 1 of a
    SINAMICS V20 is r2110 in both."""
    bus = VirtualBus(BAUD)
    (path,) = await bus.serve_pty(1)
    jobs = [
        request(5, Pkw(6, 110, index=0x8001)),  # r2110[1]: PNU 110, IND bit 15 (page 1)
        request(5, Pkw(1, 3)),
        request(5, Pkw(6, 110, index=0x8002)),
    ]
    for suffix in (".pcapng", ".jsonl"):
        capture = tmp_path / f"v20{suffix}"
        proc = await _start(
            "--port", path, "--baud", str(BAUD), "--count", "3", "--layout", "3,2",
            "--profile", "sinamics-v20", "--color", "never", "-w", str(capture),
        )  # fmt: skip
        await asyncio.sleep(0.2)
        await drive(bus, bus, jobs, [Slave(5, _v20_reply, delay=0.004)])
        out, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
        assert proc.returncode == 0, err
        live = out.decode().splitlines()
        assert len(live) == 3
        assert "read r2110[1] -> r2110[1] = 7" in live[0]
        assert "read P0003 -> P0003 = 1234" in live[1]
        replay = subprocess.run(
            [sys.executable, "-m", "pyuss.cli.main", "monitor", "--read", str(capture)],
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
        assert replay.returncode == 0, replay.stderr
        if suffix == ".pcapng":
            assert replay.stdout.splitlines() == live
        else:  # JSON lines keep Unix times in floats: the last microsecond may differ
            lines = replay.stdout.splitlines()
            assert len(lines) == 3 and "read r2110[1] -> r2110[1] = 7" in lines[0]
    await bus.close()


def test_without_a_profile_a_parameter_on_an_ind_page_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Without --profile the monitor cannot know that PNU 110 on IND page 1 is r2110 of a
    SINAMICS V20: it shows the PNU and says that the page is not counted in."""
    path = tmp_path / "v20.pcapng"
    monitor = Monitor(19200, layouts=LayoutBook(Layout(3, 2)))
    wire = Wire(monitor)
    wire.send(request(1, Pkw(6, 110, index=0x8001)), 0.01)
    wire.send(answer(1, Pkw(4, 110, index=0x8001, values=(7,))), 0.004)
    writer = open_writer(path, baud=19200, gap=monitor.gap)
    for ex in wire.finish():
        writer.write(ex)
    writer.close()
    assert main(["monitor", "--read", str(path)]) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert "read P110[1] -> P110[1] = 7 (0007h)  (IND page 1: --profile counts it in)" in line
    assert main(["monitor", "--read", str(path), "--profile", "sinamics-v20"]) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert "read r2110[1] -> r2110[1] = 7 (0007h)" in line and "IND page" not in line
