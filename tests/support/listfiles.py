"""The lists of a family's manual parameters (`pyuss/profiles/lists/FAMILY.toml`: the
parameters of access levels 1 and 2 of its parameter list, and why its file leaves some out),
read as they are shipped, and the checks the list tests share: a table of entries read from
the manual's pages against the family's parameter file, the list's coverage by the file, and
the figures docs/drives.md gives of it."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from pyuss.drive.database import ParameterDatabase
from pyuss.drive.datatypes import DataType
from pyuss.profiles import coverage
from pyuss.profiles.coverage import ManualList


def manual_list(family: str) -> ManualList:
    """The shipped list of ``family``, read as pyuss reads it (`pyuss.profiles.coverage`)."""
    listed = coverage.manual_list(family)
    assert listed.family == family
    return listed


@dataclass(frozen=True)
class Entry:
    """One parameter as a page of the manual gives it (the second reading, from the page)."""

    pnu: int
    type: DataType
    minimum: float | None
    maximum: float | None
    default: float | None
    array: int | None = None
    unit: str = ""
    changeable: str | None = None
    level: int | None = None
    read_only: bool = False
    page: int = 0


def check_entry(db: ParameterDatabase, entry: Entry) -> None:
    """The file's parameter ``entry.pnu`` says what the page says."""
    where = f"P{entry.pnu:04d} (page {entry.page})"
    assert entry.pnu in db, f"{where}: not in the file"
    p = db.parameter(entry.pnu)
    assert p.dtype is entry.type, f"{where}: type {p.dtype.name}, the page {entry.type.name}"
    assert p.array == entry.array, f"{where}: {p.array} elements, the page {entry.array}"
    if entry.read_only:
        assert p.access.name == "RO", f"{where}: writable, the page says r (read-only)"
        return
    assert (p.minimum, p.maximum) == (entry.minimum, entry.maximum), where
    assert all(value == entry.default for value in p.default), f"{where}: {p.default}"
    assert p.unit == entry.unit, f"{where}: unit {p.unit!r}, the page {entry.unit!r}"
    assert p.changeable == entry.changeable, f"{where}: {p.changeable}, the page {entry.changeable}"
    if entry.level is not None:
        assert p.level == entry.level, f"{where}: level {p.level}, the page {entry.level}"


def check_coverage(
    db: ParameterDatabase, listed: ManualList, family: str, floor: float, *, levels: bool = True
) -> None:
    """Every number of the list is in the file or left out with a reason (>= 95 %: all of
    them), the file holds at least ``floor`` of them, and the two agree with each other;
    ``levels``: the list is of access levels 1 and 2 (the MICROMASTER lists)."""
    assert listed.family == family
    assert not levels or "access levels 1 and 2" in listed.manual
    assert list(listed.numbers) == sorted(set(listed.numbers)), "numbers sorted, each once"
    assert set(listed.left_out) <= set(listed.numbers), "a left-out number not in the list"
    assert all(reason.strip() for reason in listed.left_out.values()), "a reason is empty"
    present = [n for n in listed.numbers if n in db]
    both = [n for n in present if n in listed.left_out]
    assert not both, f"in the file and left out: {both}"
    covered = len(present) + len(listed.left_out)
    assert covered / len(listed.numbers) >= 0.95
    assert covered == len(listed.numbers), "every number in the file or left out"
    assert len(present) / len(listed.numbers) >= floor - 1e-9, (
        f"{len(present)}/{len(listed.numbers)}"
    )
    wrong = [n for n in present if levels and db.parameter(n).level not in (1, 2)]
    assert not wrong, f"listed at level 1 or 2, the file says otherwise: {wrong}"


DOC = Path(__file__).resolve().parents[2] / "docs" / "drives.md"


def _numbers(text: str) -> set[int]:
    found: set[int] = set()
    for first, last in re.findall(r"(\d+)(?:\.\.[rP]?(\d+))?", text):
        found.update(range(int(first), int(last or first) + 1))
    return found


def check_docs(db: ParameterDatabase, listed: ManualList) -> None:
    """docs/drives.md's row of the list gives its figures and names every number left out."""
    rows = re.findall(
        rf"^\| `{listed.family}` \| .* \| (\d+) of (\d+) \((\d+) %\) \| (\d+): (.*) \|$",
        DOC.read_text(encoding="utf-8"),
        re.M,
    )
    assert len(rows) == 1, f"docs/drives.md: one row for {listed.family}"
    present, total, percent, out, named = rows[0]
    found = coverage.list_coverage(listed.family, db)
    assert (int(present), int(total), int(percent)) == (
        len(found.present),
        found.total,
        found.percent,
    ), found.line()
    assert int(out) == len(listed.left_out)
    assert set(listed.left_out) <= _numbers(named), sorted(set(listed.left_out) - _numbers(named))
