"""``python -m pyuss.drive``: check and show parameter files."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from pyuss.drive.__main__ import main


def test_check_accepts_a_good_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "ok.toml"
    path.write_text('[profile]\nname = "mine"\nextends = "generic"\n')
    assert main(["check", str(path)]) == 0
    assert "profile 'mine'" in capsys.readouterr().out


def test_check_refuses_a_bad_file_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(
        '[profile]\nname = "x"\n[[parameter]]\npnu = 3\nname = "A"\ntype = "int16"\nmax = 99999\n'
    )
    result = subprocess.run(
        [sys.executable, "-m", "pyuss.drive", "check", str(path)],
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
    )
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1
    assert "parameter 3" in result.stderr and "'max'" in result.stderr
    assert "Traceback" not in result.stderr


def test_show_lists_a_profile_and_details_a_parameter(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["show", "generic"]) == 0
    listing = capsys.readouterr().out
    assert "SST/SCB Busadr." in listing and "uint16[3]" in listing
    assert main(["show", "generic", "7"]) == 0
    detail = capsys.readouterr().out
    assert "'300 BAUD        '" in detail and "element  7 lower limit" in detail
    assert main(["show", "generic", "999"]) == 2


def test_show_names_the_parameters_as_the_family_writes_them(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["show", "sinamics-v20"]) == 0
    rows = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()[1:]}
    assert "r0021" in rows and "P1120" in rows and "P0003" in rows
    assert main(["show", "sinamics-v20", "21"]) == 0
    assert capsys.readouterr().out.startswith("r0021 'Actual frequency': float, ro")
    assert main(["show", "nord", "102"]) == 0
    assert capsys.readouterr().out.startswith("P102 ")


def test_show_names_an_unknown_source(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["show", "genric"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "genric: neither a built-in profile (6se21, baumueller, generic" in err
