"""How much of a commissioning each drive family's parameter file covers.

The commissioning checklist (``pyuss/profiles/commissioning.toml``, one file) names, per family
and topic (quick commissioning, motor data, command and setpoint source, inputs and outputs,
fixed frequencies, ramps, motor identification, PID, brakes, skip frequencies, motor
potentiometer, automatic restart, fieldbus, fault and alarm history), the parameters a
commissioning of that drive touches. `coverage` compares a family's list with its parameter
file and says, per topic, which of them the file holds and which it lacks: the file is the only
source, nothing here knows a parameter by itself.

The checklist is data, read once; a checklist that names an unknown topic or family, a
parameter number that is not an integer, or a family without every topic is refused with a
`ConfigError` naming the place (`parse_checklist`).

Beside it, ``pyuss/profiles/lists/FAMILY.toml`` holds the parameter numbers of a family's
manual parameter list (``[list]``: ``family``, ``manual``, ``numbers``) and, for each number
the family's file does not hold, why (``[left_out]``). `list_coverage` says how many of them
the file holds; ``python -m pyuss.profiles.coverage`` prints, per family with a list,
"N of M parameters of MANUAL (P %)", and with ``--checklist`` the checklist's coverage too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

from pyuss.drive.database import ParameterDatabase
from pyuss.drive.loader import builtin_profiles
from pyuss.errors import ConfigError
from pyuss.userfile import parse_toml

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable

__all__ = [
    "CHECKLIST",
    "Checklist",
    "Coverage",
    "ListCoverage",
    "ManualList",
    "TopicCoverage",
    "checklist",
    "coverage",
    "list_coverage",
    "list_families",
    "main",
    "manual_list",
    "parse_checklist",
    "parse_manual_list",
]

CHECKLIST = "commissioning.toml"
"""The checklist's file name in the package ``pyuss.profiles``."""


@dataclass(frozen=True, slots=True)
class Checklist:
    """The parsed checklist: topic keys with their titles (in file order) and, per family,
    the parameter numbers of each topic."""

    topics: Mapping[str, str]
    families: Mapping[str, Mapping[str, tuple[int, ...]]]


@dataclass(frozen=True, slots=True)
class TopicCoverage:
    """One topic of one family: the parameters wanted and those the file holds."""

    key: str
    title: str
    wanted: tuple[int, ...]
    present: tuple[int, ...]

    @property
    def missing(self) -> tuple[int, ...]:
        """The wanted parameters the file lacks, in checklist order."""
        return tuple(pnu for pnu in self.wanted if pnu not in self.present)


@dataclass(frozen=True, slots=True)
class Coverage:
    """A family's coverage of its commissioning checklist."""

    family: str
    topics: tuple[TopicCoverage, ...]

    @property
    def wanted(self) -> int:
        """Parameters the checklist names for the family."""
        return sum(len(t.wanted) for t in self.topics)

    @property
    def present(self) -> int:
        """Of those, the parameters the family's file holds."""
        return sum(len(t.present) for t in self.topics)

    @property
    def ratio(self) -> float:
        """``present / wanted`` (1.0 for an empty checklist)."""
        return self.present / self.wanted if self.wanted else 1.0

    @property
    def missing(self) -> tuple[int, ...]:
        """Every wanted parameter the file lacks."""
        return tuple(pnu for t in self.topics for pnu in t.missing)

    def lines(self) -> list[str]:
        """A short report for people: the total, then each topic with what it lacks."""
        out = [f"{self.family}: {self.present}/{self.wanted} = {self.ratio:.1%}"]
        for t in self.topics:
            lacks = ", ".join(str(p) for p in t.missing)
            out.append(
                f"  {t.title:28} {len(t.present):>2}/{len(t.wanted):<2}"
                + (f"  lacks {lacks}" if lacks else "")
            )
        return out


def parse_checklist(text: str, source: str = "<checklist>") -> Checklist:
    """The checklist in ``text``; `ConfigError` naming ``source`` and the place otherwise."""
    data = parse_toml(text, source)
    topics = data.pop("topics", None)
    if not isinstance(topics, dict) or not topics:
        raise ConfigError(f"{source}: [topics] must name the topics and their titles")
    for key, title in topics.items():
        if not isinstance(title, str) or not title:
            raise ConfigError(f"{source}: topics.{key}: the title must be a text")
    known = builtin_profiles()
    families: dict[str, dict[str, tuple[int, ...]]] = {}
    for family, table in data.items():
        if family not in known:
            raise ConfigError(f"{source}: [{family}] is not a built-in profile")
        if not isinstance(table, dict):
            raise ConfigError(f"{source}: {family} must be a table of topics")
        families[family] = _family(table, topics, f"{source}: [{family}]")
    return Checklist(dict(topics), families)


def _family(
    table: dict[str, Any], topics: Mapping[str, str], where: str
) -> dict[str, tuple[int, ...]]:
    unknown = sorted(set(table) - set(topics))
    if unknown:
        raise ConfigError(f"{where}: unknown topic {unknown[0]!r} (known: {', '.join(topics)})")
    lacking = [key for key in topics if key not in table]
    if lacking:
        raise ConfigError(f"{where}: topic {lacking[0]!r} missing (an empty list: none)")
    out: dict[str, tuple[int, ...]] = {}
    for key in topics:
        numbers = table[key]
        if not isinstance(numbers, list) or not all(
            isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= 65535 for n in numbers
        ):
            raise ConfigError(f"{where} {key}: must be a list of parameter numbers")
        if len(set(numbers)) != len(numbers):
            raise ConfigError(f"{where} {key}: a parameter number is named twice")
        out[key] = tuple(numbers)
    return out


def _shipped(*parts: str) -> Traversable:
    """A file or folder shipped in the package ``pyuss.profiles``."""
    from importlib import resources  # here: a command that reads no file starts sooner

    return resources.files("pyuss.profiles").joinpath(*parts)


@cache
def checklist() -> Checklist:
    """The built-in checklist (read once)."""
    text = _shipped(CHECKLIST).read_text(encoding="utf-8")
    return parse_checklist(text, f"pyuss/profiles/{CHECKLIST}")


def coverage(
    family: str, database: ParameterDatabase | None = None, *, against: Checklist | None = None
) -> Coverage:
    """How much of ``family``'s checklist its parameter file holds (``database``: another
    file to measure instead of the built-in one; ``against``: another checklist)."""
    lists = (against or checklist()).families.get(family)
    if lists is None:
        raise ConfigError(f"no commissioning checklist for {family!r}")
    if database is None:
        from pyuss.profiles import get_profile

        database = get_profile(family).database()
    titles = (against or checklist()).topics
    return Coverage(
        family,
        tuple(
            TopicCoverage(key, titles[key], wanted, tuple(p for p in wanted if p in database))
            for key, wanted in lists.items()
        ),
    )


# --------------------------------------------------------------------------------------------
# the manuals' parameter lists


LISTS = "lists"
"""The folder of the manual lists in the package ``pyuss.profiles``."""


@dataclass(frozen=True, slots=True)
class ManualList:
    """The parameter numbers of a family's manual list, and why its file leaves some out."""

    family: str
    manual: str
    numbers: tuple[int, ...]
    left_out: Mapping[int, str]


@dataclass(frozen=True, slots=True)
class ListCoverage:
    """How many of a manual list's parameters the family's file holds."""

    listed: ManualList
    present: tuple[int, ...]

    @property
    def total(self) -> int:
        """The parameters of the list."""
        return len(self.listed.numbers)

    @property
    def percent(self) -> int:
        """``present / total`` in whole per cent, rounded half up."""
        return (200 * len(self.present) + self.total) // (2 * self.total) if self.total else 100

    @property
    def missing(self) -> tuple[int, ...]:
        """The listed numbers the file does not hold."""
        return tuple(n for n in self.listed.numbers if n not in self.present)

    def line(self) -> str:
        """``FAMILY: N of M parameters of MANUAL (P %)``."""
        return (
            f"{self.listed.family}: {len(self.present)} of {self.total} parameters of "
            f"{self.listed.manual} ({self.percent} %)"
        )


def parse_manual_list(text: str, source: str = "<list>") -> ManualList:
    """The manual list in ``text``; `ConfigError` naming ``source`` and the place otherwise."""
    data = parse_toml(text, source)
    if set(data) != {"list", "left_out"}:
        raise ConfigError(f"{source}: the tables must be [list] and [left_out]")
    head, out = data["list"], data["left_out"]
    if not isinstance(head, dict) or set(head) != {"family", "manual", "numbers"}:
        raise ConfigError(f"{source}: [list] must give family, manual and numbers")
    family, manual, numbers = head["family"], head["manual"], head["numbers"]
    if family not in builtin_profiles():
        raise ConfigError(f"{source}: [list] family {family!r} is not a built-in profile")
    if not isinstance(manual, str) or not manual:
        raise ConfigError(f"{source}: [list] manual must be a text")
    if not isinstance(numbers, list) or not all(
        isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= 65535 for n in numbers
    ):
        raise ConfigError(f"{source}: [list] numbers must be a list of parameter numbers")
    if numbers != sorted(set(numbers)):
        raise ConfigError(f"{source}: [list] numbers must be sorted, each once")
    if not isinstance(out, dict):
        raise ConfigError(f"{source}: [left_out] must be a table of number = reason")
    left_out: dict[int, str] = {}
    for key, reason in out.items():
        number = int(key) if key.isdigit() else -1
        if number not in numbers:
            raise ConfigError(f"{source}: [left_out] {key}: not a number of the list")
        if not isinstance(reason, str) or not reason.strip():
            raise ConfigError(f"{source}: [left_out] {key}: the reason must be a text")
        left_out[number] = reason
    return ManualList(family, manual, tuple(numbers), left_out)


def list_families() -> tuple[str, ...]:
    """The families with a manual list."""
    folder = _shipped(LISTS)
    return tuple(
        sorted(p.name.removesuffix(".toml") for p in folder.iterdir() if p.name.endswith(".toml"))
    )


@cache
def manual_list(family: str) -> ManualList:
    """The shipped manual list of ``family`` (read once)."""
    if family not in list_families():
        raise ConfigError(f"no manual list for {family!r} (lists: {', '.join(list_families())})")
    where = f"pyuss/profiles/{LISTS}/{family}.toml"
    text = _shipped(LISTS, f"{family}.toml").read_text(encoding="utf-8")
    listed = parse_manual_list(text, where)
    if listed.family != family:
        raise ConfigError(f"{where}: [list] family is {listed.family!r}, not {family!r}")
    return listed


def list_coverage(family: str, database: ParameterDatabase | None = None) -> ListCoverage:
    """How many of ``family``'s manual list its parameter file holds (``database``: another
    file to measure instead of the built-in one)."""
    listed = manual_list(family)
    if database is None:
        from pyuss.profiles import get_profile

        database = get_profile(family).database()
    return ListCoverage(listed, tuple(n for n in listed.numbers if n in database))


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m pyuss.profiles.coverage [--checklist]``: each manual list's coverage."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m pyuss.profiles.coverage",
        description="How many parameters of each family's manual list its parameter file holds.",
    )
    parser.add_argument(
        "--checklist", action="store_true", help="also each family's commissioning checklist"
    )
    args = parser.parse_args(argv)
    for family in list_families():
        print(list_coverage(family).line())
    if args.checklist:
        for family in checklist().families:
            print("\n".join(coverage(family).lines()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
