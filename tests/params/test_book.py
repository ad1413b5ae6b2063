"""`ParamBook`: the user's file above the drive's descriptions above the profile's file; search;
the description cache; the docs example of values."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pyuss.drive.database import Access, DescriptionStyle
from pyuss.drive.datatypes import DataType
from pyuss.drive.description import description
from pyuss.drive.loader import load_profile, parse_database
from pyuss.errors import ConfigError
from pyuss.master.description import decode_description
from pyuss.params import Describe, ParamBook, Source
from pyuss.profiles import get_profile
from support.paths import ROOT


def drive_description(text: str, pnu: int):  # type: ignore[no-untyped-def]
    """The description a drive with parameter file ``text`` sends for ``pnu`` (C 6)."""
    param = parse_database(text).parameter(pnu)
    words = [w for e in description(param, DescriptionStyle.PROFIBUS) for w in e.words]
    return decode_description(pnu, words)


NEWER_FIRMWARE = """
[profile]
extends = "micromaster4"
[[parameter]]
pnu = 1120
name = "Ramp up"
type = "float"
unit = "s"
min = 0.0
max = 99.0
"""


def test_the_drives_description_wins_over_the_profile_but_keeps_its_unit_and_texts() -> None:
    book = ParamBook.for_profile(get_profile("micromaster4"))
    shipped = book[1120]
    assert (shipped.source, shipped.maximum, shipped.unit) == (Source.PROFILE, 650.0, "s")
    assert not book.needs_description(1120)  # MISSING: the profile's file knows it
    book.describe = Describe.ALWAYS
    assert book.needs_description(1120)
    book.learn(drive_description(NEWER_FIRMWARE, 1120))  # a description carries no unit
    live = book[1120]
    assert (live.source, live.name, live.maximum, live.unit) == (Source.DRIVE, "Ramp up", 99.0, "s")
    assert not book.needs_description(1120)  # asked once


def test_the_users_file_wins_over_everything(tmp_path: Path) -> None:
    book = ParamBook.for_profile(get_profile("micromaster4"))
    book.learn(drive_description(NEWER_FIRMWARE, 1120))
    mine = tmp_path / "mine.toml"
    mine.write_text(NEWER_FIRMWARE.replace("max = 99.0", "max = 30.0"), encoding="utf-8")
    book.use_file(mine)
    assert (book[1120].source, book[1120].maximum) == (Source.USER, 30.0)
    assert book[2010].source is Source.USER  # the file extends the profile: all of it is the user's
    book.describe = Describe.ALWAYS
    assert not book.needs_description(1120)


def test_a_broken_user_file_is_bad_input(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(
        "[profile]\nname = 'mine'\n[[parameter]]\npnu = 5\nname = 'x'\ntype = 'float9'\n",
        encoding="utf-8",
    )
    book = ParamBook()
    with pytest.raises(ConfigError, match="type"):
        book.use_file(bad)


def test_search_by_number_and_by_words() -> None:
    book = ParamBook.for_profile(get_profile("micromaster4"))
    assert [p.pnu for p in book.search("1120")] == [1120]
    assert [p.pnu for p in book.search("P112")] == [1120, 1121]
    assert [p.pnu for p in book.search("ramp-down")] == [1121, 1135]
    assert [p.pnu for p in book.search("ramp-down time")] == [1121]
    assert [p.pnu for p in book.search("USS")] == [2010, 2011, 2012, 2013, 2014]
    assert len(book.search("")) == len(book) == len(load_profile("micromaster4"))
    assert list(book.indices(book[2010])) == [0, 1]


def test_keys_the_parameter_file_may_grow_reach_the_model() -> None:
    book = ParamBook.for_profile(get_profile("micromaster4"))
    assert book[310].changeable in ("CT", "C")  # not while running
    assert book[310].access is Access.PROTECTED
    assert book[52].dtype is DataType.V2 and book[52].is_bit_field


def test_the_cache_file_keeps_drives_apart_and_refuses_a_foreign_file(tmp_path: Path) -> None:
    cache = tmp_path / "cache.json"
    one = ParamBook.for_profile(get_profile("micromaster4"))
    one.learn(drive_description(NEWER_FIRMWARE, 1120))
    one.no_description(5)
    one.save_cache(cache, "a")
    ParamBook().save_cache(cache, "b")
    again = ParamBook.for_profile(get_profile("micromaster4"))
    again.load_cache(cache, "a")
    assert again[1120].name == "Ramp up" and not again.needs_description(5)
    other = ParamBook()
    other.load_cache(cache, "b")
    assert len(other) == 0
    ParamBook().load_cache(tmp_path / "missing.json", "a")  # no file yet: an empty cache
    cache.write_text("[1, 2]", encoding="utf-8")
    with pytest.raises(ConfigError, match="not a pyuss description cache"):
        ParamBook().load_cache(cache, "a")


def test_descriptions_are_asked_only_where_the_profile_says_the_drive_has_them() -> None:
    unknown = ParamBook()  # a drive of no named profile
    assert unknown.describe is Describe.AUTO and not unknown.needs_description(150)
    unknown.describe = Describe.MISSING
    assert unknown.needs_description(150)
    unknown.describe = Describe.ALWAYS
    assert unknown.needs_description(150)
    generic = ParamBook.for_profile(get_profile("generic"))  # its drives answer request 4
    assert generic.needs_description(1999) and not generic.needs_description(3)
    generic.no_descriptions()  # it refused one, or did not answer: asked no more
    generic.describe = Describe.ALWAYS
    assert not generic.needs_description(1999) and not generic.needs_description(3)


def test_a_drive_without_descriptions_is_kept_so_in_the_cache_file(tmp_path: Path) -> None:
    cache = tmp_path / "cache.json"
    book = ParamBook(describe=Describe.ALWAYS)
    book.no_descriptions()
    book.save_cache(cache, "pump")
    ParamBook(describe=Describe.ALWAYS).save_cache(cache, "other")
    again = ParamBook(describe=Describe.ALWAYS)
    again.load_cache(cache, "pump")
    assert again.without_descriptions and not again.needs_description(150)
    other = ParamBook(describe=Describe.ALWAYS)
    other.load_cache(cache, "other")
    assert not other.without_descriptions and other.needs_description(150)
    with pytest.raises(ConfigError, match="'descriptions' must be true or false"):
        ParamBook().load_cache_data({"descriptions": "no"})


def test_the_values_example_of_the_master_docs_runs(capsys: pytest.CaptureFixture[str]) -> None:
    text = (ROOT / "docs" / "master.md").read_text(encoding="utf-8")
    section = text.split("### Values", 1)[1].split("\n### ", 1)[0]
    [code] = re.findall(r"```python\n(.*?)```", section, re.S)
    exec(compile(code, "docs/master.md values", "exec"), {"__name__": "__main__"})
    out = capsys.readouterr().out.splitlines()
    expected = [
        line.split("# ")[1].split(" ")[0].rstrip(":")
        for line in code.splitlines()
        if "print(" in line
    ]
    assert out[0] == "10.0" and out[1] == "P1120 = 10.00 s (Ramp-up time)"
    assert out[2] == "(16672, 0)" and out[3] == "2.5" and out[4] == "8"  # the bus's 38400 baud
    assert out[5] == "[0, 0, 0, 0, 0, 0, 0, 0]"
    assert len(out) == len(expected)
