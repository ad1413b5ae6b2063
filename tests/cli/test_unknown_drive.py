"""A drive of unknown kind that knows no parameter descriptions (most USS slaves in the field):
a vacuum-pump controller at address 0 with PKW 4, PZD 6, whose slave ignores request 4 (no
answer at all) or, as a variant, refuses it (error 102). It is served on a virtual bus in a
thread of its own and reached over raw TCP and over ``bus://``; the commands run without
``--profile``. Every command works with it, no description is asked where none was wanted, at
most one per drive where one was (a description job, repeated in every telegram until its
time is up, C 4.2.1.1, counts once), and the device itself refuses what it does not take."""

from __future__ import annotations

import asyncio
import dataclasses
import json
import subprocess
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from cli.test_lines import serve, stop
from gateway.conftest import broker  # noqa: F401  (the fixture of a real mosquitto)
from gateway.harness import Broker
from pyuss.bus import VirtualBus
from pyuss.cli.main import main
from pyuss.drive.loader import parse_database
from pyuss.drive.simulated import SimulatedDrive
from pyuss.master import sync
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import RequestId
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.slave import SlaveEngine, SlaveServer
from support.buses import SimulatorThread
from support.network import free_port

BAUD = 38400
LAYOUT = Layout(4, 6)

PUMP = """\
[profile]
name = "vacuum-pump"
title = "vacuum-pump controller"
follows = "its manual"
index_base = 1
max_pnu = 2047

[[parameter]]
pnu = 3
name = "Pump type"
type = "uint16"
access = "ro"
default = 4711

[[parameter]]
pnu = 150
name = "Rotation speed"
type = "uint16"
default = 1200

[[parameter]]
pnu = 151
name = "Operating hours"
type = "uint32"
default = 100000

[[parameter]]
pnu = 160
name = "Setpoints"
type = "uint16"
array = 3
default = 7
"""


class PumpEngine(SlaveEngine):
    """The pump's slave: the simulator's engine with the pump's parameters, on the USS
    specification's telegram rules, knowing no descriptions. ``silent``: request 4 gets no
    answer at all; else the profile leaves request 4 out and the engine refuses it (error 102,
    "service not implemented"). ``described`` counts the description jobs it got."""

    def __init__(self, *, silent: bool) -> None:
        generic = get_profile("generic")
        profile = dataclasses.replace(
            generic, request_ids=generic.request_ids - {int(RequestId.READ_PBE_ELEMENT)}
        )
        super().__init__(0, SimulatedDrive(parse_database(PUMP)), profile, layout=LAYOUT)
        self.silent = silent
        self.described = 0
        self._asked: tuple[int, int] | None = None

    def handle(self, telegram: Telegram, now: float) -> Telegram | None:
        if telegram.mode is AddressMode.NORMAL and telegram.address == self.address:
            pkw = self.layout.unpack(telegram.data).pkw
            if pkw is not None and pkw.id == RequestId.READ_PBE_ELEMENT:
                if self._asked != (pkw.pnu, pkw.index):
                    self.described += 1
                self._asked = (pkw.pnu, pkw.index)
                if self.silent:
                    return None
            else:
                self._asked = None
        return super().handle(telegram, now)


class PumpBus(SimulatorThread):
    """The pump on a virtual bus in a thread of its own, with raw TCP stations (``paths[0]``,
    ``tcp://``) and ``bus://`` (``url``) for the commands."""

    def __init__(self, *, silent: bool) -> None:
        super().__init__([], baud=BAUD)
        self.engine = PumpEngine(silent=silent)
        self.url = ""

    async def _serve(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        bus = self.bus = VirtualBus(self.baud)
        try:
            task = asyncio.create_task(SlaveServer(bus.attach("pump"), self.engine).run(self._stop))
            raw_host, raw_port = await bus.serve_tcp()
            self.paths = [f"tcp://{raw_host}:{raw_port}"]
            host, port = await bus.serve_tcp(framed=True)
            self.url = f"bus://{host}:{port}"
            self._ready.set()
            await self._stop.wait()
            await task
        except BaseException as exc:
            self._error = exc
            self._ready.set()
        finally:
            await bus.close()

    def port(self, kind: str) -> list[str]:
        return ["--port", self.paths[0] if kind == "tcp" else self.url, "--baud", str(BAUD)]

    @property
    def described(self) -> int:
        return int(self.call(lambda _: self.engine.described))


SLACK = ["--response-delay", "300"]
"""A window for a telegram's answer that a loaded test machine keeps (status, run, mirror,
scan wait for the answers to single telegrams)."""


@pytest.fixture(scope="module", params=["silent", "refusing"])
def pump(request: pytest.FixtureRequest) -> Iterator[PumpBus]:
    with PumpBus(silent=request.param == "silent") as running:
        yield running


@pytest.fixture(params=["tcp", "bus"])
def line(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_values_words_and_double_words_array_elements_read_and_written(
    pump: PumpBus, line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    at = [*pump.port(line), "--layout", "4,6"]
    before = pump.described
    code, out, err = uss(capsys, "read", "0", "150", "151", "160.2", *at)
    assert (code, err) == (0, "")
    assert out.splitlines() == [
        "P150 = 1200 (04B0h)",
        "P151 = 100000 (000186A0h)",
        "P160.2 = 7 (0007h)",
    ]
    code, out, err = uss(capsys, "write", "0", "150", "1500", *at)
    assert (code, out.strip(), err) == (0, "P150 = 1500 (05DCh)", "")
    code, out, _ = uss(capsys, "write", "0", "160.3", "9", *at)
    assert (code, out.strip()) == (0, "P160.3 = 9 (0009h)")
    code, out, _ = uss(capsys, "read", "0", "150", "160.3", *at, "--json")
    values = [(p["label"], p["value"], p["raw"]) for p in json.loads(out)["parameters"]]
    assert (code, values) == (0, [("P150", 1500, [1500]), ("P160.3", 9, [9])])
    for pnu, value in (("150", "1200"), ("160.3", "7")):  # as it was, for the next test
        assert uss(capsys, "write", "0", pnu, value, *at)[0] == 0
    assert pump.described == before  # nothing said the drive has descriptions: none asked


def test_the_device_refuses_a_write_to_its_read_only_parameter(
    pump: PumpBus, line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # The generic profile calls P3 read-only too; the refusal must be the device's.
    code, out, err = uss(capsys, "write", "0", "3", "5", *pump.port(line), "--layout", "4,6")
    assert (code, out) == (1, "")
    assert "error 1: " in err and len(err.splitlines()) == 1
    code, out, _ = uss(capsys, "read", "0", "3", *pump.port(line), "--layout", "4,6")
    assert (code, out) == (0, "P3 = 4711 (1267h)\n")


def test_asked_for_descriptions_it_is_asked_once_then_read_as_words(
    pump: PumpBus, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cache = str(tmp_path / "descriptions.json")
    at = [*pump.port("tcp"), "--layout", "4,6", "--timeout", "0.5", "--params-cache", cache]
    before = pump.described
    code, out, err = uss(capsys, "read", "0", "150", "151", "160.1", *at, "--describe", "always")
    assert (code, err) == (0, "")
    assert out.splitlines()[1:] == ["P151 = 100000 (000186A0h)", "P160.1 = 7 (0007h)"]
    assert pump.described - before == 1  # one per drive, not one per parameter
    drives = json.loads(Path(cache).read_text(encoding="utf-8"))["drives"]
    assert [entry["descriptions"] for entry in drives.values()] == [False]
    # The next run knows it from the cache file: nothing asked, even with --describe always.
    code, out, _ = uss(capsys, "write", "0", "151", "100000", *at, "--describe", "always")
    assert (code, out.strip()) == (0, "P151 = 100000 (000186A0h)")
    assert pump.described - before == 1


def test_describe_says_the_drive_has_none(
    pump: PumpBus, capsys: pytest.CaptureFixture[str]
) -> None:
    at = [*pump.port("bus"), "--layout", "4,6", "--timeout", "0.5"]
    code, out, err = uss(capsys, "describe", "0", "150", *at)
    assert (code, out) == (1, "")
    if pump.engine.silent:
        assert "slave 0 gives no description of P150: it does not answer request 4" in err
        assert "it has no parameter descriptions" in err
    else:
        assert "error 102: service not implemented" in err


def test_backup_scan_finds_the_parameters_by_their_values(
    pump: PumpBus, line: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = tmp_path / "pump.json"
    before = pump.described
    at = [*pump.port(line), "--layout", "4,6"]
    code, out, err = uss(capsys, "backup", "0", "-o", str(file), "--scan", "148-161", *at)
    data = json.loads(file.read_text(encoding="utf-8"))
    read = {p["pnu"]: p.get("raw") for p in data["parameter"]}
    assert read == {150: "04B0", 151: "0001 86A0", 160: "0007 0007 0007"}, (out, err)
    assert code == 0 and data["profile"]
    assert pump.described == before


def test_a_drive_that_does_not_answer_is_named_as_such(
    pump: PumpBus, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = uss(capsys, "read", "7", "1120", *pump.port("tcp"), "--timeout", "0.3")
    assert (code, out) == (1, "")
    assert err.startswith(
        "P1120: slave 7 does not answer (no reply within 0.3 s): check address, baud rate and "
        "wiring"
    )


def test_a_named_profile_that_has_descriptions_asks_once_then_reads_words(
    pump: PumpBus,
) -> None:
    # What the web page and the gateway's mailbox do: they read through `Drive` with the
    # profile configured (generic by default), whose drives have descriptions.
    before = pump.described
    with sync.Master(
        pump.paths[0], baud=BAUD, profile="generic", layout="4,6", job_timeout=0.5
    ) as master:
        drive = master.drive(0)
        assert drive.read(150) == 1200  # no file knows it: a description is asked, in vain
        assert drive.read(151) == 100000
        assert drive.read(160, 2) == 7
        assert drive.params.without_descriptions
    assert pump.described - before == 1


def test_status_shows_what_the_telegram_says_and_no_family_s_facts(
    pump: PumpBus, line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    before = pump.described
    at = [*pump.port(line), "--layout", "4,6", *SLACK]
    code, out, err = uss(capsys, "status", "0", *at, "--json")
    seen = json.loads(out)
    assert (code, err) == (0, ""), out
    assert (seen["state"], seen["status_hex"], seen["actual_percent"]) == (
        "switch-on inhibited",
        "0240",
        0.0,
    )
    # no generic parameters read for state, fault and warning, no reference, no texts
    assert (seen["unknown_kind"], seen["parameters"], seen["actual"]) == (True, [], None)
    assert [b["meaning"] for b in seen["bits"][11:]] == ["device-specific"] * 5
    code, out, _ = uss(capsys, "status", "0", *at)
    assert code == 0 and out.splitlines()[-1].startswith("drive of unknown kind (no --profile)")
    assert pump.described == before


def test_run_takes_percent_and_refuses_a_unit_it_cannot_know(
    pump: PumpBus, capsys: pytest.CaptureFixture[str]
) -> None:
    at = [*pump.port("bus"), "--layout", "4,6", *SLACK, "--stop-timeout", "10"]
    code, out, err = uss(capsys, "run", "0", "--setpoint", "25 Hz", *at)
    assert (code, out) == (2, "")
    assert "the drive is of unknown kind (no --profile), so its reference parameter" in err
    code, out, err = uss(capsys, "run", "0", "--setpoint", "20", "--duration", "0.3", *at, "--json")
    lines = [json.loads(text) for text in out.splitlines()]
    assert (code, err) == (0, ""), out
    answered = [ln for ln in lines if ln["state"] is not None]
    assert answered and {ln["unit"] for ln in answered} == {"%"}  # no reference: percent
    assert all(ln["setpoint"] == pytest.approx(20.0, abs=0.01) for ln in lines)
    assert lines[-1]["state"] != "operation enabled"  # switched off again
    code, out, _ = uss(capsys, "ack", "0", *at[:-2])
    assert code == 0 and out.startswith("drive 0: no fault to acknowledge")  # none reported


def test_mirror_and_scan_find_the_drive_and_name_no_family(
    pump: PumpBus, line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = uss(capsys, "mirror", "0", *pump.port(line), "--layout", "4,6", *SLACK)
    assert code == 0 and "1 of 1 came back unchanged" in out
    code, out, _ = uss(capsys, "scan", "--address", "0", *pump.port(line), "--json", *SLACK)
    found = json.loads(out)
    assert code == 0
    assert [(f["address"], f["layout"], f["family"], f["profile"]) for f in found] == [
        (0, "4,6", None, None)
    ]


def test_params_scan_lists_what_it_finds_as_words(
    pump: PumpBus, capsys: pytest.CaptureFixture[str]
) -> None:
    before = pump.described
    at = [*pump.port("tcp"), "--layout", "4,6"]
    code, out, err = uss(capsys, "params", "0", "--scan", "148-161", "--values", *at)
    assert (code, err) == (0, "")
    assert [" ".join(row.split()) for row in out.splitlines()] == [
        "P150 (nothing known: words) = 1200 (04B0h)",
        "P151 (nothing known: words) = 100000 (000186A0h)",
        "P160 (nothing known: words) = [7 (0007h), 7 (0007h), 7 (0007h)]",
    ]
    assert pump.described == before


def test_log_writes_percent_and_words(
    pump: PumpBus, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "pump.csv"
    before = pump.described
    at = [*pump.port("bus"), "--layout", "4,6"]
    code, _, _ = uss(capsys, "log", "0", "actual", "P151", "--count", "2", "-o", str(path), *at)
    header, *rows = path.read_text(encoding="utf-8").splitlines()
    assert code == 0
    # no generic reference (Hz) nor generic names for PZD3..6: the words as they come
    assert header.split(",")[1:] == [
        "actual PZD2 [%]",
        *(f"actual PZD{n}" for n in range(3, 7)),
        "P151",
        "comm",
    ]
    assert all(row.split(",")[-2:] == ["100000", "ok"] for row in rows) and len(rows) == 2
    assert pump.described == before  # no description asked of P151


def _api(base: str, path: str, body: object | None = None) -> object:
    """A request of the page's API (a POST carries the header only a script can add)."""
    data = None if body is None else json.dumps(body).encode()
    headers = {"X-Pyuss": "1", "Content-Type": "application/json"} if body is not None else {}
    request = urllib.request.Request(base + path, data=data, headers=headers)
    with urllib.request.urlopen(request, timeout=30) as reply:
        return json.load(reply)


@pytest.mark.posix("stops uss web with SIGINT and checks it ended cleanly")
def test_the_page_reads_and_writes_the_drive_s_parameters_as_words(pump: PumpBus) -> None:
    pytest.importorskip("aiohttp")
    if not pump.engine.silent:
        pytest.skip("one variant is enough: the page talks as the commands do")
    before = pump.described
    argv = ["web", *pump.port("bus"), "--address", "0", "--layout", "4,6"]
    process, lines = serve([*argv, "--listen", "127.0.0.1:0"], "http://")
    try:
        base = lines[-1].split("?")[0] + "api/drive/0"
        shown = _api(base, "")
        assert isinstance(shown, dict)
        assert (shown["profile"], shown["reference"]) == ("unknown", None)
        assert _api(base + "/params", "") == []  # nothing known of it: no family's list
        read = _api(base, "/params/read", {"ids": ["150", "151", "160.2"]})
        assert [(r["id"], r["value"]) for r in read] == [  # type: ignore[union-attr]
            ("150", "1200 (04B0h)"),
            ("151", "100000 (000186A0h)"),
            ("160.2", "7 (0007h)"),
        ]
        try:
            written = _api(base, "/params/write", {"id": "150", "value": "0x5DC"})
            assert isinstance(written, dict) and written["value"] == "1500 (05DCh)"
        finally:
            assert _api(base, "/params/write", {"id": "150", "value": "1200"})
        with pytest.raises(urllib.error.HTTPError) as refused:  # the device's own refusal
            _api(base, "/params/write", {"id": "3", "value": "5"})
        assert "error 1: " in str(json.load(refused.value)["error"])
    finally:
        assert stop(process) == 0
    assert pump.described == before


def _reply(server: Broker, command: str, body: dict[str, object]) -> dict[str, object]:
    """Publish ``body`` on the drive's ``cmd/COMMAND`` until its reply comes."""
    topic = "uss/bus/drive0"
    listen = subprocess.Popen(
        ["mosquitto_sub", "-p", str(server.port), "-t", f"{topic}/reply", "-C", "1", "-W", "60"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        payload = json.dumps(body)
        while listen.poll() is None:
            pub = ["mosquitto_pub", "-p", str(server.port), "-t", f"{topic}/cmd/{command}"]
            subprocess.run([*pub, "-m", payload], check=True, timeout=30)
            time.sleep(0.5)  # the subscription may not have been in place yet
        out, _ = listen.communicate(timeout=30)
    finally:
        if listen.poll() is None:
            listen.kill()
    reply: dict[str, object] = json.loads(out)
    return reply


@pytest.mark.posix("stops uss gateway with SIGINT and checks it ended cleanly")
def test_the_gateway_s_mailbox_reads_and_writes_words(
    pump: PumpBus,
    broker: Broker,  # noqa: F811
) -> None:
    from pymodbus.client import ModbusTcpClient

    if not pump.engine.silent:
        pytest.skip("one variant is enough: the gateway talks as the commands do")
    before = pump.described
    port = free_port()
    argv = ["gateway", *pump.port("bus"), "--address", "0", "--layout", "4,6"]
    process, _ = serve([*argv, "--modbus", f"127.0.0.1:{port}", "--mqtt", broker.url], "ready")
    try:
        client = ModbusTcpClient("127.0.0.1", port=port, timeout=10)
        assert client.connect()

        def job(pnu: int, fmt: int, value: tuple[int, int], command: int) -> list[int]:
            box = client.readwrite_registers(
                read_address=206,
                read_count=5,
                write_address=200,
                values=[pnu, 0xFFFF, fmt, *value, command],
                device_id=0,
            )
            assert not box.isError(), box
            assert box.registers[0] == 1  # done
            return list(box.registers[3:])

        assert job(150, 0, (0, 0), 1) == [0, 1200]  # the word, as nothing says more of it
        assert job(151, 3, (0, 0), 1) == [0x0001, 0x86A0]  # the double word as it came
        assert job(150, 1, (0, 1500), 2) == [0, 1500]
        assert job(150, 1, (0, 1200), 2) == [0, 1200]
        client.close()
        read = _reply(broker, "read", {"id": "r", "pnu": 151})
        assert (read["ok"], read["result"]["value"]) == (True, 100000)  # type: ignore[index]
        wrote = _reply(broker, "write", {"id": "w", "pnu": 160, "index": 3, "value": 9})
        assert (wrote["ok"], wrote["result"]["value"]) == (True, 9)  # type: ignore[index]
        back = _reply(broker, "write", {"id": "b", "pnu": 160, "index": 3, "value": 7})
        assert back["ok"] is True
    finally:
        assert stop(process) == 0
    assert pump.described == before


def test_backup_says_the_kind_is_unknown_and_restore_writes_the_words_back(
    pump: PumpBus, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    at = [*pump.port("bus"), "--layout", "4,6"]
    file = tmp_path / "pump.json"
    code, _, _ = uss(capsys, "backup", "0", "-o", str(file), "--scan", "150-151", *at)
    data = json.loads(file.read_text(encoding="utf-8"))
    assert (code, data["profile"]) == (0, "unknown")
    code, out, _ = uss(capsys, "diff", "0", str(file), *at)
    assert (code, out.splitlines()[1]) == (0, f"drive 0 and {file} agree")
    # a file of the generic profile, as earlier versions wrote of every drive: the same words
    old = tmp_path / "old.json"
    old.write_text(json.dumps({**data, "profile": "generic"}), encoding="utf-8")
    assert uss(capsys, "diff", str(file), str(old))[0] == 0  # two kinds: compared by words
    try:
        assert uss(capsys, "write", "0", "150", "1500", *at)[0] == 0
        code, out, _ = uss(capsys, "diff", "0", str(file), *at)
        assert (code, out.splitlines()[1]) == (1, "P150: 1500 -> 1200")
        code, out, err = uss(capsys, "restore", "0", str(old), "--yes", *at)
        assert (code, out) == (2, "")  # refused before anything is written
        assert "a backup of a generic drive, this drive is of unknown kind (no --profile)" in err
        assert uss(capsys, "read", "0", "150", *at)[1] == "P150 = 1500 (05DCh)\n"
        code, out, _ = uss(capsys, "restore", "0", str(file), "--yes", *at)
        assert (code, out.splitlines()) == (
            0,
            ["P150: 05DCh -> 04B0h", "drive 0: 1 of 1 written"],
        )
        assert uss(capsys, "read", "0", "150", *at)[1] == "P150 = 1200 (04B0h)\n"
        assert uss(capsys, "write", "0", "150", "1500", *at)[0] == 0
        code, out, _ = uss(capsys, "restore", "0", str(old), "--yes", "--force", *at)
        assert (code, out.splitlines()[0]) == (0, "P150: 05DCh -> 04B0h")  # its words as read
    finally:
        uss(capsys, "write", "0", "150", "1200", *at)
    assert uss(capsys, "read", "0", "150", *at)[1] == "P150 = 1200 (04B0h)\n"


def test_a_backup_that_would_hold_nothing_is_refused(
    pump: PumpBus, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # of a drive of unknown kind nothing is known: a backup of it would be an empty file
    # reported as taken; it is refused before anything is sent, saying what gives parameters
    file = tmp_path / "pump.json"
    at = [*pump.port("tcp"), "--layout", "4,6"]
    code, out, err = uss(capsys, "backup", "0", "-o", str(file), *at)
    assert (code, out) == (2, "")
    assert err.startswith("uss backup: no parameter of drive 0 is known (a drive of unknown kind")
    assert "--scan FROM-TO" in err and "--params FILE" in err and "--profile" in err
    assert not file.exists()
