"""The commissioning checklist and each family's coverage of it, computed from the files.

`test_each_family_covers_at_least_what_it_reached` prints every family's coverage (run with
``-s`` to see it) and holds the share each family's parameter file has reached: the goal is
95 %; what the project could not confirm is left out of the files and listed in docs/drives.md,
so a family may stay below the goal but never falls back.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pyuss.drive.loader import parse_database
from pyuss.errors import ConfigError
from pyuss.profiles.coverage import checklist, coverage, parse_checklist

DOC = Path(__file__).resolve().parents[2] / "docs" / "drives.md"
GOAL = 0.95
REACHED = {
    "micromaster420": 77 / 85,
    "micromaster440": 56 / 91,
    "sinamics-g110": 54 / 73,
    "sinamics-g120": 56 / 91,
    "sinamics-v20": 52 / 93,
    "nord-sk500e": 36 / 61,
}
"""The share of its checklist each family's file holds today (the floor; raise it as the files
grow)."""

TOPICS = (
    "quick commissioning",
    "motor data",
    "command and setpoint source",
    "digital inputs",
    "digital and relay outputs",
    "analog inputs",
    "analog outputs",
    "fixed frequencies",
    "ramps and limits",
    "motor identification",
    "PID controller",
    "holding and DC brake",
    "skip frequencies",
    "motor potentiometer",
    "automatic restart",
    "fieldbus (USS)",
    "fault and alarm history",
)


def test_the_checklist_names_every_topic_for_every_family() -> None:
    lists = checklist()
    assert tuple(lists.topics.values()) == TOPICS
    assert set(lists.families) == set(REACHED)
    for family, topics in lists.families.items():
        assert tuple(topics) == tuple(lists.topics), family


def test_each_family_covers_at_least_what_it_reached() -> None:
    report: list[str] = []
    below: list[str] = []
    for family, floor in REACHED.items():
        found = coverage(family)
        report += found.lines()
        assert found.ratio >= floor - 1e-9, "\n".join(found.lines())
        if found.ratio < GOAL:
            below.append(f"{family} {found.ratio:.1%}")
    print("\n".join(report))
    print(f"below the goal of {GOAL:.0%}: {', '.join(below) or 'none'}")


def test_coverage_is_computed_from_the_parameter_file() -> None:
    # The same family with two parameters taken out of its file: they count as missing.
    whole = coverage("sinamics-v20")
    less = parse_database(
        '[profile]\nname = "v20-less"\nextends = "sinamics-v20"\nremove = [1131, 722]\n'
    )
    part = coverage("sinamics-v20", less)
    assert part.present == whole.present - 2
    assert {1131, 722} <= set(part.missing) and not {1131, 722} & set(whole.missing)
    ramps = next(t for t in part.topics if t.key == "ramps")
    assert 1131 in ramps.missing and 1131 not in ramps.present


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("[micromaster420]\n", "[topics] must name"),
        ('[topics]\na = "A"\n[no-such-drive]\na = []\n', "[no-such-drive] is not a built-in"),
        ('[topics]\na = "A"\n[micromaster420]\nb = []\n', "unknown topic 'b'"),
        ('[topics]\na = "A"\nb = "B"\n[micromaster420]\na = []\n', "topic 'b' missing"),
        ('[topics]\na = "A"\n[micromaster420]\na = ["P0010"]\n', "a: must be a list of"),
        ('[topics]\na = "A"\n[micromaster420]\na = [10, 10]\n', "named twice"),
        ("[topics]\na = 1\n[micromaster420]\na = []\n", "topics.a: the title must be"),
        ("[topics\n", "not valid TOML"),
    ],
)
def test_a_bad_checklist_is_refused_naming_the_place(text: str, problem: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_checklist(text, "list.toml")
    assert "list.toml" in str(caught.value) and problem in str(caught.value)


def test_a_family_without_a_checklist_is_named() -> None:
    with pytest.raises(ConfigError, match="no commissioning checklist for 'generic'"):
        coverage("generic")


def _numbers(text: str) -> set[int]:
    found: set[int] = set()
    for first, last in re.findall(r"(\d+)(?:\.\.(\d+))?", text):
        found.update(range(int(first), int(last or first) + 1))
    return found


def test_docs_list_every_parameter_a_family_lacks() -> None:
    rows = re.findall(
        r"^\| `([a-z0-9-]+)` \| (\d+) of (\d+) \(\d+%\) \| (.*) \|$",
        DOC.read_text(encoding="utf-8"),
        re.M,
    )
    assert {row[0] for row in rows} == set(REACHED)
    for family, present, wanted, left_out in rows:
        found = coverage(family)
        assert int(wanted) == found.wanted, family
        assert int(present) / int(wanted) == pytest.approx(REACHED[family]), family
        assert set(found.missing) <= _numbers(left_out), family
