"""What the commands that speak of parameter values share: ``--params FILE`` (the user's
parameter file, the simulator's TOML format), ``--describe auto|always|never|missing`` (when to
ask the drive for its parameter descriptions, C 6; `pyuss.params.Describe`), ``--params-cache
FILE`` (keep the descriptions read, and which drives have none), and a progress line on stderr
for long jobs."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any, TextIO

from pyuss.master.drive import Drive
from pyuss.params.book import Describe


def add_options(parser: argparse.ArgumentParser) -> None:
    """``--params``, ``--describe`` and ``--params-cache``."""
    group = parser.add_argument_group("parameter knowledge")
    group.add_argument(
        "--params",
        metavar="FILE",
        help="parameter file of the drive (the simulator's TOML format, docs/drive.md); "
        "trusted above the drive's descriptions and the profile's file",
    )
    group.add_argument(
        "--describe",
        choices=[d.value for d in Describe],
        default=Describe.AUTO.value,
        help="when to read the drive's own parameter descriptions (USS specification C 6): "
        "auto (default): for parameters no file knows where --profile says the drive has "
        "descriptions, never without --profile; always: before every parameter; never; "
        "missing: for parameters no file knows, whatever the profile. A drive that refuses "
        "or does not answer one is asked no more",
    )
    group.add_argument(
        "--params-cache",
        metavar="FILE",
        help="JSON file keeping the descriptions read from drives, for the next run",
    )


def cache_key(args: argparse.Namespace, drive: Drive) -> str:
    return f"{args.profile or 'unknown'}@{args.port}#{drive.address}"


def setup(args: argparse.Namespace, drive: Drive) -> None:
    """Apply the options to ``drive``'s parameter book (`ConfigError` for a bad file)."""
    book = drive.params
    book.describe = Describe(getattr(args, "describe", Describe.AUTO.value))
    if getattr(args, "params", None):
        drive.use_params(args.params)
    if getattr(args, "params_cache", None):
        book.load_cache(args.params_cache, cache_key(args, drive))


def save(args: argparse.Namespace, drive: Drive) -> None:
    """Keep what the run learnt in ``--params-cache``."""
    if getattr(args, "params_cache", None):
        drive.params.save_cache(args.params_cache, cache_key(args, drive))


class Progress:
    """A one-line progress bar with an estimate of the time left, redrawn on ``stream``
    (stderr) only where it is a terminal, so files and pipes get no control characters."""

    def __init__(
        self, what: str, *, stream: TextIO | None = None, enabled: bool | None = None
    ) -> None:
        self.what = what
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.start = time.monotonic()
        self.shown = False

    def __call__(self, done: int, total: int, *_: Any) -> None:
        if not self.enabled or total <= 0:
            return
        width = 30
        filled = width * done // total
        elapsed = time.monotonic() - self.start
        left = elapsed / done * (total - done) if done else 0.0
        eta = f"ETA {left:4.0f} s" if done < total else f"{elapsed:5.1f} s"
        bar = "#" * filled + "." * (width - filled)
        self.stream.write(f"\r{self.what} [{bar}] {done}/{total} {eta}")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
            self.shown = False
