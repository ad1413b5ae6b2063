"""``uss params macro``: the parameters a family's file marks as macros (``macro = true``,
docs/drive.md), whatever their names say; a family whose file has none is told so in one line
that names the profiles whose files have them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pyuss.cli.main import main
from pyuss.params.book import macro_profiles
from support.processes import simulator

MACROS = """\
[profile]
name = "v20-macros"

[[parameter]]
pnu = 717
name = "Connection macro"
type = "uint16"
macro = true

[[parameter]]
pnu = 718
name = "Applic. setting"
type = "uint16"
macro = true
"""
"""Two macro parameters added to a V20's database; the second has no "macro" in its name."""


def uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_the_word_macro_finds_the_parameters_marked_as_macros(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    extra = tmp_path / "macros.toml"
    extra.write_text(MACROS, encoding="utf-8")
    given = ("--profile", "sinamics-v20", "--params", str(extra))
    code, out, err = uss(capsys, "params", "macro", *given)
    assert code == 0, err
    assert [line.split()[0] for line in out.splitlines()] == ["P0717", "P0718"]
    code, out, _ = uss(capsys, "params", "MACROS", *given, "--json")
    records = json.loads(out)["parameters"]
    assert code == 0 and [(r["pnu"], r["macro"]) for r in records] == [(717, True), (718, True)]
    code, out, _ = uss(capsys, "params", "macro", "applic", *given)  # with other words: all match
    assert (code, [line.split()[0] for line in out.splitlines()]) == (0, ["P0718"])
    code, out, _ = uss(capsys, "params", "macro", "ramp", *given)  # the file has macros
    assert (code, out) == (0, "no parameter matches\n")


def test_a_family_without_macro_parameters_says_so(capsys: pytest.CaptureFixture[str]) -> None:
    having = macro_profiles()
    for profile in ("generic", "sinamics-g120c"):
        assert profile not in having
        code, out, err = uss(capsys, "params", "macro", "--profile", profile)
        assert (code, err) == (0, "")
        (line,) = out.splitlines()
        assert line.startswith(f"the {profile} parameter file has no macro parameters (")
        if having:
            assert line.endswith(
                f"profiles whose files have macro parameters: {', '.join(having)})"
            )
        else:
            assert line.endswith("(no built-in profile's file has macro parameters yet)")
    code, out, _ = uss(capsys, "params", "nosuchword", "--profile", "generic")
    assert (code, out) == (0, "no parameter matches\n")  # other searches as before


def test_a_drive_of_unknown_kind_has_no_family_file(capsys: pytest.CaptureFixture[str]) -> None:
    with simulator("--profile", "sinamics-v20", "--address", "1", "--baud", "38400") as url:
        code, out, err = uss(capsys, "params", "1", "macro", "--port", url, "--baud", "38400")
    assert code == 0, err
    assert out.startswith("a drive of unknown kind has no family's parameter file, so no macro")
    assert "give --profile NAME" in out


def test_a_macro_flag_is_true_or_false(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(MACROS.replace("macro = true", 'macro = "yes"', 1), encoding="utf-8")
    code, out, err = uss(capsys, "params", "macro", "--params", str(bad))
    assert (code, out) == (2, "") and "'macro'" in err and "true or false" in err, err
