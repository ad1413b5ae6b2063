"""The SINAMICS V20 against its Operating Instructions: the entries of the parameter-list
pages read (07/2012 pages 179 and 206, 09/2014 page 229), written down here from the pages (not
from the parameter file), checked against the file; the list of the V20 parameters the project
knows (`pyuss/profiles/lists/sinamics-v20.toml`), each in the file or left out with a reason;
and the editions of the instructions (`sinamics-v20@2012`)."""

from __future__ import annotations

import pytest

from pyuss.drive.datatypes import DataType
from pyuss.drive.loader import load_profile
from pyuss.errors import ConfigError
from pyuss.profiles import get_profile
from support.listfiles import Entry, check_coverage, check_docs, check_entry, manual_list

FLOAT, U16 = DataType.FLOAT, DataType.UINT16

PAGES = [
    # 07/2012 page 179: the boosts, per drive data set, PERCENT
    Entry(1311, FLOAT, 0.0, 250.0, 0.0, array=3, unit="%", changeable="UT", level=2, page=179),
    Entry(1312, FLOAT, 0.0, 250.0, 0.0, array=3, unit="%", changeable="UT", level=2, page=179),
    # 07/2012 page 206: the PID controller, not per data set
    Entry(2285, FLOAT, 0.0, 60.0, 0.0, unit="s", changeable="UT", level=2, page=206),
    Entry(2291, FLOAT, -200.0, 200.0, 100.0, unit="%", changeable="UT", level=2, page=206),
    Entry(2292, FLOAT, -200.0, 200.0, 0.0, unit="%", changeable="UT", level=2, page=206),
    Entry(2293, FLOAT, 0.0, 100.0, 1.0, unit="s", changeable="UT", level=3, page=206),
    Entry(2294, FLOAT, None, None, None, read_only=True, page=206),
    Entry(2295, FLOAT, -100.0, 100.0, 100.0, unit="%", changeable="UT", level=3, page=206),
    # 09/2014 page 229: P2013[0...1], 0 - 127 (0, 3, 4, 127), factory 127, U, T, U16, level 3
    Entry(2013, U16, None, None, 127, array=2, changeable="UT", level=3, page=229),
]

REACHED = 102 / 143
"""The share of the list the file holds today (the floor; raise it as the file grows)."""


@pytest.mark.parametrize("entry", PAGES, ids=lambda e: f"P{e.pnu:04d}")
def test_the_file_says_what_the_page_says(entry: Entry) -> None:
    check_entry(load_profile("sinamics-v20"), entry)


def test_every_listed_parameter_is_in_the_file_or_left_out_with_a_reason() -> None:
    db = load_profile("sinamics-v20")
    check_coverage(db, manual_list("sinamics-v20"), "sinamics-v20", REACHED, levels=False)


def test_docs_give_the_lists_figures_and_what_is_left_out() -> None:
    check_docs(load_profile("sinamics-v20"), manual_list("sinamics-v20"))


def test_the_default_is_the_newest_edition_and_the_older_ones_are_selectable() -> None:
    newest = load_profile("sinamics-v20")
    assert newest.profile.edition == "2019"
    assert newest.profile.editions == ("2019", "2014", "2012")
    assert "10/2019" in newest.profile.manual
    old = load_profile("sinamics-v20@2012")
    assert old.profile.edition == "2012"
    assert old.profile.manual.startswith("SINAMICS V20 Inverter Operating Instructions, 07/2012")
    assert "09/2014" in load_profile("sinamics-v20@2014").profile.manual
    assert load_profile("sinamics-v20@2019").profile.manual == newest.profile.manual
    # read in 07/2012 6.2 and the same in the file's own edition: 38400 baud
    assert old.parameter(2010).default == newest.parameter(2010).default == (8, 8)


def test_a_profile_of_an_edition_talks_like_the_family_with_that_editions_file() -> None:
    profile = get_profile("sinamics-v20@2012")
    assert profile.name == "sinamics-v20@2012"
    assert profile.database().profile.edition == "2012"
    assert profile.baud_codes == get_profile("sinamics-v20").baud_codes
    assert get_profile("sinamics-v20@2012") is profile


@pytest.mark.parametrize(
    ("name", "says"),
    [
        ("sinamics-v20@1999", "unknown edition '1999' (known: 2019, 2014, 2012)"),
        ("generic@2012", "unknown edition '2012' (known: none)"),
        ("sinamics-v20@", "both parts given"),
        ("nosuch@2012", "unknown profile 'nosuch'"),
    ],
)
def test_an_unknown_edition_is_refused_naming_the_known_ones(name: str, says: str) -> None:
    with pytest.raises(ConfigError, match=says.replace("(", r"\(").replace(")", r"\)")):
        get_profile(name)
    with pytest.raises(ConfigError, match=says.replace("(", r"\(").replace(")", r"\)")):
        load_profile(name)
