"""The page's backups, comparisons and restores, those of ``uss backup``, ``uss diff`` and
``uss restore`` (`pyuss.commission`: one file format, one comparison), for both of the page's
backends (a drive on the line, or one behind a gateway over the broker).

A backup file comes as the bytes a page uploads; the drive's values are read for exactly
the parameters it holds. A file of another family or another drive (its identity parameters
differ) is a stranger: compared, but restored only when forced. A restore writes only what
differs and is writable, in the profile's order, after every value is checked; a person says
yes to the very writes a comparison listed (`Approve`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from pyuss.commission import backup as backups
from pyuss.commission.compare import Outcome, Skip, Write, another_drive, compare, plan
from pyuss.errors import ConfigError
from pyuss.params import ParamBook
from pyuss.points import Drive
from pyuss.profiles import Profile
from pyuss.web.shown import param_id

__all__ = ["Approve", "Progress", "compared", "planned", "restored", "stranger", "wanted_and_now"]

Progress = Callable[[int, int, str], object]
"""``progress(done, total, label)`` of a backup, compare or restore."""
Approve = Callable[[list[dict[str, Any]]], object]
"""Told the writes a restore is about to make (as a comparison lists them), before the
first: it raises to write nothing (the person said yes to another list)."""


async def wanted_and_now(
    drive: Drive,
    data: bytes,
    name: str,
    *,
    address: int,
    kind: str,
    source: str,
    progress: Progress | None,
) -> tuple[backups.Backup, backups.Backup]:
    """The uploaded backup file ``name`` (``data``) and the drive's values of the parameters
    it holds, read now (a backup of the drive at ``address``, of ``kind``, from ``source``)."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{name}: not a text file (a backup is TOML or JSON)") from None
    wanted = backups.loads(text, name)
    refs = [(e.pnu, e.index) for e in wanted.entries]
    entries = await backups.read_parameters(drive, refs, progress=progress)
    return wanted, backups.Backup(address, kind, entries, source=source)


async def stranger(wanted: backups.Backup, drive: Drive, *, kind: str, who: str) -> str | None:
    """Why ``wanted`` may be another drive's file than drive ``who`` (of ``kind``): another
    family, or identity parameters it holds otherwise (`pyuss.commission.another_drive`)."""
    if wanted.profile != kind:
        return f"{wanted.source} is a backup of a {wanted.profile} drive, drive {who} is {kind}"
    return await another_drive(wanted, drive)


def compared(
    name: str,
    wanted: backups.Backup,
    now: backups.Backup,
    book: ParamBook,
    profile: Profile | None,
    stranger: str | None,
) -> dict[str, Any]:
    """A comparison as the page shows it: the differences of the drive (``now``) and the
    file ``name`` (``wanted``) with names and units, what a restore would write and leave out,
    why the file may be another drive's (``stranger``) or cannot be restored (``refused``)."""
    differences = []
    for diff in compare(now, wanted):
        info = book.get(diff.pnu)
        differences.append(
            {
                "id": param_id(diff.pnu, diff.index),
                "label": diff.label,
                "name": diff.name,
                "drive": None if diff.left is None else diff.left.text(info),
                "file": None if diff.right is None else diff.right.text(info),
            }
        )
    reply: dict[str, Any] = {
        "file": name,
        "address": wanted.address,
        "profile": wanted.profile,
        "date": wanted.date,
        "differences": differences,
        "writes": [],
        "skipped": [],
        "stranger": stranger,
        "refused": None,
    }
    try:
        writes, skips = plan(wanted, now, book, profile)
    except ConfigError as exc:
        reply["refused"] = str(exc)
    else:
        reply["writes"] = planned(writes)
        reply["skipped"] = [_skip_dict(s) for s in skips]
    return reply


def restored(
    drive: str,
    name: str,
    writes: Sequence[Write],
    skips: Sequence[Skip],
    outcomes: Sequence[Outcome],
    *,
    eeprom: bool,
) -> dict[str, Any]:
    """A restore of file ``name`` to ``drive`` (``drive 5``) as the page shows it: how many
    were written and refused, each write's result, what was left out."""
    failed = [o for o in outcomes if not o.ok]
    stored = " and stored in EEPROM" if eeprom else ""
    message = f"{drive}: {len(outcomes) - len(failed)} of {len(outcomes)} written{stored}" + (
        f", {len(failed)} refused" if failed else ""
    )
    if not writes:
        message = f"{drive} already holds {name}: nothing to write"
    return {
        "message": message,
        "written": len(outcomes) - len(failed),
        "refused": len(failed),
        "results": [
            {
                **_write_dict(o.write),
                "ok": o.ok,
                "answer": o.answer,
                "error": o.error_text() or None,
            }
            for o in outcomes
        ],
        "skipped": [_skip_dict(s) for s in skips],
    }


def planned(writes: Sequence[Write]) -> list[dict[str, Any]]:
    """The writes of a restore as a comparison lists them and a person says yes to."""
    return [_write_dict(w) for w in writes]


def _skip_dict(skip: Skip) -> dict[str, Any]:
    return {"label": skip.entry.label, "name": skip.entry.name, "reason": skip.reason}


def _write_dict(write: Write) -> dict[str, Any]:
    return {
        "id": param_id(write.pnu, write.index),
        "label": write.label,
        "name": write.info.name if write.info is not None else "",
        "change": write.text(),
    }
