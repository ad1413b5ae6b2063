"""Words a person reads, through the `uss` command in processes of its own against `uss
simulate` over TCP: `uss read` and `uss status` show the status and control words in hex with
the names of their set bits (`pyuss.params.words`), `uss diff` names its sides and says what
`uss restore` would do."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from support.processes import USS, simulator

BAUD = "38400"
AFTER_POWER_UP = (
    "EA40h  switch-on inhibited, control requested, no motor current limit warning, "
    "no motor overload, motor turns right, no inverter overload"
)
"""A SINAMICS V20's status word 1 after power-up: switch-on inhibited, no warning (its
warning bits 11, 13 and 15 are 1 while there is none)."""


@pytest.fixture(scope="module")
def v20() -> Iterator[str]:
    with simulator("--profile", "sinamics-v20", "--address", "5", "--baud", BAUD) as url:
        yield url


def uss(url: str, *args: str) -> tuple[int, str]:
    done = subprocess.run(
        [*USS, *args, "--port", url, "--baud", BAUD, "--profile", "sinamics-v20"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    return done.returncode, done.stdout + done.stderr


def test_read_shows_status_and_control_words_with_their_set_bits(v20: str) -> None:
    code, out = uss(v20, "read", "5", "r0052", "r0054", "P1120")
    assert code == 0, out
    assert out.splitlines() == [
        f"r0052 (Status word 1) = {AFTER_POWER_UP}",
        "r0054 (Control word 1) = 0000h  no bit set",
        "P1120 = [10.00, 10.00, 10.00] s (Ramp-up time)",  # any other parameter as before
    ]
    code, out = uss(v20, "read", "5", "r0052", "P1120", "--json")
    first, second = json.loads(out)["parameters"]
    assert first["value"] == 0xEA40 and first["word"]["text"] == AFTER_POWER_UP
    assert [b["bit"] for b in first["word"]["bits"]] == [6, 9, 11, 13, 14, 15]
    assert "word" not in second


def test_status_shows_the_word_with_its_set_bits(v20: str) -> None:
    code, out = uss(v20, "status", "5")
    assert code == 0, out
    assert out.splitlines()[:2] == ["drive 5: switch-on inhibited", f"status word {AFTER_POWER_UP}"]
    code, out = uss(v20, "status", "5", "--json")
    assert json.loads(out)["status_text"] == AFTER_POWER_UP


def test_diff_names_its_sides_and_what_a_restore_would_do(v20: str, tmp_path: Path) -> None:
    backup = str(tmp_path / "v20.toml")
    assert uss(v20, "backup", "5", "-o", backup)[0] == 0
    try:
        assert uss(v20, "write", "5", "P1120.0", "3.5")[0] == 0
        code, out = uss(v20, "diff", "5", backup)
        assert code == 1, out
        assert out.splitlines() == [
            f"left: drive 5 (live) -> right: file ({backup})",
            "P1120 (Ramp-up time): [3.50, 10.00, 10.00] s -> [10.00, 10.00, 10.00] s",
            f"1 parameter differs between drive 5 and {backup}",
            f"uss restore 5 {backup} (file -> drive 5) would make 1 write: P1120.0",
        ]
        code, out = uss(v20, "diff", "5", backup, "--json")
        data = json.loads(out)
        assert data["sides"] == {"left": "drive 5 (live)", "right": f"file ({backup})"}
        assert data["restore"].endswith("would make 1 write: P1120.0")
    finally:
        assert uss(v20, "restore", "5", backup, "--yes")[0] == 0
    code, out = uss(v20, "diff", "5", backup)
    assert code == 0 and out.splitlines()[-1] == (
        f"uss restore 5 {backup} (file -> drive 5) would write nothing"
    )
