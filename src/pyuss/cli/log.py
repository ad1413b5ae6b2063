"""Log drive values into a CSV file, one row per sample, for a spreadsheet.

    uss log 5 status actual P52 --rate 10 -o run.csv --port /dev/ttyUSB0 --baud 19200

VALUES: ``status`` (the status word), ``state`` (the drive state it spells), ``actual`` (the
actual values, PZD2 and up), a status bit's name (``ready``, ``operation_enabled``, ``fault``,
``warning``, ``in_tolerance``, ... or ``bit0``..``bit15``) or a parameter (``P52``, ``P4.2``:
read with a parameter job for every row). Each row starts with the wall-clock time (ISO 8601
with the UTC offset) and ends with a ``comm`` column: ``ok``, ``no answer`` (then every value
of the row is empty: a drive that stops answering is never logged with its last values) or
the drive's refusal of a parameter. Units stand in the header.

An existing file is never overwritten: ``--append`` adds rows to it when it has the same
columns; ``--rotate SIZE`` starts a new file when the current one would grow past SIZE (the
full one is renamed NAME-YYYYMMDD-HHMMSS.csv). Ctrl+C or SIGTERM ends the log cleanly, as do
``--count`` and ``--duration``. A file the disk cannot take more of ends it with one line
(``cannot write FILE: no space left on device``, exit code 1), the rows before kept whole. A
line too slow for ``--rate`` (9600 baud carries some 25 samples a second) is said on stderr,
once early and at the end with the rate reached, and in a ``#`` comment row at the end of the
file. A lost port or connection is reopened (the first try at once, then after 0.5 s, the wait
doubling up to 10 s; the rows meanwhile say ``no answer``); ``?reconnect=0`` in the port's URL
turns that off: then a lost port ends the log with exit code 1. See docs/web.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from pyuss.cli import _master
from pyuss.errors import ConfigError
from pyuss.system import stop_on_signals

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    parser = _master.command(
        subparsers,
        "log",
        "log drive values to a CSV file (status, actual values, parameters)",
        __doc__,
    )
    parser.add_argument(
        "values",
        nargs="+",
        metavar="VALUE",
        help="status, state, actual, a status bit's name (fault, ready, ...) or P52, P4.2",
    )
    parser.add_argument(
        "-o", "--output", required=True, metavar="FILE.csv", help="the CSV file to write"
    )
    parser.add_argument(
        "--rate", type=float, default=1.0, metavar="HZ", help="samples a second (default 1)"
    )
    parser.add_argument(
        "--append",
        action="store_true",
        help="add rows to an existing log with the same columns (else an existing file is refused)",
    )
    parser.add_argument(
        "--rotate",
        metavar="SIZE",
        help="start a new file before this one grows past SIZE (500k, 10M, 1G)",
    )
    parser.add_argument("--count", type=int, metavar="N", help="stop after N rows")
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    _master.finish(parser, run)


def run(args: argparse.Namespace) -> int:
    return _master.run("log", args, lambda: _log(args))


async def _log(args: argparse.Namespace) -> int:
    from pyuss.datalog import CsvLog, DataLogger, parse_size, parse_values
    from pyuss.datalog.logger import LogResult, rate_text, write_comment
    from pyuss.master import CYCLIC

    if args.count is not None and args.count < 1:
        raise ConfigError(f"--count {args.count}: must be at least 1")
    if args.duration is not None and not args.duration > 0:
        raise ConfigError(f"--duration {args.duration}: must be > 0 seconds")
    rotate = parse_size(args.rotate) if args.rotate else None
    quantities = parse_values(args.values)  # bad VALUES: bad input before the port is opened
    async with _master.open_master(args, mode=CYCLIC, reconnect=True) as master:
        drive = master.drive(args.address)
        logger = DataLogger(drive, quantities, rate=args.rate, job_timeout=args.timeout)
        await logger.prepare()
        log = CsvLog(args.output, logger.header(), append=args.append, rotate=rotate)
        if log.repaired:
            print(
                f"uss log: removed a last row cut short ({log.repaired} bytes) from {log.path}",
                file=sys.stderr,
            )
        with stop_on_signals() as stop:
            # a line lost for good (reconnect=0) ends the log: the master leaves it to us to say
            master.on_line(lambda _: stop.set() if master.lost is not None else None)
            if not args.json:
                print(
                    f"logging drive {args.address} to {log.path} at {args.rate:g} Hz: "
                    f"{', '.join(logger.header()[1:-1])}; Ctrl+C stops",
                    file=sys.stderr,
                    flush=True,
                )

            def short(so_far: LogResult) -> None:
                print(f"uss log: {rate_text(so_far)}", file=sys.stderr, flush=True)

            try:
                result = await logger.run(
                    log, stop, count=args.count, duration=args.duration, on_short=short
                )
                if result.short:
                    write_comment(log, rate_text(result))
                    print(f"uss log: {rate_text(result)}", file=sys.stderr)
            finally:
                log.close()
    summary = {
        "file": str(log.path),
        "rows": result.rows,
        "no_answer": result.no_answer,
        "rotated": [str(p) for p in log.rotated],
        "rate": args.rate,
        "rate_reached": round(result.reached, 3),
    }
    if master.lost is not None:
        print(f"uss log: the line is lost: {master.lost}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"{result.rows} rows ({result.no_answer} without answer) in {log.path}")
    return 0 if master.lost is None else 1
