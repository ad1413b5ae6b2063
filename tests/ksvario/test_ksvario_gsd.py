"""GSD file (KS VARIO PROFIBUS-DP interface description, 9.4): emit, parse back, and parse the
document's own file where ../shared holds it."""

from __future__ import annotations

import re

import pytest

from pyuss.errors import ConfigError
from pyuss.ksvario.diag import IDENT_NUMBER, Diagnosis
from pyuss.ksvario.gsd import emit_gsd, parse_gsd
from pyuss.ksvario.modules import MODULES
from support.paths import load_vectors, shared_folder


def _document_gsd() -> str:
    """The GSD file printed in the KS VARIO interface description (section 9.4), from ../shared."""
    text = (shared_folder() / "seeds" / "003_3a92a27fc43b4069.txt").read_text(encoding="utf-8")
    start = text.index("#Profibus_DP")
    body = text[start:]
    return re.sub(r"^```\s*$", "", body, flags=re.M)


def test_ident_number_of_the_vectors() -> None:
    """The vector's ident number 1030h is the GSD's and diagnosis bytes 5-6 (6.1.1)."""
    ident = int(load_vectors("ksvario")["gsd_ident_number"], 16)
    assert parse_gsd(emit_gsd()).ident_number == ident == IDENT_NUMBER
    assert Diagnosis().encode()[4:6] == ident.to_bytes(2, "big")


def test_emitted_gsd_parses_back() -> None:
    text = emit_gsd()
    assert text.endswith("\r\n") and text.isascii()
    gsd = parse_gsd(text)
    assert gsd.ident_number == 0x1030
    assert gsd.text("Model_Name") == "KS Vario/DP"
    assert gsd.number("Max_Module") == 50
    assert [(m.config, m.reference) for m in gsd.modules] == [
        (bytes((m.ident,)), m.number) for m in MODULES
    ]
    assert gsd.default_user_prm() == bytes(4)
    assert gsd.prm_texts[3] == {0: "last value", 1: "zero"}
    assert gsd.user_prms[2].first_bit == 1 and gsd.user_prms[2].text_ref == 2
    assert gsd.diag_bits[32] == "E.1 Internal error"
    assert gsd.diag_bits[48] == "Fail Fail input"
    area = gsd.diag_areas[0]
    assert (area.first_bit, area.last_bit, area.values[21]) == (24, 31, "Firmware V2.1")


def test_the_documents_gsd_parses() -> None:
    gsd = parse_gsd(_document_gsd())
    assert gsd.ident_number == 0x1030
    assert len(gsd.modules) == 17
    assert gsd.module_by_ident(0xF3) is not None
    assert gsd.module_by_ident(0xF3).reference == 1  # type: ignore[union-attr]
    # the interface description writes Ext_user_prm_data_ref in lower case: keywords are
    # case-insensitive
    assert [ref for _, ref in gsd.prm_refs] == [1, 2, 3]
    assert gsd.default_user_prm() == bytes(4)
    assert len(gsd.diag_bits) == 10


@pytest.mark.parametrize(
    ("text", "what"),
    [
        ("#Profibus_DP\nModule = 0xF3\n", "line 2"),
        ('#Profibus_DP\nPrmText=1\nText(0)="a"\n', "inside a prmtext"),
        ('Vendor_Name = "x"\n', "no #Profibus_DP"),
        ('#Profibus_DP\nExtUserPrmData=1 "x"\nBit(0) 0 0-1\nbogus\nEndExtUserPrmData\n', "line 4"),
    ],
)
def test_broken_gsd_is_named(text: str, what: str) -> None:
    with pytest.raises(ConfigError, match=what):
        parse_gsd(text)
