"""BICO inputs end to end: ``uss simulate --profile sinamics-g120c`` in a process of its own,
``uss read``, ``uss write``, ``uss backup`` and ``uss restore`` against it."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from pyuss.cli.main import main
from support.processes import simulator

BAUD = "38400"


@pytest.fixture(scope="module")
def sim() -> Iterator[str]:
    """A simulated G120C at address 5 on TCP; yields its ``tcp://`` URL."""
    with simulator("--profile", "sinamics-g120c", "--address", "5", "--baud", BAUD) as url:
        yield url


def uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def line(url: str) -> list[str]:
    return ["--port", url, "--baud", BAUD, "--profile", "sinamics-g120c"]


def test_read_and_write_a_source(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = uss(capsys, "read", "5", "p0840[0]", *line(sim))
    assert (code, out) == (0, "P0840.0 = r2090.0 (ON/OFF1 source)\n")  # the factory source
    code, out, _ = uss(capsys, "write", "5", "p0840[1]", "r722.2", *line(sim))
    assert (code, out) == (0, "P0840.1 = r722.2 (ON/OFF1 source)\n")
    code, out, _ = uss(capsys, "read", "5", "p0840[1]", *line(sim))
    assert (code, out) == (0, "P0840.1 = r722.2 (ON/OFF1 source)\n")
    code, out, _ = uss(capsys, "read", "5", "p0840[1]", *line(sim), "--json")
    [reading] = json.loads(out)["parameters"]
    assert reading["value"] == "r722.2" and reading["raw"] == [0x02D2, 0xFC02]
    code, out, _ = uss(capsys, "write", "5", "p0840[1]", "2090.0", *line(sim))  # no "r"
    assert (code, out) == (0, "P0840.1 = r2090.0 (ON/OFF1 source)\n")


@pytest.mark.parametrize("value", ["r722.x", "722.2.1", "on", "r722.2000"])
def test_a_malformed_source_is_refused_and_nothing_sent(
    sim: str, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    code, out, err = uss(capsys, "write", "5", "p0840[1]", value, *line(sim))
    assert code == 2 and out == ""
    assert err.startswith("uss write: P0840.1 (BICO input): ")
    assert "r722.2" in err or "0..1023" in err
    _, out, _ = uss(capsys, "read", "5", "p0840[1]", *line(sim))
    assert out == "P0840.1 = r2090.0 (ON/OFF1 source)\n"


def test_backup_and_restore_carry_the_sources(
    sim: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert uss(capsys, "write", "5", "p1113[1]", "r722.3", *line(sim))[0] == 0
    backup = tmp_path / "g120c.toml"
    code, _, _ = uss(capsys, "backup", "5", "-o", str(backup), *line(sim))
    assert code == 0
    text = backup.read_text()
    assert 'value = ["r2090.11", "r722.3"]' in text and 'raw = "082A FC0B 02D2 FC03"' in text
    assert uss(capsys, "write", "5", "p1113[1]", "r2090.11", *line(sim))[0] == 0
    code, out, _ = uss(capsys, "restore", "5", str(backup), *line(sim), "--yes")
    assert code == 0, out
    assert "P1113.1 (Setp invert src): r2090.11 -> r722.3" in out
    _, out, _ = uss(capsys, "read", "5", "p1113[1]", *line(sim))
    assert out == "P1113.1 = r722.3 (Setp invert src)\n"
    code, out, _ = uss(capsys, "diff", "5", str(backup), *line(sim))
    assert code == 0 and "agree" in out
    assert uss(capsys, "write", "5", "p1113[1]", "r2090.11", *line(sim))[0] == 0
