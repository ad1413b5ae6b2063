"""Editions of a parameter file (``[profile] edition`` and ``[editions.NAME]``): the file's own
values are one edition of its manual, each further edition changes fields of parameters or
drops some, chosen as ``NAME@EDITION`` or with ``edition=``; an unknown or malformed edition is
refused naming the file and the place."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from pyuss.drive.loader import load_database, parse_database, split_edition
from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import ConfigError

FILE = """
[profile]
name = "fan"
manual = "Fan drive manual, 2020"
edition = "2020"

[editions.2015]
manual = "Fan drive manual, 2015"
remove = [20]
[[editions.2015.parameter]]
pnu = 10
default = 8
max = 8
name = "Baud (old)"

[[parameter]]
pnu = 10
name = "Baud code"
type = "uint16"
min = 6
max = 12
default = 6

[[parameter]]
pnu = 20
name = "Parity"
type = "uint16"
max = 2
"""


def test_the_files_own_values_are_its_edition_and_the_default() -> None:
    db = parse_database(FILE)
    assert db.profile.edition == "2020"
    assert db.profile.editions == ("2020", "2015")
    assert db.parameter(10).default == (6,)
    assert 20 in db
    same = parse_database(FILE, edition="2020")
    assert same.parameter(10).default == (6,) and same.profile.manual == "Fan drive manual, 2020"


def test_an_edition_changes_the_fields_it_names_and_drops_what_it_removes() -> None:
    old = parse_database(FILE, edition="2015")
    assert old.profile.edition == "2015"
    assert old.profile.manual == "Fan drive manual, 2015"
    p = old.parameter(10)
    assert (p.name, p.default, p.minimum, p.maximum) == ("Baud (old)", (8,), 6, 8)
    assert 20 not in old


def test_a_file_without_editions_has_none(tmp_path: Path) -> None:
    path = tmp_path / "plain.toml"
    path.write_text('[profile]\nname = "plain"\n', encoding="utf-8")
    assert load_database(path).profile.editions == ()
    with pytest.raises(ConfigError, match=r"unknown edition '1' \(known: none\)"):
        load_database(path, "1")


def test_an_edition_of_a_file_is_checked_like_the_file(tmp_path: Path) -> None:
    path = tmp_path / "fan.toml"
    path.write_text(FILE.replace("default = 8", "default = 9"), encoding="utf-8")
    load_database(path)  # the file's own edition is fine
    with pytest.raises(ConfigError, match="parameter 10"):
        load_database(path, "2015")
    # python -m pyuss.drive check builds every edition, so the bad one is found
    for text, code, says in ((None, 2, "parameter 10"), (FILE, 0, "(editions 2020, 2015)")):
        if text is not None:
            path.write_text(text, encoding="utf-8")
        done = subprocess.run(
            [sys.executable, "-m", "pyuss.drive", "check", str(path)],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert done.returncode == code and says in done.stdout + done.stderr


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (('edition = "2020"\n', ""), "'edition': required with [editions]"),
        (('edition = "2020"', "edition = 2020"), "'edition': must be a non-empty text"),
        (("[editions.2015]", "[editions.2020]"), "the name is the file's own edition"),
        (('manual = "Fan drive manual, 2015"\n', ""), "field 'manual': required"),
        (("remove = [20]", "remove = [30]"), "remove: the file has no parameter 30"),
        (("pnu = 10\ndefault = 8", "pnu = 11\ndefault = 8"), "parameter 11: the file has no"),
        (('name = "Baud (old)"', "colour = 1"), "unknown field(s) ['colour']"),
        (("remove = [20]", "drop = [20]"), "unknown field(s) drop"),
    ],
)
def test_a_malformed_edition_is_refused_naming_the_place(
    change: tuple[str, str], says: str
) -> None:
    old, new = change
    assert old in FILE
    with pytest.raises(ConfigError, match=r"\[editions|\[profile\]|edition") as info:
        parse_database(FILE.replace(old, new, 1), "fan.toml", edition="2015")
    assert says in str(info.value) and "fan.toml" in str(info.value)


def test_an_unknown_edition_names_the_known_ones() -> None:
    with pytest.raises(
        ConfigError, match=r"fan\.toml: unknown edition '1999' \(known: 2020, 2015\)"
    ):
        parse_database(FILE, "fan.toml", edition="1999")


def test_a_name_with_an_edition_splits_at_the_mark() -> None:
    assert split_edition("sinamics-v20@2012") == ("sinamics-v20", "2012")
    assert split_edition("sinamics-v20") == ("sinamics-v20", None)
    for bad in ("@2012", "sinamics-v20@"):
        with pytest.raises(ConfigError, match="both parts"):
            split_edition(bad)


def test_a_file_that_extends_another_does_not_take_its_editions(tmp_path: Path) -> None:
    (tmp_path / "fan.toml").write_text(FILE, encoding="utf-8")
    child = tmp_path / "child.toml"
    child.write_text('[profile]\nname = "child"\nextends = "fan.toml"\n', encoding="utf-8")
    db = load_database(child)
    assert db.profile.editions == () and db.profile.edition == ""
    with pytest.raises(ConfigError, match="unknown edition"):
        load_database(child, "2015")


def test_a_simulated_drive_of_an_edition_has_that_editions_factory_values() -> None:
    drive = SimulatedDrive.from_profile("sinamics-v20@2012", factory=True, now=0.0)
    assert drive.value(2010, 0) == 8
    assert "07/2012" in drive.db.profile.manual
