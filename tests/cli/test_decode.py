"""``uss decode``: person-readable and JSON output, and the exit codes for bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.cli.decode import describe, parse_hex, render
from pyuss.cli.main import main
from pyuss.errors import ConfigError
from pyuss.protocol.layout import MAX_WORDS, PKW_VARIABLE, Layout
from pyuss.protocol.telegram import AddressMode, Telegram
from support.paths import load_vectors

VECTORS = load_vectors("uss")["telegrams"]
BY_NAME = {v["name"]: v for v in VECTORS}
JSON_KEYS = {
    "hex",
    "address",
    "mode",
    "adr",
    "lge",
    "bcc",
    "bcc_expected",
    "bcc_ok",
    "layout",
    "direction",
    "pkw",
    "broadcast_enable",
    "pzd",
    "pzd1",
}
PKW_KEYS = {
    "id",
    "id_name",
    "id_text",
    "pnu",
    "parameter",
    "index",
    "subindex",
    "spm_toggle",
    "values",
    "error_number",
    "error_text",
}


def layout_arg(vec: dict[str, Any]) -> str:
    pkw = vec["layout"]["pkw"]
    return f"{'v' if pkw == 'variable' else pkw},{vec['layout']['pzd']}"


def direction(vec: dict[str, Any]) -> str:
    return "request" if vec["direction"] == "master->slave" else "response"


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any]:
    code = main(["decode", *argv, "--json"])
    out = capsys.readouterr().out
    return code, json.loads(out)


@pytest.mark.parametrize("vec", VECTORS, ids=[v["name"] for v in VECTORS])
def test_json_for_every_vector(capsys: pytest.CaptureFixture[str], vec: dict[str, Any]) -> None:
    code, info = run_json(
        capsys, vec["hex"], "--layout", layout_arg(vec), "--direction", direction(vec)
    )
    assert code == 0
    assert set(info) == JSON_KEYS
    assert info["adr"] == vec["adr"]
    assert info["address"] == vec["adr"] & 0x1F
    assert info["lge"] == vec["lge"]
    assert info["bcc_ok"] is True
    assert info["hex"] == vec["hex"]
    words = [int(w, 16) for w in vec["words_hex"]]
    pzd_count = vec["layout"]["pzd"]
    assert info["pzd"] == words[len(words) - pzd_count :]
    if vec["layout"]["pkw"] == 0:
        assert info["pkw"] is None
    else:
        pkw = info["pkw"]
        assert set(pkw) == PKW_KEYS
        assert pkw["id"] == words[0] >> 12
        assert pkw["pnu"] == words[0] & 0x7FF
        assert pkw["parameter"] == pkw["pnu"]  # no --profile: no IND pages
        assert pkw["spm_toggle"] == bool(words[0] & 0x800)
        assert pkw["index"] == words[1]
        assert pkw["values"] == words[2 : len(words) - pzd_count]


def test_json_names_and_meanings(capsys: pytest.CaptureFixture[str]) -> None:
    vec = BY_NAME["read_whole_pbe_refused"]
    _, info = run_json(capsys, vec["hex"], "-l", "3,2", "-d", "response")
    assert info["mode"] == "normal"
    assert info["pkw"]["id_name"] == "REFUSED"
    assert info["pkw"]["error_number"] == 103
    assert info["pkw"]["error_text"] == "device-specific error 103"
    assert info["pzd1"] == {
        "kind": "status",
        "set": ["READY_TO_SWITCH_ON", "NO_OFF2", "NO_OFF3", "CONTROL_REQUESTED"],
    }
    _, info = run_json(capsys, vec["hex"], "-l", "3,2")
    assert info["pkw"]["id_name"] == "WRITE_ARRAY_WORD"  # the same ID read as a request
    assert info["pkw"]["error_number"] is None
    assert info["pzd1"]["kind"] == "control"


def test_json_broadcast_enable_array(capsys: pytest.CaptureFixture[str]) -> None:
    _, info = run_json(capsys, BY_NAME["broadcast_setpoint"]["hex"], "-l", "4,2")
    assert info["mode"] == "broadcast"
    assert info["broadcast_enable"] == {"a": 5, "b": 0, "c": 0, "d": 0, "flag": True, "words": [2]}
    _, info = run_json(capsys, BY_NAME["read_word_request"]["hex"], "-l", "3,2")
    assert info["broadcast_enable"] is None


def test_wrong_bcc_is_decoded_with_its_verdict(capsys: pytest.CaptureFixture[str]) -> None:
    bad = BY_NAME["read_word_request"]["hex"][:-2] + "56"
    code, info = run_json(capsys, bad, "-l", "3,2")
    assert code == 0
    assert (info["bcc"], info["bcc_expected"], info["bcc_ok"]) == (0x56, 0x55, False)
    assert main(["decode", bad, "-l", "3,2"]) == 0
    assert "BCC        56h WRONG, expected 55h" in capsys.readouterr().out


def test_person_readable_output(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["decode", BY_NAME["read_word_request"]["hex"], "--layout", "3,2"]) == 0
    out = capsys.readouterr().out
    assert "ADR        05h: address 5, normal" in out
    assert "BCC        55h ok" in out
    assert "request 1 READ_VALUE (read parameter value), PNU 52" in out
    assert "bit  0 = 0  OFF1: ramp down and switch off" in out
    assert "bit  1 = 1  no OFF2" in out
    assert "bit 10 = 1  control by PLC" in out
    main(["decode", BY_NAME["read_text_response"]["hex"], "-l", "v,0", "-d", "response"])
    out = capsys.readouterr().out
    assert "text '300 BAUD'" in out
    assert "PWE8" in out
    main(["decode", BY_NAME["pzd_only_request"]["hex"], "-l", "0,2"])
    out = capsys.readouterr().out
    assert "PKW        none (PKW 0)" in out
    assert "PZD2       2000h = 8192 (50.00 % of 4000h)" in out


def test_with_a_profile_the_parameter_is_named_as_the_family_writes_it(
    capsys: pytest.CaptureFixture[str],
) -> None:
    telegram = BY_NAME["read_word_request"]["hex"]  # read PNU 52
    assert main(["decode", telegram, "--layout", "3,2", "--profile", "sinamics-v20"]) == 0
    assert "\n           parameter r0052 (Status word 1)\n" in capsys.readouterr().out
    assert main(["decode", telegram, "--layout", "3,2"]) == 0
    assert "parameter r0052" not in capsys.readouterr().out  # no family: the PNU alone


def test_a_parameter_on_an_ind_page_is_named_with_its_page_counted_in(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """PNU 110 with IND bit 15 (page 1) is r2110 of a SINAMICS V20, named as its parameter
    file names it; the IND line says page 1, not "device bits"."""
    telegram = "020e01606e800100000000047e0000f8"  # read array element, PNU 110, IND 8001h
    assert main(["decode", telegram, "--layout", "4,2", "--profile", "sinamics-v20"]) == 0
    out = capsys.readouterr().out
    assert "parameter r2110 (Warning numbers): PNU 110 on IND page 1 (bits 12..15)" in out
    assert "IND        8001h: subindex 1, bits 8/9 = 00, page 1 (bits 12..15)" in out
    assert "device bits" not in out
    assert main(["decode", telegram, "--layout", "4,2", "--profile", "sinamics-v20", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["pkw"]["parameter"] == 2110


@pytest.mark.parametrize(
    "hexes",
    [
        ["020C0510340000000004 7E00 0055"],
        ["0x02", "0x0C", "0x05", "0x10", "0x34", "0", "0", "0", "0", "4", "7E", "0", "0", "55"],
        ["02:0C:05:10:34:00:00:00:00:04:7E:00:00:55"],
    ],
)
def test_hex_forms(capsys: pytest.CaptureFixture[str], hexes: list[str]) -> None:
    code, info = run_json(capsys, *hexes, "-l", "3,2")
    assert code == 0
    assert info["hex"] == BY_NAME["read_word_request"]["hex"]


@pytest.mark.parametrize(
    ("hexes", "layout", "text"),
    [
        (["02 0C zz"], "3,2", "bad hex 'zz'"),
        (["02 0C 5"], "3,2", "too short"),
        (["020"], "3,2", "odd number of digits"),
        ([BY_NAME["read_word_request"]["hex"]], "5,2", "PKW count must be 0, 3, 4"),
        ([BY_NAME["read_word_request"]["hex"]], "3", "bad layout '3'"),
        ([BY_NAME["read_word_request"]["hex"]], "4,2", "do not fit layout 4,2"),
        (["41" + BY_NAME["read_word_request"]["hex"][2:]], "3,2", "not STX"),
        ([BY_NAME["read_word_request"]["hex"][:-3]], "3,2", "announces 14 bytes, got 13"),
        (["02 02 65 65"], "0,0", "undefined"),
        (["0x"], "3,2", "bad hex '0x'"),
        (["02 0C 0x5G"], "3,2", "bad hex '0x5G'"),
    ],
)
def test_bad_input_gives_one_line_and_exit_2(
    capsys: pytest.CaptureFixture[str], hexes: list[str], layout: str, text: str
) -> None:
    assert main(["decode", *hexes, "--layout", layout]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1
    assert captured.err.startswith("uss decode: ")
    assert text in captured.err
    assert main(["decode", *hexes, "--layout", layout, "--json"]) == 2
    captured = capsys.readouterr()
    error = json.loads(captured.out)
    assert set(error) == {"error"}
    assert text in error["error"]["message"] and error["error"]["exit_code"] == 2


def test_parse_hex_needs_bytes() -> None:
    with pytest.raises(ConfigError, match="no hex"):
        parse_hex(["  "])


def test_the_uss_command_runs_decode() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "pyuss.cli.main", "decode", "02 0C", "--layout", "3,2"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == "uss decode: 2 bytes are too short for a telegram " + (
        "(at least 4: STX, LGE, ADR, BCC)"
    )


@pytest.mark.parametrize(
    ("argv", "text"),
    [
        ([BY_NAME["read_word_request"]["hex"]], "no layout given: --layout PKW,PZD is required"),
        ([BY_NAME["read_word_request"]["hex"], "-l", "3,2", "-d", "sideways"], "bad direction"),
    ],
)
def test_missing_layout_and_bad_direction_are_bad_input(
    capsys: pytest.CaptureFixture[str], argv: list[str], text: str
) -> None:
    assert main(["decode", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith(f"uss decode: {text}")
    assert captured.err.count("\n") == 1
    assert main(["decode", *argv, "--json"]) == 2
    error = json.loads(capsys.readouterr().out)
    assert set(error) == {"error"}
    assert text in error["error"]["message"] and error["error"]["type"] == "ConfigError"


def test_refused_answer_with_padding_is_decoded(capsys: pytest.CaptureFixture[str]) -> None:
    # Response 7 in the variable layout, padded to 3 PWE words: the number travels in PWE1.
    raw = "02 0C 05 70 05 00 00 00 05 00 00 00 00 7B"
    code, info = run_json(capsys, raw, "-l", "v,0", "-d", "response")
    assert code == 0
    assert info["pkw"]["values"] == [5, 0, 0]
    assert info["pkw"]["error_number"] == 5
    assert info["pkw"]["error_text"] == "wrong data type"


@st.composite
def fitting_telegrams(draw: st.DrawFn) -> tuple[bytes, Layout]:
    """Any telegram with a defined ADR whose net data fit the layout drawn with it."""
    layout = Layout(draw(st.sampled_from((0, 3, 4, PKW_VARIABLE))), draw(st.integers(0, 16)))
    words = draw(st.integers(layout.pzd + 3, MAX_WORDS)) if layout.variable else layout.words
    assert words is not None
    address = draw(st.integers(0, 31))
    mode = draw(st.sampled_from(list(AddressMode)))
    data = draw(st.binary(min_size=2 * words, max_size=2 * words))
    return Telegram(address, mode, data).encode(), layout


@given(fitting_telegrams(), st.sampled_from(["request", "response"]))
@settings(max_examples=300)
def test_every_telegram_that_fits_its_layout_is_decoded(
    case: tuple[bytes, Layout], way: str
) -> None:
    raw, layout = case
    info = describe(raw, layout, way)
    assert info["bcc_ok"] is True
    assert bytes.fromhex(info["hex"]) == raw
    assert render(info).startswith("telegram   ")
