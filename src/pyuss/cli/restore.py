"""Write a backup back to a drive: uss restore ADDRESS FILE

The file is checked first (a cut-short or hand-broken file, or a value a parameter cannot take,
is refused before anything is written, exit 2), and so is whose it is: a file of another
profile, or whose identity parameters (firmware, type) differ from the drive's, is refused
unless ``--force``. Without ``--profile`` the drive is of unknown kind: a backup of a drive of
unknown kind (``profile = "unknown"``) is written back as the words it read; a file of a named
profile (``"generic"`` in files of earlier versions) wants that ``--profile``, or ``--force``,
which writes its words as read. Then the drive's parameters are read and the differences shown;
after a ``y`` (or ``--yes``) only the writable parameters that differ are written, in an order
the profile gives (the access level and commissioning parameters first), with ``--eeprom``
through the EEPROM requests (C Table 4.1). A refusal is reported with its error number and
meaning and the restore goes on. ``--dry-run`` shows what would be written and writes nothing.
A restore cut short (Ctrl+C, exit code 130; the drive gone, exit code 1) says what it wrote,
the write under way, what it did not write, and a drive it may have left in quick
commissioning; run again, it writes the rest. Exit code 0 when every write was taken, 1 when
any was refused.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from typing import Any

from pyuss.cli import _params
from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_USAGE,
    command,
    emit,
    error_dict,
    finish,
    open_master,
    run,
)
from pyuss.commission import backup as backups
from pyuss.commission.compare import Outcome, another_drive, cut_short, plan, restore
from pyuss.errors import ConfigError, UssError


def register(subparsers: Any) -> None:
    parser = command(subparsers, "restore", "write a backup file back to a drive", __doc__)
    parser.add_argument("file", metavar="FILE", help="backup file (TOML or JSON)")
    parser.add_argument(
        "--dry-run", action="store_true", help="show what would be written, write nothing"
    )
    parser.add_argument(
        "--eeprom", action="store_true", help="store the values in the drive's EEPROM too"
    )
    parser.add_argument("--yes", action="store_true", help="write without asking")
    parser.add_argument(
        "--force",
        action="store_true",
        help="restore a file of another profile or of a drive with other identity parameters",
    )
    _params.add_options(parser)
    finish(parser, main)


def ask(question: str) -> bool:
    if not sys.stdin.isatty():
        raise ConfigError("no terminal to ask on: give --yes to write (or --dry-run)")
    print(question, end=" ", flush=True)
    return sys.stdin.readline().strip().lower() in ("y", "yes")


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        wanted = backups.load(args.file)
        kind = args.profile or backups.UNKNOWN_KIND
        if kind != "auto":  # else once the drive has shown its family
            check_kind(args, wanted, kind)
        if not args.dry_run and not args.yes and args.json:
            raise ConfigError("--json needs --yes (or --dry-run): there is no one to ask")
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            check_kind(args, wanted, backups.kind_of(drive))
            _params.setup(args, drive)
            stranger = await another_drive(wanted, drive)
            if stranger is not None and not args.force:
                raise ConfigError(f"{stranger} (--force to restore anyway)")
            progress = _params.Progress("reading", enabled=None if not args.json else False)
            try:
                now = await backups.read_entries(drive, wanted, progress=progress)
            finally:
                progress.close()
            current = backups.Backup(args.address, backups.kind_of(drive), now)
            named = drive.profile if drive.profile_named else None
            writes, skips = plan(wanted, current, drive.params, named)
            if not args.json:
                for write in writes:
                    print(write.text())
                for skip in skips:
                    print(skip.text())
                if not writes:
                    print(f"drive {args.address} already holds {args.file}: nothing to write")
            if args.dry_run or not writes:
                if args.json:
                    emit(args, report(args, writes, skips, None), "")
                return EXIT_OK
            question = f"write {len(writes)} parameter(s) to drive {args.address}? [y/N]"
            if not args.yes and not ask(question):
                print("nothing written")
                return EXIT_USAGE
            progress = _params.Progress("restore", enabled=None if not args.json else False)
            outcomes: list[Outcome] = []
            try:
                await restore(
                    drive, writes, eeprom=args.eeprom, progress=progress, outcomes=outcomes
                )
            except asyncio.CancelledError:  # Ctrl+C: say what was written, then stop
                progress.close()
                stopped(args, "interrupted", writes, skips, outcomes, None)
                raise
            except UssError as exc:  # the drive gone: what was written is not lost
                progress.close()
                stopped(args, str(exc), writes, skips, outcomes, exc)
                return EXIT_FAILED
            finally:
                progress.close()
            _params.save(args, drive)
        failed = [o for o in outcomes if not o.ok]
        otherwise = sum(o.differs for o in failed)
        if not args.json:
            print_failed(failed)
            stored = " and stored in EEPROM" if args.eeprom else ""
            print(
                f"drive {args.address}: {len(outcomes) - len(failed)} of {len(outcomes)} "
                f"written{stored}"
                + (f", {len(failed) - otherwise} refused" if len(failed) > otherwise else "")
                + (f", {otherwise} answered with another value" if otherwise else "")
            )
        if args.json:
            emit(args, report(args, writes, skips, outcomes), "")
        return EXIT_FAILED if failed else EXIT_OK

    return run("restore", args, body)


def stopped(
    args: argparse.Namespace,
    why: str,
    writes: list[Any],
    skips: list[Any],
    outcomes: list[Outcome],
    exc: UssError | None,
) -> None:
    """A restore cut short after ``outcomes``: what it wrote, what it did not, how to go on
    (stderr; with ``--json`` the report with the results so far and the error)."""
    if args.json:
        data = report(args, writes, skips, outcomes)
        data["error"] = (
            error_dict(exc) if exc is not None else {"type": "Interrupted", "message": why}
        )
        emit(args, data, "")
        return
    print_failed([o for o in outcomes if not o.ok])
    sys.stdout.flush()
    print(f"uss restore: {why}: drive {args.address} not fully restored", file=sys.stderr)
    for line in cut_short(writes, outcomes):
        print(f"uss restore: {line}", file=sys.stderr)


def print_failed(failed: list[Outcome]) -> None:
    """The writes the drive refused, and those it answered with another value than the
    file's (it holds that one), one line each."""
    for outcome in failed:
        if outcome.differs:
            print(outcome.error_text())
        else:
            print(f"{outcome.write.label}: refused: {outcome.error_text()}")


def check_kind(args: argparse.Namespace, wanted: backups.Backup, kind: str) -> None:
    """`ConfigError` (nothing written) for a file of another kind than the drive, unless
    ``--force``."""
    if wanted.profile != kind and not args.force:
        raise ConfigError(f"{args.file} is {whose(wanted.profile)}, {this(kind)}")


def whose(kind: str) -> str:
    """``a backup of a generic drive`` / ``a backup of a drive of unknown kind``."""
    if kind == backups.UNKNOWN_KIND:
        return "a backup of a drive of unknown kind (taken without --profile)"
    return f"a backup of a {kind} drive"


def this(kind: str) -> str:
    """What the command takes the drive as, and what to do about a file of another kind."""
    if kind == backups.UNKNOWN_KIND:
        return (
            "this drive is of unknown kind (no --profile): give the file's --profile, or "
            "--force to write its words as read"
        )
    return f"this is --profile {kind} (--force to restore anyway)"


def report(
    args: argparse.Namespace, writes: list[Any], skips: list[Any], outcomes: Any
) -> dict[str, Any]:
    return {
        "address": args.address,
        "file": args.file,
        "dry_run": args.dry_run,
        "writes": [
            {"label": w.label, "pnu": w.pnu, "index": w.index, "change": w.text()} for w in writes
        ],
        "skipped": [
            {"label": s.entry.label, "pnu": s.entry.pnu, "reason": s.reason} for s in skips
        ],
        "results": None if outcomes is None else [o.to_dict() for o in outcomes],
    }
