"""Show what differs between parameter sets: uss diff ADDRESS FILE, or uss diff FILE FILE

With an ADDRESS (and ``--port``) the drive's parameters named in FILE are read now and compared
with the file; with two files nothing is sent. Without ``--profile`` the drive is of unknown
kind and read as words; against a file of a named profile (or two files of different profiles)
the parameters are compared by their raw words. Each setting that differs prints as one line
with the parameter's name and unit: ``P1120 (Ramp-up time): 10.00 s -> 2.50 s`` (left ->
right). Read-only values (status words, actual values) that differ follow apart: the drive
measures or shows them, they are no settings and no restore writes them. A parameter neither
side has a value of (not read by the backup, nor now) is not compared: a line names them first,
and the settings agree only "in the parameters both hold". Exit code 0 when the settings
agree, 1 when they differ (as diff does) or the drive gave no value of a parameter, 2 for a
file that is no backup.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pyuss.cli import _params
from pyuss.cli._help import subcommand
from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_OK,
    add_options,
    emit,
    names_drive,
    open_master,
    run,
    use_lines,
)
from pyuss.commission import backup as backups
from pyuss.commission.compare import (
    Sides,
    changed_values,
    compare,
    not_compared,
    plan,
    restore_line,
)
from pyuss.errors import ConfigError
from pyuss.lines import is_address
from pyuss.params.book import ParamBook
from pyuss.profiles import Profile, get_profile


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers, "diff", "compare a drive with a backup, or two backups", __doc__
    )
    parser.add_argument("left", metavar="ADDRESS|FILE", help="drive address (with --port) or file")
    parser.add_argument("right", metavar="FILE", help="backup file (TOML or JSON)")
    add_options(parser)
    parser.set_defaults(func=main)
    for action in parser._actions:  # --port only when the left side is a drive
        if action.dest == "port":
            action.required = False
    _params.add_options(parser)
    parser.epilog = (
        "exit codes:\n  0    the settings agree\n  1    settings differ, or the drive gave no "
        "value of one\n  2    bad input"
    )


def book_for(profile: str) -> ParamBook | None:
    try:
        return ParamBook.for_profile(get_profile(profile))
    except ConfigError:
        return None


def family_of(profile: str) -> Profile | None:
    try:
        return get_profile(profile)
    except ConfigError:
        return None


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        right = backups.load(args.right)
        book: ParamBook | None
        restoring = ""
        if is_address(args.left) or (not Path(args.left).exists() and names_drive(args, args.left)):
            args.address = args.left
            use_lines(args, args.left)
            where = args.address
            async with open_master(args) as bus:
                drive = bus.drive(where)
                _params.setup(args, drive)
                entries = await backups.read_entries(drive, right)
                book = drive.params
                family = drive.profile if drive.profile_named else None
            left = backups.Backup(where, backups.kind_of(drive), entries, source=f"drive {where}")
            left_name = f"drive {where}"
            sides = Sides(Sides.drive(where), Sides.file(args.right))
            live = True
            try:
                restoring = restore_line(where, args.right, *plan(right, left, book, family))
            except ConfigError as exc:  # a value the parameter cannot take
                restoring = f"uss restore {where} {args.right} would refuse the file: {exc}"
        else:
            left = backups.load(args.left)
            left_name = args.left
            sides = Sides(Sides.file(args.left), Sides.file(args.right))
            live = False
            book = book_for(right.profile)
            family = family_of(right.profile)
        differences = compare(left, right)
        values = changed_values(left, right)
        unknown = not_compared(left, right)
        if args.json:
            emit(
                args,
                {
                    "left": left_name,
                    "right": args.right,
                    "sides": {"left": sides.left, "right": sides.right},
                    "restore": restoring or None,
                    "differences": [d.to_dict() for d in differences],
                    "read_only": [d.to_dict() for d in values],
                    "not_compared": [d.to_dict() for d in unknown],
                },
                "",
            )
        else:
            print(sides.header())
            if unknown:
                print(
                    "not compared, read on neither side: "
                    + ", ".join(f"{d.label} ({d.name})" if d.name else d.label for d in unknown)
                )
            for difference in differences:
                print(difference.text(book, family))
            count = len(differences)
            print(
                f"{count} parameter{'s' if count != 1 else ''} differ{'s' if count == 1 else ''}"
                f" between {left_name} and {args.right}"
                if count
                else f"{left_name} and {args.right} agree"
                + (" in the parameters both hold" if unknown else "")
            )
            if values:
                print(
                    "read-only values, measured or shown by the drive (no settings, not restored):"
                )
                for value in values:
                    print(f"  {value.text(book, family)}")
            if restoring:
                print(restoring)
        # a parameter the drive gave no value of now could not be read (exit code 1)
        return EXIT_FAILED if differences or (unknown and live) else EXIT_OK

    return run("diff", args, body)
