"""The manual lists' coverage as ``python -m pyuss.profiles.coverage`` prints it (run as a
process, as a user runs it) is the figure docs/drives.md gives, family by family."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from pyuss.errors import ConfigError
from pyuss.profiles.coverage import list_coverage, list_families, parse_manual_list

DOC = Path(__file__).resolve().parents[2] / "docs" / "drives.md"


def test_the_script_prints_each_list_and_the_docs_give_the_same_figures() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pyuss.profiles.coverage"],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    lines = done.stdout.splitlines()
    assert len(lines) == len(list_families()) >= 3
    doc = DOC.read_text(encoding="utf-8")
    for family, line in zip(list_families(), lines, strict=True):
        assert line == list_coverage(family).line()
        found = re.fullmatch(
            rf"{re.escape(family)}: (\d+) of (\d+) parameters of .* \((\d+) %\)", line
        )
        assert found, line
        present, total, percent = found.groups()
        row = re.search(
            rf"^\| `{re.escape(family)}` \| .* \| (\d+) of (\d+) \((\d+) %\) \|", doc, re.M
        )
        assert row, f"docs/drives.md: no row for {family}"
        assert row.groups() == (present, total, percent), (family, line)


def test_the_docs_console_example_is_what_the_script_prints() -> None:
    blocks = re.findall(r"```console\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)
    (block,) = [b for b in blocks if "pyuss.profiles.coverage" in b]
    command, first, rest = block.splitlines()
    assert command == "$ python -m pyuss.profiles.coverage" and rest == "..."
    done = subprocess.run(
        [sys.executable, *command.split()[2:]], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0 and done.stdout.splitlines()[0] == first


def test_the_checklist_option_adds_the_commissioning_coverage() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pyuss.profiles.coverage", "--checklist"],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    assert "sinamics-v20: 52/93 = 55.9%" in done.stdout


def test_percent_is_rounded_half_up() -> None:
    assert list_coverage("micromaster440").percent == 63  # 76 of 121 = 62.8 %
    assert list_coverage("micromaster420").percent == 88  # 90 of 102 = 88.2 %


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ('[list]\nfamily = "x"\nmanual = "m"\nnumbers = [1]\n[left_out]\n', "not a built-in"),
        ('[list]\nfamily = "generic"\nmanual = "m"\nnumbers = [2, 1]\n[left_out]\n', "sorted"),
        (
            '[list]\nfamily = "generic"\nmanual = "m"\nnumbers = [1]\n[left_out]\n2 = "r"\n',
            "2: not",
        ),
        (
            '[list]\nfamily = "generic"\nmanual = "m"\nnumbers = [1]\n[left_out]\n1 = " "\n',
            "reason",
        ),
        ('[list]\nfamily = "generic"\nmanual = "m"\nnumbers = [1]\n', "[left_out]"),
        ('left_out = 1\n[list]\nfamily = "generic"\nmanual = "m"\nnumbers = [1]\n', "a table"),
    ],
)
def test_a_bad_list_is_refused_naming_the_place(text: str, says: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(says)):
        parse_manual_list(text, "bad.toml")
