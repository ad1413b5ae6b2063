"""`pyuss.commission.survey.line_table`: the line a scan found, as the lines' reader takes it."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyuss.commission.survey import Surveyed, line_table, save_line
from pyuss.errors import ConfigError
from pyuss.lines import load
from pyuss.master.scan import Found
from pyuss.protocol.layout import Layout


def drive(address: int, baud: int, layout: str = "3,2", profile: str | None = None) -> Surveyed:
    found = Found(address, baud, Layout.parse(layout), 0, 0.0)
    return Surveyed(found, None if profile is None else "x", profile)


def test_the_rate_most_drives_answered_at_and_the_others_left_out() -> None:
    drives = [drive(1, 9600), drive(2, 19200), drive(3, 19200, "4,2"), drive(2, 38400)]
    data, left = line_table("/dev/ttyUSB0", drives)
    (line,) = data["bus"]
    assert (line["baud"], line["layout"]) == (19200, "3,2")
    assert line["drive"] == [
        {"name": "drive2", "address": 2},
        {"name": "drive3", "address": 3, "layout": "4,2"},  # its own, not the line's
    ]
    assert [d.address for d in left] == [1]


def test_a_drive_of_unknown_kind_keeps_the_line_without_a_profile(tmp_path: Path) -> None:
    data, _ = line_table("tcp://h:1", [drive(5, 9600, profile="sinamics-v20"), drive(6, 9600)])
    (line,) = data["bus"]
    assert "profile" not in line
    assert line["drive"][0]["profile"] == "sinamics-v20" and "profile" not in line["drive"][1]
    save_line(data, tmp_path / "uss.toml")
    lines = load(tmp_path / "uss.toml")
    assert lines.target(None, "6", port_given=False).profile is None
    assert lines.target(None, "5", port_given=False).profile == "sinamics-v20"
    with pytest.raises(ConfigError, match=r"uss\.toml exists: --force replaces it"):
        save_line(data, tmp_path / "uss.toml")
    save_line(data, tmp_path / "uss.toml", overwrite=True)
