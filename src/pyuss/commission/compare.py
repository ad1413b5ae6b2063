"""Comparing parameter sets and writing one back to a drive.

`compare` lists the settings that differ between two `Backup`s (a drive read now, or two
files), with names and units; two sets of different kinds (a drive of unknown kind, read as
words, and a file of a named profile, or files of two profiles) are compared by their raw words
where both sides have them, since their values are not read alike. Read-only parameters (status
and control words, actual values, fault numbers: what the drive measures or shows) are no
settings: two readings at different moments differ without anything to restore, so `compare`
leaves them out and `changed_values` lists them apart; a restore never writes them. `plan`
turns "what the drive holds now" and "what the file says" into the writes a restore makes: only
settings that differ, only writable ones (a parameter the book knows as read-only, one the file
could not read, and one nothing is known of without raw words are listed as skipped), an array
element by element, each value checked against the parameter's type and limits first so that a
hand-broken file is refused before anything is written. The order (for a drive of a named
profile; a drive of unknown kind is written by number, no family's order or commissioning rule
put on it): the profile's own list (``restore_order``) if it has one, then the access level
parameter, the parameter that enables writing, parameters changeable only in quick
commissioning (``changeable`` C; wrapped in the drive's commissioning rule: P0010 = 1 before
them, 0 after), then the rest by number. The commissioning parameters themselves (P0010,
P3900, P0970) are commands, not settings, and are not restored.
`restore` makes the writes, reports each refusal with its meaning and goes on.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pyuss.commission.backup import (
    MAX_TIMEOUTS,
    Backup,
    Entry,
    error_dict,
    kind_of,
    read_entries,
)
from pyuss.drive.datatypes import DataType
from pyuss.errors import ConfigError, UssError, UssTimeout
from pyuss.master.drive import Drive
from pyuss.master.errors import ValueDiffers
from pyuss.params.book import ParamBook
from pyuss.params.model import ParamInfo, Reading, param_label
from pyuss.params.values import ValueRefused, encode, format_value, words_text
from pyuss.params.words import changed_bits, word_kind
from pyuss.profiles import Profile

__all__ = [
    "Difference",
    "Outcome",
    "Sides",
    "Skip",
    "Write",
    "another_drive",
    "changed_values",
    "compare",
    "cut_short",
    "not_compared",
    "plan",
    "restore",
    "restore_line",
]


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, bool) or isinstance(b, bool):
            return False
        if isinstance(a, int | float) and isinstance(b, int | float):
            return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
        return False
    if isinstance(a, str) and isinstance(b, str):
        return a.rstrip() == b.rstrip()
    return bool(a == b)


def same_entry(a: Entry, b: Entry, *, words: bool = False) -> bool:
    """Whether two entries hold the same value (two failed reads count as the same);
    ``words``: the same raw words where both have them (sets of different kinds)."""
    if not a.ok or not b.ok:
        return not a.ok and not b.ok
    if words and a.raw and b.raw:
        return a.raw == b.raw
    return _same(a.value, b.value)


@dataclass(frozen=True, slots=True)
class Difference:
    """One parameter that differs: ``left`` / ``right`` None where only one side has it."""

    pnu: int
    index: int | None
    left: Entry | None
    right: Entry | None

    @property
    def label(self) -> str:
        entry = self.right or self.left
        return entry.label if entry is not None else param_label(self.pnu, self.index)

    @property
    def name(self) -> str:
        for entry in (self.right, self.left):
            if entry is not None and entry.name:
                return entry.name
        return ""

    @property
    def read_only(self) -> bool:
        """A value the drive measures or shows (either side read it as read-only), no setting."""
        return any(e is not None and e.access == "ro" for e in (self.left, self.right))

    @property
    def kind(self) -> str:
        if self.left is None:
            return "only right"
        if self.right is None:
            return "only left"
        return "changed"

    def text(self, book: ParamBook | None = None, family: Profile | None = None) -> str:
        """``P1120 (Ramp-up time): 10.00 s -> 2.50 s``; the family's control or status word
        (``family``: the drive's profile) in hex with the bits that changed
        (``r0052 (Status word 1): EA31h -> EA40h  +switch-on inhibited, -ready to switch on``,
        `pyuss.params.words`)."""
        name = f" ({self.name})" if self.name else ""
        words = self._words(family)
        if words is not None:
            return f"{self.label}{name}: {words}"
        info = book.get(self.pnu) if book is not None else None
        left = "(not there)" if self.left is None else self.left.text(info)
        right = "(not there)" if self.right is None else self.right.text(info)
        return f"{self.label}{name}: {left} -> {right}"

    def _words(self, family: Profile | None) -> str | None:
        kind = word_kind(family, self.pnu, self.index)
        if kind is None or self.left is None or self.right is None:
            return None
        before, after = self.left.value, self.right.value
        for value in (before, after):
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF:
                return None
        changed = changed_bits(before, after, kind, family)
        return f"{before:04X}h -> {after:04X}h  {changed}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "pnu": self.pnu,
            "index": self.index,
            "label": self.label,
            "name": self.name,
            "kind": self.kind,
            "left": None if self.left is None else self.left.to_dict(),
            "right": None if self.right is None else self.right.to_dict(),
        }


@dataclass(frozen=True, slots=True)
class Sides:
    """Which side of a comparison is which: ``drive 5 (live)`` or ``file (backup.toml)``.
    A difference reads left -> right; with the drive left and the file right that is also
    what a restore does to the drive (file -> drive)."""

    left: str
    right: str

    @staticmethod
    def drive(address: int) -> str:
        return f"drive {address} (live)"

    @staticmethod
    def file(path: str) -> str:
        return f"file ({path})"

    def header(self) -> str:
        """``left: drive 5 (live) -> right: file (backup.toml)``."""
        return f"left: {self.left} -> right: {self.right}"


def restore_line(address: int, path: str, writes: Sequence[Write], skips: Sequence[Skip]) -> str:
    """What ``uss restore ADDRESS FILE`` would do, in one line: the direction (file -> drive)
    and the parameters it would write (in its order), and how many differences it leaves
    out."""
    where = f"uss restore {address} {path} (file -> drive {address})"
    left_out = f"; {len(skips)} left out (uss restore says why)" if skips else ""
    if not writes:
        return f"{where} would write nothing{left_out}"
    shown = ", ".join(w.label for w in writes[:_SHOWN]) + (", ..." if len(writes) > _SHOWN else "")
    count = f"{len(writes)} write{'s' if len(writes) != 1 else ''}"
    return f"{where} would make {count}: {shown}{left_out}"


_SHOWN = 6
"""Parameters `restore_line` names before it cuts the list short."""


def compare(left: Backup, right: Backup) -> list[Difference]:
    """The settings that differ between two parameter sets, in parameter order (by raw words
    where they are of different kinds: module docstring; read-only values are left out:
    `changed_values`)."""
    return [d for d in _differences(left, right) if not d.read_only]


def changed_values(left: Backup, right: Backup) -> list[Difference]:
    """The read-only values (measured or shown by the drive) that differ between two parameter
    sets: shown apart from the settings, never restored."""
    return [d for d in _differences(left, right) if d.read_only]


def not_compared(left: Backup, right: Backup) -> list[Difference]:
    """The parameters neither set holds a value of (both could not read them): nothing says
    whether they agree, so they are no difference and no agreement."""
    rights = {(e.pnu, e.index): e for e in right.entries}
    return [
        Difference(a.pnu, a.index, a, b)
        for a in left.entries
        if not a.ok and (b := rights.get((a.pnu, a.index))) is not None and not b.ok
    ]


def _differences(left: Backup, right: Backup) -> list[Difference]:
    words = left.profile != right.profile
    lefts = {(e.pnu, e.index): e for e in left.entries}
    rights = {(e.pnu, e.index): e for e in right.entries}
    keys = sorted({*lefts, *rights}, key=lambda k: (k[0], -1 if k[1] is None else k[1]))
    found = []
    for key in keys:
        a, b = lefts.get(key), rights.get(key)
        if a is not None and b is not None and same_entry(a, b, words=words):
            continue
        found.append(Difference(key[0], key[1], a, b))
    return found


# -- restore ----------------------------------------------------------------------------------


async def another_drive(wanted: Backup, drive: Drive) -> str | None:
    """Why ``wanted`` may be another drive's file: the first of its identity parameters
    (firmware, device type) the drive holds otherwise, in words - or, where one side has no
    value of it (not read), that this cannot be told: a failed read is no value, neither a
    match nor another drive's. None when they agree. Reads them."""
    found = await read_entries(drive, wanted, wanted.identity)
    words = wanted.profile != kind_of(drive)
    source = wanted.source or "the backup"
    for old, new in zip(wanted.identity, found, strict=True):
        if same_entry(old, new, words=words):
            continue
        if old.ok and new.ok:
            return (
                f"{source} is from another drive: {old.label} ({old.name}) is {old.text()} "
                f"there, {new.text()} here"
            )
        where = "there" if not old.ok else "here"
        error = (old if not old.ok else new).error or {}
        return (
            f"cannot tell whether {source} is this drive's: {old.label} ({old.name}) was not "
            f"read {where} ({error.get('message', 'error')})"
        )
    return None


@dataclass(frozen=True, slots=True)
class Write:
    """One write of a restore: a typed ``value`` through what is known of the parameter, or
    the file's ``raw`` words for a parameter nothing is known of."""

    pnu: int
    index: int | None
    info: ParamInfo | None
    value: Any
    raw: tuple[int, ...]
    before: str
    """The value the drive holds now, as printed."""

    @property
    def label(self) -> str:
        return param_label(self.pnu, self.index, self.info)

    def text(self) -> str:
        name = f" ({self.info.name})" if self.info is not None else ""
        if self.info is None:
            after = " ".join(f"{w:04X}h" for w in self.raw)
        else:
            after = format_value(self.info, self.value)
        return f"{self.label}{name}: {self.before} -> {after}"


@dataclass(frozen=True, slots=True)
class Skip:
    """A difference a restore does not write, and why."""

    entry: Entry
    reason: str

    def text(self) -> str:
        return f"{self.entry.label} ({self.entry.name}): not written, {self.reason}"


def _typed(info: ParamInfo, value: Any) -> Any:
    if info.dtype is DataType.OCTET_STRING and isinstance(value, str):
        try:
            return bytes.fromhex(value)
        except ValueError:
            return value
    return value


def commissioning_only(info: ParamInfo | None) -> bool:
    """Changeable only in quick commissioning (the file's ``changeable`` letters: C alone)."""
    letters = (info.changeable or "") if info is not None else ""
    return "C" in letters and "T" not in letters and "U" not in letters


def _order(profile: Profile | None, book: ParamBook) -> Callable[[Write], tuple[int, int, int]]:
    first = [int(getattr(p, "pnu", p)) for p in getattr(profile, "restore_order", ()) or ()]
    db = None if profile is None else profile.database().profile
    early = [] if db is None else [r.pnu for r in (db.access_level, db.write_enable) if r]

    def key(write: Write) -> tuple[int, int, int]:
        if write.pnu in first:
            rank = first.index(write.pnu)
        elif write.pnu in early:
            rank = len(first) + early.index(write.pnu)
        elif commissioning_only(write.info):
            rank = len(first) + len(early)
        else:
            rank = len(first) + len(early) + 1
        return (rank, write.pnu, -1 if write.index is None else write.index)

    return key


COMMISSIONING = "(commissioning)"
"""The ``before`` of the writes that enter and leave quick commissioning around a restore."""


def _with_commissioning(
    writes: list[Write], profile: Profile | None, book: ParamBook
) -> list[Write]:
    """Wrap the writes of parameters changeable only in commissioning in the drive's own rule:
    its commissioning parameter (P0010) to quick commissioning first, back to 0 after them."""
    rule = _commissioning(profile)
    if rule is None or not any(commissioning_only(w.info) for w in writes):
        return writes
    info = book.get(rule.parameter)
    if info is None:
        return writes
    start = next(i for i, w in enumerate(writes) if commissioning_only(w.info))
    end = max(i for i, w in enumerate(writes) if commissioning_only(w.info)) + 1
    enter = Write(rule.parameter, None, info, rule.quick, (), COMMISSIONING)
    leave = Write(rule.parameter, None, info, 0, (), COMMISSIONING)
    return [*writes[:start], enter, *writes[start:end], leave, *writes[end:]]


def _commissioning(profile: Profile | None) -> Any:
    return None if profile is None else getattr(profile.database(), "commissioning", None)


def plan(
    wanted: Backup, current: Backup, book: ParamBook, profile: Profile | None
) -> tuple[list[Write], list[Skip]]:
    """The writes that make the drive (``current``) hold ``wanted``, in the order they are
    made, and the differences left out (``profile`` None: a drive of unknown kind, no
    family's order or commands). Every value is checked first: a value the parameter cannot
    take is a `ConfigError` naming the file and the parameter (nothing written yet)."""
    writes: list[Write] = []
    skips: list[Skip] = []
    rule = _commissioning(profile)
    commands = set() if rule is None else {rule.parameter, rule.end, rule.reset} - {None}
    for diff in compare(current, wanted):
        entry = diff.right
        if entry is None:
            continue  # the drive has it, the file does not: left alone
        if not entry.ok:
            skips.append(Skip(entry, "the backup could not read it"))
            continue
        if entry.pnu in commands:
            skips.append(Skip(entry, "a commissioning command, not a setting"))
            continue
        info = book.get(entry.pnu)
        now = diff.left
        if (info is not None and info.read_only) or (info is None and entry.access == "ro"):
            skips.append(Skip(entry, "read-only"))
            continue
        if now is not None and not now.ok:
            skips.append(Skip(entry, "the drive does not give its value now"))
            continue
        try:
            writes.extend(_writes(entry, now, info, book))
        except ValueRefused as exc:
            raise ConfigError(f"{wanted.source or 'the backup'}: {exc}") from None
        if info is None and not entry.raw:
            skips.append(Skip(entry, "nothing is known of it and the file has no raw words"))
    writes.sort(key=_order(profile, book))
    return _with_commissioning(writes, profile, book), skips


def _writes(
    entry: Entry, now: Entry | None, info: ParamInfo | None, book: ParamBook
) -> list[Write]:
    if info is None:
        if not entry.raw:
            return []
        before = "(unknown)" if now is None else " ".join(f"{w:04X}h" for w in now.raw)
        return [Write(entry.pnu, entry.index, None, None, entry.raw, before)]
    values = entry.value
    if info.array is not None and entry.index is None:
        if not isinstance(values, list) or len(values) != info.array:
            raise ValueRefused(
                f"{entry.label}: an array of {info.array} element(s), the file has "
                f"{len(values) if isinstance(values, list) else 'one value'}"
            )
        olds = now.value if now is not None and isinstance(now.value, list) else []
        out = []
        for i, value in enumerate(values):
            index = book.index_base + i
            old = olds[i] if i < len(olds) else None
            if old is not None and _same(old, value):
                continue
            typed = _typed(info, value)
            encode(info, typed, index)
            before = "(unknown)" if old is None else format_value(info, old)
            out.append(Write(entry.pnu, index, info, typed, (), before))
        return out
    typed = _typed(info, values)
    encode(info, typed, entry.index)
    before = "(unknown)" if now is None else now.text(info)
    return [Write(entry.pnu, entry.index, info, typed, (), before)]


@dataclass(frozen=True, slots=True)
class Outcome:
    """What became of one write: ``error`` None when the drive took it."""

    write: Write
    error: dict[str, Any] | None = None
    answer: str = ""

    @property
    def ok(self) -> bool:
        return self.error is None

    @property
    def differs(self) -> bool:
        """The drive took the write but answered with another value (`ValueDiffers`)."""
        return self.error is not None and self.error.get("type") == ValueDiffers.__name__

    def error_text(self) -> str:
        """``error 12: keyword missing; <what to do>`` for a refusal, else the error's
        message."""
        if self.error is None:
            return ""
        if self.differs:
            return str(self.error["message"])
        if "number" in self.error:
            hint = self.error.get("hint")
            todo = f"; {hint}" if hint else ""
            return f"error {self.error['number']}: {self.error['meaning']}{todo}"
        return str(self.error.get("message", "failed"))

    def text(self) -> str:
        if self.error is None:
            return f"{self.write.label} = {self.answer}"
        if self.differs:
            return self.error_text()
        return f"{self.write.label}: {self.error_text()}"

    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {
            "pnu": self.write.pnu,
            "index": self.write.index,
            "label": self.write.label,
            "name": self.write.info.name if self.write.info else "",
            "ok": self.ok,
        }
        if self.error is None:
            data["answer"] = self.answer
        else:
            data["error"] = self.error
        return data


async def restore(
    drive: Drive,
    writes: Sequence[Write],
    *,
    eeprom: bool = False,
    progress: Callable[[int, int, str], object] | None = None,
    outcomes: list[Outcome] | None = None,
) -> list[Outcome]:
    """Make ``writes`` in order; a refusal is recorded with its number and meaning and the
    others are still written. Stops with `UssTimeout` when the drive answered `MAX_TIMEOUTS`
    jobs in a row with nothing. ``outcomes``: the list the outcomes are added to as they
    come, so that a restore cut short (interrupted, the drive gone) still tells what it wrote:
    ``writes[len(outcomes)]`` was under way (`cut_short`)."""
    outcomes = [] if outcomes is None else outcomes
    silent = 0
    for done, write in enumerate(writes):
        if progress is not None:
            progress(done, len(writes), write.label)
        try:
            if write.info is None:
                words = await drive.write_raw(write.pnu, write.raw, write.index, eeprom=eeprom)
                reading = Reading(write.pnu, write.index, None, words, 0, write.raw)
                answer = words_text(words)
                written = words_text(write.raw)
            else:
                reading = await drive.write_param(
                    write.pnu, write.value, write.index, eeprom=eeprom
                )
                answer = format_value(reading.info, reading.value)
                written = reading.written_text()
        except ConfigError as exc:
            outcomes.append(Outcome(write, {"type": type(exc).__name__, "message": str(exc)}))
            continue
        except UssError as exc:
            silent = silent + 1 if isinstance(exc, UssTimeout) else 0
            if silent >= MAX_TIMEOUTS:
                raise
            outcomes.append(Outcome(write, error_dict(exc)))
            continue
        silent = 0
        if reading.differs:  # the drive holds another value than the file's
            name = f" ({write.info.name})" if write.info is not None and write.info.name else ""
            differs = ValueDiffers(f"{write.label}{name}", written, answer)
            outcomes.append(Outcome(write, error_dict(differs), answer))
            continue
        outcomes.append(Outcome(write, None, answer))
    if progress is not None:
        progress(len(writes), len(writes), "")
    return outcomes


def cut_short(writes: Sequence[Write], outcomes: Sequence[Outcome]) -> list[str]:
    """What a restore stopped after ``outcomes`` of ``writes`` has done, in lines: how many
    were written, the write under way (sent or not, the drive may have taken it), those not
    written, a commissioning parameter left in quick commissioning (its entry was written,
    its end was not), and how to go on."""
    taken = [o.write.label for o in outcomes if o.ok]
    refused = [o.write.label for o in outcomes if not o.ok and not o.differs]
    otherwise = [o.write.label for o in outcomes if o.differs]
    lines = [
        f"{len(taken)} of {len(writes)} written"
        + (f" ({', '.join(taken)})" if taken else "")
        + (f", {len(refused)} refused ({', '.join(refused)})" if refused else "")
        + (
            f", {len(otherwise)} answered with another value ({', '.join(otherwise)})"
            if otherwise
            else ""
        )
    ]
    rest = list(writes[len(outcomes) :])
    if rest:
        lines.append(f"{rest[0].label}: under way, the drive may or may not have taken it")
    if len(rest) > 1:
        lines.append(f"not written: {', '.join(w.label for w in rest[1:])}")
    entered = [o.write for o in outcomes if o.ok and o.write.before == COMMISSIONING]
    if (
        entered
        and entered[-1].value != 0
        and rest
        and any(w.before == COMMISSIONING and w.value == 0 for w in rest)
    ):
        info = entered[-1].info
        name = f" ({info.name})" if info is not None else ""
        lines.append(
            f"{entered[-1].label}{name} may be left at {entered[-1].value}, in quick "
            f"commissioning: write {entered[-1].label} 0 to end it"
        )
    lines.append("the same uss restore again writes the rest (only what still differs)")
    return lines
