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
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

from pyuss.drive.database import ParameterDatabase, builtin_profiles
from pyuss.errors import ConfigError
from pyuss.userfile import parse_toml

__all__ = [
    "CHECKLIST",
    "Checklist",
    "Coverage",
    "TopicCoverage",
    "checklist",
    "coverage",
    "parse_checklist",
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


@cache
def checklist() -> Checklist:
    """The built-in checklist (read once)."""
    from importlib import resources  # here: a command that reads no file starts sooner

    text = resources.files("pyuss.profiles").joinpath(CHECKLIST).read_text(encoding="utf-8")
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
