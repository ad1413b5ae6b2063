"""The MICROMASTER 420 against its Parameter List, issue 04/02: the entries of the pages read,
written down here from the pages (not from the parameter file), checked against the file; and
the list of the parameters of access levels 1 and 2 (`pyuss/profiles/lists/micromaster420.toml`),
each in the file or left out with a reason."""

from __future__ import annotations

import pytest

from pyuss.drive.datatypes import DataType
from pyuss.drive.loader import load_profile
from support.listfiles import Entry, check_coverage, check_docs, check_entry, manual_list

FLOAT, U16 = DataType.FLOAT, DataType.UINT16

PAGES = [
    # page 84: P2012[2] USS PZD length, index 0 COM link, 1 BOP link
    Entry(2012, U16, 0, 4, 2, array=2, changeable="CUT", level=3, page=84),
    # page 108: the PID controller
    Entry(2280, FLOAT, 0.0, 125.0, 3.0, changeable="CUT", page=108),
    Entry(2285, FLOAT, 0.0, 100.0, 0.0, unit="s", changeable="CUT", page=108),
    Entry(2291, FLOAT, -200.0, 200.0, 100.0, unit="%", changeable="CUT", page=108),
    Entry(2292, FLOAT, -200.0, 200.0, 0.0, unit="%", changeable="CUT", page=108),
    Entry(2293, FLOAT, 0.0, 100.0, 1.0, unit="s", changeable="CUT", page=108),
]

REACHED = 90 / 102
"""The share of the list the file holds today (the floor; raise it as the file grows)."""


@pytest.mark.parametrize("entry", PAGES, ids=lambda e: f"P{e.pnu:04d}")
def test_the_file_says_what_the_page_says(entry: Entry) -> None:
    check_entry(load_profile("micromaster420"), entry)


def test_every_listed_parameter_is_in_the_file_or_left_out_with_a_reason() -> None:
    check_coverage(
        load_profile("micromaster420"), manual_list("micromaster420"), "micromaster420", REACHED
    )


def test_docs_give_the_lists_figures_and_what_is_left_out() -> None:
    check_docs(load_profile("micromaster420"), manual_list("micromaster420"))
