"""Parameter numbers from 2000 on as the drive's manual writes them (P2010, not "PNU 10 with
IND bit 15") in `uss decode`, the monitor's lines and JSON, and the Wireshark dissector."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
from contextlib import redirect_stdout
from pathlib import Path

import pytest

from monitor.traffic import Wire
from pyuss.cli.main import main
from pyuss.monitor import LayoutBook, Monitor, dissector_source, open_writer
from pyuss.monitor.render import exchange_line
from pyuss.profiles import get_profile
from pyuss.protocol import Layout, Pkw, Telegram
from pyuss.protocol.pkw import ResponseId, page_of, parameter_number
from pyuss.protocol.telegram import AddressMode

LAYOUT = Layout(4, 2)
MM4 = get_profile("micromaster4")


def telegram(pkw: Pkw, pzd: tuple[int, ...] = (0, 0)) -> bytes:
    return Telegram(3, AddressMode.NORMAL, LAYOUT.pack(pkw, pzd)).encode()


BITS, PAGE = MM4.encode_pnu(2010)
REQUEST = telegram(Pkw(6, BITS, PAGE | 1))  # read P2010.1
ANSWER = telegram(Pkw(ResponseId.ARRAY_WORD, BITS, PAGE | 1, values=(0, 6)), (0x0231, 0))


def test_the_page_bits_give_the_profiles_number() -> None:
    assert (BITS, PAGE) == (10, 0x8000)
    assert page_of(PAGE) == 1 and parameter_number(10, PAGE | 1, 2000) == 2010
    assert parameter_number(10, PAGE, None) == 10  # a device without pages
    for pnu in (0, 1999, 2000, 2010, 3999, 31999):
        bits, ind = MM4.encode_pnu(pnu)
        assert parameter_number(bits, ind, MM4.pnu_page_size) == pnu == MM4.decode_pnu(bits, ind)


def test_uss_decode_names_the_parameter_with_a_profile() -> None:
    out = io.StringIO()
    with redirect_stdout(out):
        code = main(["decode", REQUEST.hex(), "--layout", "4,2", "--profile", "micromaster4"])
    text = out.getvalue()
    assert (
        code == 0 and "parameter P2010 (USS baudrate): PNU 10 on IND page 1 (bits 12..15)" in text
    )
    assert "IND        8001h: subindex 1, bits 8/9 = 00, page 1 (bits 12..15)" in text
    out = io.StringIO()
    with redirect_stdout(out):
        main(["decode", REQUEST.hex(), "--layout", "4,2", "--profile", "micromaster4", "--json"])
    pkw = json.loads(out.getvalue())["pkw"]
    assert (pkw["pnu"], pkw["parameter"], pkw["subindex"]) == (10, 2010, 1)


def exchanges() -> list:  # type: ignore[type-arg]
    wire = Wire(Monitor(19200, layouts=LayoutBook(LAYOUT)))
    wire.send(REQUEST, 0.01)
    wire.send(ANSWER, 0.004)
    return wire.finish()


def test_the_monitor_shows_the_profiles_number() -> None:
    [ex] = exchanges()
    assert "read P2010[1] -> P2010[1] = 6" in exchange_line(ex, page_size=2000)
    assert "read P10[1]" in exchange_line(ex)  # without a profile: the PNU as it travels


def test_uss_monitor_profile_option(tmp_path: Path) -> None:
    capture = tmp_path / "mm4.pcapng"
    writer = open_writer(capture, baud=19200, epoch=1.7e9)
    for ex in exchanges():
        writer.write(ex)
    writer.close()
    out = io.StringIO()
    with redirect_stdout(out):
        code = main(["monitor", "--read", str(capture), "--profile", "micromaster4", "--json"])
    [line] = out.getvalue().splitlines()
    data = json.loads(line)
    assert code == 0 and "read P2010[1]" in data["summary"]
    assert data["request"]["telegram"]["pkw"]["parameter"] == 2010


@pytest.mark.skipif(
    shutil.which("tshark") is None and not os.environ.get("CI"), reason="tshark not installed"
)
def test_the_dissector_counts_the_page_in_when_told(tmp_path: Path) -> None:
    capture = tmp_path / "mm4.pcapng"
    writer = open_writer(capture, baud=19200, epoch=1.7e9)
    for ex in exchanges():
        writer.write(ex)
    writer.close()
    tshark = shutil.which("tshark")
    assert tshark is not None
    env = {**os.environ, "HOME": str(tmp_path), "XDG_CONFIG_HOME": str(tmp_path / "config")}
    base = [tshark, "-r", str(capture), "-X", f"lua_script:{dissector_source()}"]
    fields = ["-T", "fields", "-e", "uss.pnu", "-e", "uss.parameter", "-e", "_ws.col.Info"]
    paged = subprocess.run(
        [*base, "-o", "uss.page_size:2000", *fields],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=True,
    ).stdout.splitlines()
    assert paged[0].split("\t")[:2] == ["10", "2010"] and "(P2010)" in paged[0]
    plain = subprocess.run(
        [*base, *fields], capture_output=True, text=True, env=env, timeout=120, check=True
    ).stdout.splitlines()
    assert plain[0].split("\t")[:2] == ["10", ""] and "P2010" not in plain[0]
