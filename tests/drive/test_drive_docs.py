"""docs/drive.md stays true: its examples run and give what the comments say."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pyuss.drive.loader import parse_database
from pyuss.drive.simulated import SimulatedDrive

DOC = Path(__file__).resolve().parents[2] / "docs" / "drive.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)


def test_the_parameter_file_example_is_valid() -> None:
    example, _ = _blocks("toml")
    db = parse_database(example, "docs/drive.md")
    assert db.profile.name == "conveyor"
    assert 91 not in db and db.parameter(684).allowed == (6, 7)
    drive = SimulatedDrive(db)
    drive.exchange([0x047E, 0], 0.0)
    reply = drive.exchange([0x047F | 0x0100, 0, 0], 0.0)  # jog 1
    assert reply[2] == 75
    drive.step(10.0)
    assert drive.actual_value() == round(0.075 * 0x4000)


def test_the_editions_example_gives_each_edition_its_values() -> None:
    _, example = _blocks("toml")
    own = parse_database(example, "docs/drive.md")
    assert own.profile.editions == ("2020", "2015")
    assert own.parameter(10).default == (6,) and 20 in own
    old = parse_database(example, "docs/drive.md", edition="2015")
    assert old.parameter(10).default == (8,) and 20 not in old
    assert old.profile.manual == "Fan drive manual, 2015"


def _run(example: str) -> dict[str, object]:
    lines = [line.split("#")[0].rstrip() for line in example.splitlines()]
    namespace: dict[str, object] = {}
    exec("\n".join(lines), namespace)
    return namespace


def test_the_python_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    example, _ = _blocks("python")
    monkeypatch.chdir(tmp_path)
    namespace = _run(example)
    drive = namespace["drive"]
    assert isinstance(drive, SimulatedDrive)
    assert drive.exchange([0x047F, 0x2000], now=10.0) == (0x0337, 0x2000)
    assert drive.value(4, 2) == 0x4000_0000
    assert (tmp_path / "drive5.store").exists()


def test_the_sources_example_runs_as_its_comments_say() -> None:
    _, example = _blocks("python")
    v20 = _run(example)["v20"]
    assert isinstance(v20, SimulatedDrive)
    assert v20.running  # after P0700 = 5 and P1000 = 5: ON and 50 % taken
    v20.step(100.0)
    assert v20.actual_value() == 0x2000
    # the same telegrams before the writes did nothing (the example's first lines)
    fresh = SimulatedDrive.from_profile("sinamics-v20", factory=True)
    assert (fresh.value(700, 0), fresh.value(1000, 0)) == (1, 1)
    fresh.exchange([0x047E, 0x2000], now=0.0)
    fresh.exchange([0x047F, 0x2000], now=0.0)
    assert fresh.state.name == "SWITCH_ON_INHIBIT" and fresh.machine.control == 0
