"""The MICROMASTER 440 against its Parameter List, issue 01/06 (firmware V2.1): the entries of
the pages read, written down here from the pages (not from the parameter file), checked against
the file; and the list of the parameters of access levels 1 and 2
(`pyuss/profiles/lists/micromaster440.toml`), each in the file or left out with a reason."""

from __future__ import annotations

import pytest

from pyuss.drive.datatypes import DataType
from pyuss.drive.loader import load_profile
from support.listfiles import Entry, check_coverage, check_docs, check_entry, manual_list

FLOAT, U16 = DataType.FLOAT, DataType.UINT16
BIG = 99999.0

PAGES = [
    # page 95: the analog outputs' scaling, index 0/1 = DAC 1/2
    Entry(778, FLOAT, 0, 20, 0, array=2, changeable="CUT", level=2, page=95),
    Entry(
        779, FLOAT, -99999.0, 99999.0, 100.0, array=2, unit="%", changeable="CUT", level=2, page=95
    ),
    Entry(780, FLOAT, 0, 20, 20, array=2, changeable="CUT", level=2, page=95),
    # page 107: r0948 fault time, 12 indices (three a trip for the last four trips)
    Entry(948, U16, None, None, None, array=12, level=3, read_only=True, page=107),
    # page 127: P1080[3] minimum frequency, per drive data set
    Entry(1080, FLOAT, 0.0, 650.0, 0.0, array=3, unit="Hz", changeable="CUT", level=1, page=127),
    # page 196: P2012[2] USS PZD length, index 0 COM link, 1 BOP link
    Entry(2012, U16, 0, 8, 2, array=2, changeable="CUT", level=3, page=196),
    # page 237: the PID controller, not per data set
    Entry(2274, FLOAT, 0.0, 60.0, 0.0, unit="s", changeable="CUT", page=237),
    Entry(2280, FLOAT, 0.0, 65.0, 3.0, changeable="CUT", page=237),
    Entry(2285, FLOAT, 0.0, 60.0, 0.0, unit="s", changeable="CUT", page=237),
    Entry(2291, FLOAT, -200.0, 200.0, 100.0, unit="%", changeable="CUT", page=237),
]

REACHED = 76 / 121
"""The share of the list the file holds today (the floor; raise it as the file grows)."""


@pytest.mark.parametrize("entry", PAGES, ids=lambda e: f"P{e.pnu:04d}")
def test_the_file_says_what_the_page_says(entry: Entry) -> None:
    check_entry(load_profile("micromaster440"), entry)


def test_every_listed_parameter_is_in_the_file_or_left_out_with_a_reason() -> None:
    check_coverage(
        load_profile("micromaster440"), manual_list("micromaster440"), "micromaster440", REACHED
    )


def test_the_list_is_of_firmware_2_1() -> None:
    assert "issue 01/06" in manual_list("micromaster440").manual
    assert "V2.1" in manual_list("micromaster440").manual


def test_docs_give_the_lists_figures_and_what_is_left_out() -> None:
    check_docs(load_profile("micromaster440"), manual_list("micromaster440"))
