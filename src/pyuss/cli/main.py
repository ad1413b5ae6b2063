"""The `uss` command. Each sub-command lives in its own module of `pyuss.cli` and exposes
``register(subparsers)``; `COMMANDS` lists them in the order `uss --help` shows them.

Exit codes (all commands): 0 success, 1 the operation failed (no answer, drive refused, ...),
2 bad input (arguments, hex, files), 130 interrupted.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
from collections.abc import Sequence

from pyuss import __version__
from pyuss.errors import UssError

COMMANDS: tuple[str, ...] = (
    "demo",
    "scan",
    "read",
    "write",
    "params",
    "backup",
    "diff",
    "restore",
    "status",
    "ack",
    "describe",
    "mirror",
    "run",
    "gateway",
    "simulate",
    "bus",
    "monitor",
    "wireshark",
    "decode",
    "web",
    "log",
    "bass",
    "ksvario",
)

ONE_SHOT = frozenset(
    {"scan", "read", "write", "describe", "mirror", "params", "backup", "diff", "restore"}
    | {"status", "ack"}
)
"""Commands whose outcome is their one line of output: their log warnings (a slave that does
not send, ...) stay quiet unless -v asks for them, so a failure reads as one line."""

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="uss", description="USS protocol toolkit: master, simulator, bus, monitor, tools."
    )
    parser.add_argument("--version", action="version", version=f"pyuss {__version__}")
    parser.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=0,
        help="-v: warnings and progress, -vv: also raw frames (pyuss.wire logger)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        module = importlib.import_module(f"pyuss.cli.{name}")
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    quiet = logging.ERROR if args.command in ONE_SHOT else logging.WARNING
    level = quiet if args.verbose == 0 else (logging.INFO if args.verbose == 1 else logging.DEBUG)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    try:
        code: int = args.func(args)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except UssError as exc:
        print(f"uss {args.command}: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except BrokenPipeError:
        # The reader went away (``uss ... | head``): stop quietly, like any filter does.
        _silence_stdout()
        return EXIT_OK
    return code


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush raises no second error."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
