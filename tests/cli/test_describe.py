"""``uss describe`` heads a description with what it is in the drive family's own terms: the
family, its manuals' word for what request ID 4 reads, and the layout its elements follow -
never the bare name of a layout."""

from __future__ import annotations

import json

import pytest

from pyuss.cli.main import main
from support.processes import simulator

BAUD = "38400"


def describe(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    code = main(["describe", *argv, "--baud", BAUD])
    out, err = capsys.readouterr()
    assert code == 0, err
    return code, out


def test_a_v20_description_in_its_manuals_terms(capsys: pytest.CaptureFixture[str]) -> None:
    with simulator("--profile", "sinamics-v20", "--address", "1", "--baud", BAUD) as url:
        _, out = describe(capsys, "1", "P1120", "--port", url, "--profile", "sinamics-v20")
        _, unknown = describe(capsys, "1", "1120", "--port", url)
        _, data = describe(
            capsys, "1", "P1120", "--port", url, "--profile", "sinamics-v20", "--json"
        )
    head, layout, *_ = out.splitlines()
    assert head == "P1120: descriptive elements (request ID 4), SINAMICS V20"
    assert layout.split() == [
        *("layout", "elements", "1..10", "of", "USS", "specification", "C", "6"),
        *("(the", "PROFIBUS", "drive", "profile's", "layout)"),
    ]
    assert "profibus description" not in out and "Ramp-up time" in out
    # A drive of unknown kind: the specification's word, no family named.
    assert unknown.splitlines()[0] == "P1120: parameter description (request ID 4)"
    assert json.loads(data)["style"] == "profibus"  # the JSON keeps the layout's key


def test_a_firmware_4_g120_description(capsys: pytest.CaptureFixture[str]) -> None:
    with simulator("--profile", "sinamics-g120c", "--address", "3", "--baud", BAUD) as url:
        _, out = describe(capsys, "3", "p2021", "--port", url, "--profile", "sinamics-g120c")
    assert out.splitlines()[0] == (
        "P2021: descriptive elements (request ID 4), SINAMICS G120C (firmware 4)"
    )
