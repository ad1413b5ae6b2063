"""Whether a drive follows USS: its command source and setpoint source, read and judged.

A SINAMICS V20, G110, G120 or MICROMASTER 420/440 takes its control word from USS only while
P0700 (command source) is 5, and its main setpoint only while P1000 (setpoint source) is 5;
out of the box they hold other values (operator panel, terminals, MOP, analog input) and the
drive ignores what USS sends. The family's data file names the parameters and the USS value
(``[sources]``, `pyuss.drive.database.Sources`); the names of the other values are the
parameters' value texts.

`check` reads them through the master and says, for each, whether the drive follows USS
(`SourceCheck.follows`) and, where not, what to set (`SourceCheck.message`: "the drive ignores
the control word: P0700 = 1 (operator panel), set P0700 = 5 for USS"). `uss run` refuses
before it sends a command when a source is not USS (`NotFromUss`), and `uss status` and the
web page show the same line. A drive of unknown kind or of a family without ``[sources]``
has nothing to check (`Sources.known` false).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pyuss.errors import DriveRefusal, UssError
from pyuss.params.book import ParamReader

__all__ = [
    "NotFromUss",
    "SourceCheck",
    "Sources",
    "check",
    "refuse_unless_uss",
]

WHAT = {"command": "the control word", "setpoint": "the setpoint"}
"""What a source parameter gates, as the messages name it."""


class NotFromUss(UssError):
    """The drive takes its commands or its setpoint from elsewhere than USS: a run would do
    nothing (the drive ignores what USS sends). The message names each parameter, its value
    and the value to set."""


@dataclass(frozen=True, slots=True)
class SourceCheck:
    """One source parameter as the drive holds it."""

    kind: str
    """``command`` (the control word) or ``setpoint`` (the main setpoint)."""
    label: str
    """The parameter as the family writes it and ``uss write`` takes it (``P0700``,
    ``P0700.0``)."""
    uss: int
    """The value that means USS."""
    value: int | None
    """What the drive holds (None: it could not be read, `problem` says why)."""
    text: str = ""
    """The value's text (``operator panel``), where the parameter has one."""
    problem: str = ""

    @property
    def follows(self) -> bool | None:
        """Whether the drive takes this from USS (None: not known, it could not be read)."""
        return None if self.value is None else self.value == self.uss

    @property
    def shown(self) -> str:
        """``P0700 = 1 (operator panel)``."""
        if self.value is None:
            return f"{self.label} = ?"
        text = f" ({self.text})" if self.text else ""
        return f"{self.label} = {self.value}{text}"

    @property
    def message(self) -> str:
        """What this means for USS, in one sentence."""
        what = WHAT[self.kind]
        if self.value is None:
            return f"whether the drive follows {what} of USS is not known: {self.problem}"
        if self.follows:
            return f"the drive follows {what} of USS: {self.shown}"
        return f"the drive ignores {what}: {self.shown}, set {self.label} = {self.uss} for USS"

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "parameter": self.label,
            "value": self.value,
            "text": self.text,
            "uss": self.uss,
            "follows": self.follows,
            "message": self.message,
        }


@dataclass(frozen=True, slots=True)
class Sources:
    """A drive's command and setpoint sources (none where nothing is known of them)."""

    checks: tuple[SourceCheck, ...] = field(default_factory=tuple)

    @property
    def known(self) -> bool:
        """Whether the drive's family has source parameters (``[sources]``)."""
        return bool(self.checks)

    @property
    def ignored(self) -> tuple[SourceCheck, ...]:
        """The sources that are not USS: what the drive ignores."""
        return tuple(c for c in self.checks if c.follows is False)

    @property
    def follows(self) -> bool:
        """Whether nothing a run sends is ignored: no source is known not to be USS."""
        return not self.ignored

    def line(self) -> str:
        """One line for a person: what the drive ignores and what to set, or that it follows
        USS (empty where nothing is known)."""
        if not self.checks:
            return ""
        if self.ignored:
            return "; ".join(c.message for c in self.ignored)
        unknown = [c.message for c in self.checks if c.follows is None]
        if unknown:
            return "; ".join(unknown)
        shown = ", ".join(c.shown for c in self.checks)
        return f"the drive follows USS: {shown}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "known": self.known,
            "follows": self.follows,
            "line": self.line(),
            "sources": [c.to_dict() for c in self.checks],
        }


async def check(drive: ParamReader, *, timeout: float | None = None) -> Sources:
    """Read the drive's source parameters (``[sources]`` of its profile) and judge them; a
    drive of unknown kind, or of a family without them, gives `Sources` with no checks. A
    read the drive refuses leaves that source unknown, with the refusal as its problem."""
    if not drive.profile_named:
        return Sources()
    found = []
    for kind, source in drive.profile.database().sources:
        ref = source.ref
        label = drive.params.label(ref.pnu, ref.index)
        try:
            reading = await drive.read_param(ref.pnu, ref.index, timeout=timeout)
        except DriveRefusal as exc:
            problem = f"{label} could not be read: error {exc.number}: {exc.meaning}"
            found.append(SourceCheck(kind, label, source.uss, None, problem=problem))
            continue
        value = reading.value
        if isinstance(value, bool) or not isinstance(value, int):
            problem = f"{label} holds {value!r}, no source number"
            found.append(SourceCheck(kind, label, source.uss, None, problem=problem))
            continue
        texts = reading.info.texts if reading.info is not None else {}
        found.append(SourceCheck(kind, label, source.uss, value, texts.get(value, "")))
    return Sources(tuple(found))


async def refuse_unless_uss(drive: ParamReader, *, timeout: float | None = None) -> Sources:
    """`check`, and `NotFromUss` naming every source that is not USS: what a command that
    switches the drive calls before it sends anything."""
    sources = await check(drive, timeout=timeout)
    if not sources.follows:
        raise NotFromUss(sources.line())
    return sources
