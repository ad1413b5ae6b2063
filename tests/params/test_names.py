"""Parameter names: written as the family's documents write them, read in any spelling."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.drive.database import NameStyle
from pyuss.errors import ConfigError
from pyuss.params import ParamBook
from pyuss.params.names import MAX_INDEX, MAX_PNU, param_name, parse_param_name
from pyuss.profiles import get_profile


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("r21", (21, None)),
        ("R21", (21, None)),
        ("P0021", (21, None)),
        ("p21", (21, None)),
        ("21", (21, None)),
        ("21.0", (21, 0)),
        ("21[0]", (21, 0)),
        ("r0947[1]", (947, 1)),
        ("P947.3", (947, 3)),
        (" P2010.1 ", (2010, 1)),
        ("0", (0, None)),
    ],
)
def test_every_spelling_names_the_same_parameter(
    text: str, expected: tuple[int, int | None]
) -> None:
    assert parse_param_name(text) == expected


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("P21x", "'P21x' is not a parameter number (for example r0021, P1120, 21 or 947.1)"),
        ("", "'' is not a parameter number"),
        ("P", "'P' is not a parameter number"),
        ("x21", "'x21' is not a parameter number"),
        ("21.", "'21.' is not a parameter number"),
        ("21[0", "'21[0' is not a parameter number"),
        ("21.0]", "'21.0]' is not a parameter number"),
        ("-21", "'-21' is not a parameter number"),
        ("0x15", "'0x15' is not a parameter number"),
        ("r 21", "'r 21' is not a parameter number"),
        ("\u0663", "is not a parameter number"),  # an Arabic-Indic digit: not the documents'
        ("70000", "'70000': the parameter number must be 0..65535"),
        ("947.255", "'947.255': the index must be 0..254"),
    ],
)
def test_what_names_no_parameter_is_refused_saying_so(text: str, says: str) -> None:
    with pytest.raises(ConfigError) as info:
        parse_param_name(text)
    assert says in str(info.value)


def test_the_siemens_style_writes_r_for_read_only_and_four_digits() -> None:
    siemens = NameStyle.SIEMENS
    assert param_name(21, style=siemens, read_only=True) == "r0021"
    assert param_name(1120, style=siemens) == "P1120"
    assert param_name(947, 0, style=siemens, read_only=True) == "r0947.0"
    assert param_name(2010, 1, style=siemens) == "P2010.1"
    assert param_name(21, read_only=True) == "P21"  # the project's style: no r
    assert param_name(947, 3) == "P947.3"


def test_a_drive_book_names_parameters_in_its_familys_style() -> None:
    mm4 = ParamBook.for_profile(get_profile("micromaster4"))
    assert mm4.label(21) == "r0021" and mm4.label(1120) == "P1120"
    assert mm4.label(947, 0) == "r0947.0"
    assert mm4.label(9999) == "P9999"  # unknown: its access is not known
    assert mm4[21].label() == "r0021"
    nord = ParamBook.for_profile(get_profile("nord"))
    assert nord.label(102) == "P102"
    generic = ParamBook.for_profile(get_profile("generic"))
    assert generic.label(52) == "P52" and generic.label(947, 3) == "P947.3"


@pytest.mark.parametrize("term", ["r0021", "r21", "P0021", "21", "21[0]", "r0021.0"])
def test_search_takes_every_spelling(term: str) -> None:
    book = ParamBook.for_profile(get_profile("micromaster4"))
    assert [info.pnu for info in book.search(term)] == [21]


def test_search_by_the_first_digits_of_either_spelling() -> None:
    book = ParamBook.for_profile(get_profile("micromaster4"))
    assert {info.pnu for info in book.search("r00")} == {p for p in book.pnus() if p < 100}
    assert 1120 in {info.pnu for info in book.search("11")}


@given(
    pnu=st.integers(0, MAX_PNU),
    index=st.none() | st.integers(0, MAX_INDEX),
    style=st.sampled_from(NameStyle),
    read_only=st.booleans(),
)
@settings(max_examples=300)
def test_what_is_written_reads_back_in_every_style(
    pnu: int, index: int | None, style: NameStyle, read_only: bool
) -> None:
    text = param_name(pnu, index, style=style, read_only=read_only)
    assert parse_param_name(text) == (pnu, index)
    assert parse_param_name(text.lower()) == (pnu, index)
    bracket = text if index is None else text.replace(f".{index}", f"[{index}]")
    assert parse_param_name(bracket) == (pnu, index)


def test_what_the_book_learns_later_is_named_in_its_style_too() -> None:
    from pyuss.drive.loader import load_profile

    mm4 = ParamBook.for_profile(get_profile("micromaster4"))
    kept = {"parameters": [{**mm4[21].to_dict(), "pnu": 9021}]}  # a description cached
    mm4.load_cache_data(kept)
    assert mm4.label(9021) == "r9021"
    unnamed = ParamBook()  # a drive of no profile, with the user's file of a Siemens drive
    unnamed.use_database(load_profile("micromaster4"))
    assert unnamed.label(21) == "r0021" and unnamed.label(1120) == "P1120"
