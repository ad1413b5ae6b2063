"""Read a drive's whole parameter set into a file: uss backup ADDRESS -o FILE

Every parameter pyuss knows of the drive (``--profile``'s parameter file, ``--params FILE``, the
drive's descriptions) is read, arrays whole; ``--scan FROM-TO`` first finds the parameters no
file knows over that range: by asking for their descriptions (C 6) where ``--describe`` says
the drive has them, else, and for a drive that refuses or does not answer a description, by
reading their values (a drive of unknown kind, without ``--profile``, has no file and gives
what the scan finds, as words). The file (TOML for
``.toml``, JSON for ``.json``, a CSV export for ``.csv``; ``--format`` to choose) starts with a
header: address, profile, date, the drive's identity parameters where it has them. A parameter
that cannot be read is recorded with its error and the backup goes on; a drive that stops
answering ends it (nothing written). An existing FILE is refused before the drive is read
(exit code 2) unless ``--force``, which replaces it (a device or a pipe is never replaced).
A progress bar with the time left shows on a terminal. The file is written atomically: a
backup killed half way leaves no half-written file. Exit code 0 when every parameter was
read, 1 when some were not (the file says which).
"""

from __future__ import annotations

import argparse
from typing import Any

from pyuss.cli import _params
from pyuss.cli._master import EXIT_FAILED, EXIT_OK, command, emit, finish, open_master, run
from pyuss.cli.params import pnu_range
from pyuss.commission import backup as backups
from pyuss.errors import ConfigError


def register(subparsers: Any) -> None:
    parser = command(subparsers, "backup", "read a drive's parameter set into a file", __doc__)
    parser.add_argument(
        "-o", "--output", required=True, metavar="FILE", help="file to write (.toml, .json, .csv)"
    )
    parser.add_argument(
        "--format", choices=backups.FORMATS, help="file format (default: from the file name)"
    )
    parser.add_argument(
        "--scan",
        metavar="FROM-TO",
        help="also find the parameters no file knows, by their descriptions where the drive "
        "has them (C 6), else by reading their values",
    )
    parser.add_argument(
        "--force", action="store_true", help="replace FILE if it exists (else it is refused)"
    )
    _params.add_options(parser)
    finish(parser, main)


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        fmt = backups.file_format(args.output, args.format)
        backups.check_new(args.output, overwrite=args.force)  # before the drive is read
        span = pnu_range(args.scan) if args.scan else None
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            _params.setup(args, drive)
            progress = _params.Progress("backup", enabled=None if not args.json else False)
            try:
                pnus = None
                if span is not None:
                    span = pnu_range(args.scan, drive)  # within the drive's numbers
                    found = await backups.scan(drive, span, progress=progress)
                    pnus = sorted({*drive.params.pnus(), *found})
                    progress.close()
                    progress = _params.Progress("backup", enabled=None if not args.json else False)
                if pnus is None and not drive.params.pnus():
                    kind = "" if drive.profile_named else " (a drive of unknown kind: no --profile)"
                    raise ConfigError(
                        f"no parameter of drive {args.address} is known{kind}: a backup would "
                        "hold nothing; --scan FROM-TO finds its parameters, --params FILE names "
                        "them, --profile NAME gives its family's"
                    )
                taken = await backups.take(drive, pnus=pnus, port=args.port, progress=progress)
            finally:
                progress.close()
            _params.save(args, drive)
        backups.save(taken, args.output, fmt, overwrite=args.force)
        failed = taken.failed
        if not args.json:
            for entry in failed:
                print(f"{entry.label}: not read: {entry.error and entry.error['message']}")
        summary = {
            "address": args.address,
            "file": args.output,
            "format": fmt,
            "parameters": len(taken.entries),
            "failed": [e.to_dict() for e in failed],
            "identity": [e.to_dict() for e in taken.identity],
        }
        note = f" ({len(failed)} not read)" if failed else ""
        emit(
            args,
            summary,
            f"drive {args.address}: {len(taken.entries)} parameters{note} -> {args.output}",
        )
        return EXIT_FAILED if failed else EXIT_OK

    return run("backup", args, body)
