"""tshark (Debian's package, installed by ``make test``) decodes a capture the monitor wrote,
with the shipped Lua dissector: every field of the telegram, PKW, PZD and the pseudo-header."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from monitor.traffic import REQ_52, Wire
from pyuss.monitor import LayoutBook, Monitor, dissector_source, open_writer
from pyuss.protocol import Layout, Pkw, Telegram
from pyuss.protocol.layout import PKW_VARIABLE
from support.paths import load_vectors

TSHARK = shutil.which("tshark")
IN_CI = bool(os.environ.get("CI"))
pytestmark = pytest.mark.skipif(
    TSHARK is None and not IN_CI,
    reason="tshark is not installed (make test installs it: .ci/system-deps); in CI it must run",
)
V = {v["name"]: bytes.fromhex(v["hex"]) for v in load_vectors("uss")["telegrams"]}
BAUD = 19200
FIELDS = [
    "uss.direction",
    "uss.address",
    "uss.mode",
    "uss.lge",
    "uss.pke.request",
    "uss.pke.response",
    "uss.pnu",
    "uss.ind.subindex",
    "uss.pwe",
    "uss.value",
    "uss.error",
    "uss.text",
    "uss.cw",
    "uss.sw",
    "uss.setpoint",
    "uss.actual",
    "uss.bcc.ok",
    "uss.fault",
    "uss.flags.guessed_direction",
    "uss.flags.no_answer",
    "uss.delay",
    "uss.layout.pkw",
    "uss.layout.pzd",
]


def _capture(path: Path) -> None:
    """The monitor decodes the spec's examples (one monitor per layout) into one capture."""
    writer = open_writer(path, baud=BAUD, epoch=1.7e9)
    t = 100.0
    bad = bytearray(V["read_word_response"])
    bad[-1] ^= 0x01
    parts: list[tuple[Layout, list[tuple[bytes, float]]]] = [
        (
            Layout(3, 2),
            [
                (V["read_word_request"], 0.01),
                (V["read_word_response"], 0.004),
                (V["read_whole_pbe_request"], 0.01),
                (V["read_whole_pbe_refused"], 0.0035),
                (V["mirror_request"], 0.01),
                (V["mirror_request"], 0.004),
                (REQ_52, 0.01),
                (bytes(bad), 0.004),
                (REQ_52, 0.01),  # not answered
                (b"\xff\xfe", 0.08),  # noise
            ],
        ),
        (
            Layout(4, 0),
            [(V["write_array_dword_request"], 0.01), (V["write_array_dword_response"], 0.002)],
        ),
        (
            Layout(PKW_VARIABLE, 0),
            [(V["read_text_request"], 0.01), (V["read_text_response"], 0.005)],
        ),
        (Layout(0, 2), [(V["pzd_only_request"], 0.01), (V["pzd_only_response"], 0.006)]),
    ]
    for layout, sends in parts:
        wire = Wire(Monitor(BAUD, layouts=LayoutBook(layout)), t=t)
        for data, gap in sends:
            wire.send(data, gap)
        for exchange in wire.finish():
            writer.write(exchange)
        t = wire.t + 1.0
    writer.close()


# One row per packet: the fields above, occurrences joined by commas ("" = absent).
EXPECTED = [
    "1|5|0|12|1||52|0|0x0000||||0x047e||0||1|255|1|0||3|2",
    "2|5|0|12||1|52|0|0x4000|16384||||0x0231||0|1|255|1|0|4000|3|2",
    "1|5|0|12|4||52|255|0x0000||||0x047e||0||1|255|1|0||3|2",
    "2|5|0|12||7|52|255|0x0067||103|||0x0231||0|1|255|1|0|3500|3|2",
    "1|7|2|12|||||||||||||1|255|1|0||255|255",
    "2|7|2|12|||||||||||||1|255|1|0|4000|255|255",
    "1|5|0|12|1||52|0|0x0000||||0x047e||0||1|255|1|0||3|2",
    "2|5|0|12||1|52|0|0x4000|16384||||0x0231||0|0|4|1|0|4000|3|2",
    "1|5|0|12|1||52|0|0x0000||||0x047e||0||1|255|1|1||3|2",
    "1|||||||||||||||||3|1|0||255|255",
    "1|5|0|10|8||4|2|0x4000,0x0000|1073741824|||||||1|255|1|0||4|0",
    "2|5|0|10||5|4|2|0x4000,0x0000|1073741824|||||||1|255|1|0|2000|4|0",
    "1|5|0|8|15||7|3|0x0000||||||||1|255|1|0||127|0",
    "2|5|0|22||15|7|3|0x3330,0x3020,0x4241,0x5544,0x2020,0x2020,0x2020,0x2020|||"
    "300 BAUD        |||||1|255|1|0|5000|127|0",
    "1|5|0|6|||||||||0x047f||8192||1|255|1|0||0|2",
    "2|5|0|6||||||||||0x0337||8192|1|255|1|0|6000|0|2",
]


def _tshark(path: Path, home: Path, *args: str) -> str:
    assert TSHARK is not None, "tshark must be installed in CI (make test installs it)"
    env = {**os.environ, "HOME": str(home), "XDG_CONFIG_HOME": str(home / "config")}
    result = subprocess.run(
        [TSHARK, "-r", str(path), "-X", f"lua_script:{dissector_source()}", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "Lua: Error" not in result.stderr, result.stderr
    return result.stdout


def _rows(path: Path, home: Path, fields: list[str]) -> list[str]:
    """One row per packet: ``fields`` joined by ``|``, occurrences by commas ("" = absent)."""
    columns = [arg for field in fields for arg in ("-e", field)]
    options = ["-T", "fields", "-E", "separator=|", "-E", "occurrence=a"]
    return _tshark(path, home, *options, *columns).splitlines()


def test_tshark_prints_the_fields(tmp_path: Path) -> None:
    path = tmp_path / "line.pcapng"
    _capture(path)
    assert _rows(path, tmp_path, FIELDS) == EXPECTED


def test_tshark_info_column_and_expert_info(tmp_path: Path) -> None:
    path = tmp_path / "line.pcapng"
    _capture(path)
    lines = _tshark(path, tmp_path, "-T", "fields", "-e", "_ws.col.Info").splitlines()
    assert lines[0] == "Request adr 5: read parameter value (1), PNU 52, CW 047E, SP 0.00%"
    assert lines[1].startswith("Response adr 5: parameter value (word) (1), PNU 52 = 16384")
    assert "error 103" in lines[3]
    assert "[wrong BCC]" in lines[7]
    assert "[no_answer]" in lines[8]
    assert "'300 BAUD'" in lines[13]
    assert lines[9].startswith("Request: 2 bytes")
    # A filter on a decoded field works, and so does one on an expert item.
    refused = _tshark(
        path, tmp_path, "-Y", "uss.pke.response == 7", "-T", "fields", "-e", "frame.number"
    )
    assert refused.split() == ["4"]
    bad = _tshark(path, tmp_path, "-Y", "uss.bcc.ok == 0", "-T", "fields", "-e", "frame.number")
    assert bad.split() == ["8"]


def test_uss_wireshark_install_is_what_tshark_loads(tmp_path: Path) -> None:
    """Installed into the default folder of a user (HOME), tshark loads the dissector by
    itself, with no -X option."""
    assert TSHARK is not None, "tshark must be installed in CI (make test installs it)"
    path = tmp_path / "line.pcapng"
    _capture(path)
    home = tmp_path / "home"
    home.mkdir()
    env = {**os.environ, "HOME": str(home), "XDG_CONFIG_HOME": str(home / "config")}
    result = subprocess.run(
        [sys.executable, "-m", "pyuss.cli.main", "wireshark", "install"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
        check=True,
    )
    assert Path(result.stdout.strip()) == home / ".local/lib/wireshark/plugins/uss.lua"
    folders = subprocess.run(
        [TSHARK, "-G", "folders"], capture_output=True, text=True, env=env, timeout=120
    ).stdout
    assert f"{home}/.local/lib/wireshark/plugins" in folders
    out = subprocess.run(
        [TSHARK, "-r", str(path), "-T", "fields", "-e", "uss.pnu", "-e", "_ws.col.Info"],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=True,
    ).stdout
    assert out.splitlines()[0] == (
        "52\tRequest adr 5: read parameter value (1), PNU 52, CW 047E, SP 0.00%"
    )


BIT_FIELDS = [f"uss.{word}.bit{n}" for word in ("cw", "sw") for n in range(11)]
FOUR_WIRE_FIELDS = [
    "uss.direction",
    "uss.flags.port_1",
    "uss.flags.layout_given",
    "uss.flags.late_answer",
    "uss.flags.wrong_address",
    "uss.stx",
    "uss.lge",
    "uss.adr",
    "uss.address",
    "uss.bcc",
    "uss.pke",
    "uss.pke.toggle",
    "uss.pnu",
    "uss.ind",
    "uss.ind.subindex",
    "uss.ind.text",
    "uss.pwe",
    "uss.pzd",
    "uss.cw",
    "uss.sw",
    "uss.setpoint",
    "uss.actual",
    *BIT_FIELDS,
]


def _four_wire_capture(path: Path) -> None:
    """A 4-wire line, layout 3,4 given: an array write, a spontaneous answer, a late answer
    and one from the wrong address; port 1 carries the answers."""
    layout = Layout(3, 4)
    monitor = Monitor(BAUD, four_wire=True, layouts=LayoutBook(layout))
    wire = Wire(monitor)

    def send(address: int, pkw: Pkw, pzd: tuple[int, ...], gap: float, port: int) -> None:
        wire.send(Telegram(address, 0, layout.pack(pkw, pzd)).encode(), gap, port)

    send(3, Pkw(7, 10, index=2, values=(0x1234,)), (0x047F, 0x2000, 0x1111, 0x2222), 0.01, 0)
    send(3, Pkw(5, 10, index=2, values=(0x1234,)), (0x0237, 0x1FFF, 0x3333, 0x4444), 0.004, 1)
    send(3, Pkw(0), (0x047E, 0x2000, 0, 0), 0.01, 0)
    send(3, Pkw(9, 300, spm_toggle=True, values=(7,)), (0x0231, 0, 0, 0), 0.030, 1)  # late
    send(3, Pkw(1, 11), (0x047E, 0, 0, 0), 0.01, 0)
    send(4, Pkw(1, 11, values=(5,)), (0x0237, 0, 0, 0), 0.003, 1)  # wrong address
    writer = open_writer(path, baud=BAUD, four_wire=True, epoch=1.7e9, gap=monitor.gap)
    for exchange in wire.finish():
        writer.write(exchange)
    writer.close()


def _bits(control: int | None, status: int | None) -> str:
    """The 22 bit columns: control word bits 0..10, then status word bits 0..10."""
    cells = [
        "" if word is None else str(word >> n & 1) for word in (control, status) for n in range(11)
    ]
    return "|".join(cells)


# Requests on port 0 (direction 1), answers on port 1 (direction 2, flag port_1).
FOUR_WIRE_EXPECTED = [
    "1|0|1|0|0|0x02|16|0x03|3|0x14|0x700a|0|10|0x0002|2|0x0000|0x1234|0x1111,0x2222|0x047f||8192|"
    + f"|{_bits(0x047F, None)}",
    "2|1|1|0|0|0x02|16|0x03|3|0xba|0x500a|0|10|0x0002|2|0x0000|0x1234|0x3333,0x4444||0x0237||"
    + f"8191|{_bits(None, 0x0237)}",
    "1|0|1|0|0|0x02|16|0x03|3|0x4b|0x0000|0|0|0x0000|0|0x0000|0x0000|0x0000,0x0000|0x047e||8192|"
    + f"|{_bits(0x047E, None)}",
    "2|1|1|1|0|0x02|16|0x03|3|0x90|0x992c|1|300|0x0000|0|0x0000|0x0007|0x0000,0x0000||0x0231||0|"
    + f"{_bits(None, 0x0231)}",
    "1|0|1|0|0|0x02|16|0x03|3|0x70|0x100b|0|11|0x0000|0|0x0000|0x0000|0x0000,0x0000|0x047e||0|"
    + f"|{_bits(0x047E, None)}",
    "2|1|1|0|1|0x02|16|0x04|4|0x3d|0x100b|0|11|0x0000|0|0x0000|0x0005|0x0000,0x0000||0x0237||0|"
    + f"{_bits(None, 0x0237)}",
]


def test_tshark_four_wire_pzd_and_every_control_and_status_bit(tmp_path: Path) -> None:
    path = tmp_path / "four.pcapng"
    _four_wire_capture(path)
    assert _rows(path, tmp_path, FOUR_WIRE_FIELDS) == FOUR_WIRE_EXPECTED
    info = _tshark(path, tmp_path, "-T", "fields", "-e", "_ws.col.Info").splitlines()
    assert "[late_answer]" in info[3] and "[wrong_address]" in info[5]
