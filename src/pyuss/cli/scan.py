"""Find the drives on a line: their addresses, baud rate, telegram layout and family.

Every address of ``--address`` (default 0-31) is probed at every rate of ``--baud`` (a list,
default 9600; ``all`` for the 13 rates of USS specification B 2.4) with "no job" telegrams
whose control word is 0000h: bit 10 clear means "process data not valid" (USS specification
C Table 5.4), so the drives take nothing from them. A drive with a fixed telegram length
answers only a telegram of its own length, so the common fixed layouts are tried in turn
(``--layout`` gives the list instead, repeatable); a variable-length drive is recognised by the
length of its answers.

Each drive is printed as soon as it is found; ``--first`` stops there. An address that stays
silent costs, for every layout tried, its request, the response window (20 ms by default,
A 5.2.1.1) and the 20 ms a serial adapter is allowed for handing characters over: the 32
addresses take about 15 s at 9600 baud, a little less at the faster rates, and ``--baud all``
some 6 to 7 minutes, most of it at the slow rates. A progress bar with the time still to go
goes to stderr when it is a terminal. Ctrl+C stops the scan: the drives found so far stay
printed (with ``--json`` they are printed as the JSON list), exit code 130.

A rate the port cannot be opened at (a ``bus://`` line runs at one rate only) is not probed,
with a note on stderr. A pseudo-terminal (``uss simulate --pty``) carries no baud rate at all:
a drive behind one answers at every rate, so the rate cannot be told there (a note on stderr
says so). Exit code 0 when at least one drive answered, 1 when none did.

Each drive found with a parameter area is asked who it is as soon as it is found, on the line
still open at its rate: the family column names it where the drive shows its identity in a
parameter (r0964 product type on MICROMASTER 420/440, P2023 on SINAMICS V20, P743/P707 on NORD
SK 500E; docs/drives.md), and the profile column the profile to give to the other commands.
A drive that shows no family stays one of unknown kind (``-``; ``null`` in JSON): no profile is
named for it on the strength of its answering. The probes follow the USS specification's
telegram rules; ``--profile NAME`` probes by that family's (its default layout first), and
``--profile auto`` as without a profile.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    command,
    emit,
    finish,
    master_options,
    run,
)
from pyuss.errors import ConfigError, UssError
from pyuss.master.identify import identify_on
from pyuss.master.profile import resolve_profile
from pyuss.master.scan import Found, Progress, probe_layouts, scan
from pyuss.master.scheduler import Master
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import MAX_ADDRESS
from pyuss.system import is_pty_device
from pyuss.transport.queued import BAUD_RATES, check_baud
from pyuss.transport.url import open_transport


def register(subparsers: Any) -> None:
    parser = command(
        subparsers, "scan", "find drives, their baud rate and telegram layout", __doc__
    )
    parser.add_argument(
        "--address",
        default="0-31",
        metavar="RANGE",
        help="bus addresses to probe, e.g. 0-31 or 1,5,7-9 (default 0-31)",
    )
    parser.add_argument(
        "--first", action="store_true", help="stop at the first drive found (a quick check)"
    )
    finish(parser, main)


def ranges(text: str) -> list[int]:
    """``0-31`` or ``1,5,7-9`` as a list of addresses."""
    out: list[int] = []
    for part in text.split(","):
        low, dash, high = part.strip().partition("-")
        try:
            first = int(low, 0)
            last = int(high, 0) if dash else first
        except ValueError:
            raise ConfigError(
                f"--address {text!r}: expected addresses 0..{MAX_ADDRESS} and ranges, e.g. 0-31 or "
                "1,5,7-9"
            ) from None
        if not 0 <= first <= last <= MAX_ADDRESS:
            raise ConfigError(f"--address {text!r}: addresses are 0..{MAX_ADDRESS}, low to high")
        out += [a for a in range(first, last + 1) if a not in out]
    return out


def rates(text: str) -> list[int]:
    if text.strip().lower() == "all":
        return list(BAUD_RATES)
    out: list[int] = []
    for part in text.split(","):
        try:
            baud = check_baud(int(part.strip()))
        except ValueError:
            raise ConfigError(
                f"--baud {text!r}: expected a list such as 9600,19200 or all"
            ) from None
        if baud not in out:
            out.append(baud)
    return out


class Bar:
    """A progress bar on stderr with the time still to go (only when it is a terminal)."""

    def __init__(self) -> None:
        self.enabled = sys.stderr.isatty()
        self.shown = False

    def __call__(self, progress: Progress) -> None:
        if not self.enabled or not progress.total:
            return
        width = 30
        filled = width * progress.done // progress.total
        left = "" if progress.left is None else f", {_duration(progress.left)} left"
        sys.stderr.write(
            f"\rscanning [{'#' * filled}{'.' * (width - filled)}] "
            f"{progress.done}/{progress.total}{left}\x1b[K"
        )
        sys.stderr.flush()
        self.shown = True

    def clear(self) -> None:
        """Take the bar off its line (before a drive's line is printed)."""
        if self.shown:
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()


def _duration(seconds: float) -> str:
    whole = round(seconds)
    return f"{whole // 60} min {whole % 60:02d} s" if whole >= 60 else f"{whole} s"


HEADER = "address  baud    layout  status  response  family"

IDENTIFY_TIMEOUT = 1.0
"""Seconds each identification read may take."""


def row(f: Found, family: str = "-") -> str:
    """The line of one drive in the table."""
    status = "-" if f.status is None else f"{f.status:04X}h"
    response = "-" if f.measured is None else f"{f.measured * 1000:.2f} ms"
    return f"{f.address:>7}  {f.baud:<6}  {f.layout!s:<6}  {status:<6}  {response:<8}  {family}"


def render(found: list[Found], families: dict[int, tuple[str, str]] | None = None) -> str:
    if not found:
        return "no drive answered"
    families = families or {}
    rows = [row(f, families.get(f.address, ("-", ""))[0]) for f in found]
    return "\n".join([HEADER, *rows])


class Report:
    """Asks each drive who it is as it is found, then prints it (text) or keeps it for one
    JSON list at the end."""

    def __init__(self, args: argparse.Namespace, bar: Bar) -> None:
        self.args = args
        self.bar = bar
        self.found: list[Found] = []
        self.families: dict[int, tuple[str, str]] = {}

    async def identify(self, bus: Master, found: Found) -> Found:
        """The `pyuss.master.scan.Identify` hook: the family, on the scanning master."""
        try:
            identity = await identify_on(bus, found.address, found.layout, timeout=IDENTIFY_TIMEOUT)
        except UssError:
            return found  # it stopped answering: no family
        if identity is not None and identity.profile is not None:
            self.families[found.address] = (identity.text, identity.profile)
        return found

    def __call__(self, found: Found) -> None:
        self.found.append(found)
        if self.args.json:
            return
        self.bar.clear()
        if len(self.found) == 1:
            print(HEADER)
        print(row(found, self.families.get(found.address, ("-", ""))[0]), flush=True)

    def items(self) -> list[dict[str, Any]]:
        out = []
        for f in self.found:
            family, use = self.families.get(f.address, ("", ""))
            out.append({**f.to_dict(), "family": family or None, "profile": use or None})
        return out

    def finish(self) -> None:
        if self.args.json:
            emit(self.args, self.items(), "")
        elif not self.found:
            print("no drive answered", flush=True)


def pty_note(port: str, bauds: list[int]) -> str | None:
    """What to say when ``port`` is a pseudo-terminal: it has no baud rate of its own."""
    if not is_pty_device(port):
        return None
    return (
        f"uss scan: {port} is a pseudo-terminal: it carries no baud rate, so a drive behind it "
        "answers at "
        + (
            "every rate probed and the rates cannot be told apart there"
            if len(bauds) > 1
            else "any rate: the rate shown is the one probed, not the drive's"
        )
    )


def main(args: argparse.Namespace) -> int:
    bar = Bar()
    report = Report(args, bar)

    async def body() -> int:
        addresses = ranges(args.address)
        bauds = rates(args.baud)
        layouts = [Layout.parse(text) for text in args.layout or ()]
        options = master_options(args)
        name = options.pop("profile")
        # no profile (or auto): the USS specification's telegram rules; families come only from
        # what each drive shows of itself (Report.identify)
        profile = resolve_profile(None if name == "auto" else name)
        probe_layouts(profile, layouts)  # checks the layouts against the profile early
        port = args.port
        open_transport(port, baud=bauds[0])  # a bad URL is bad input (exit 2) before probing
        note = pty_note(port, bauds)
        if note is not None:
            print(note, file=sys.stderr)
        notes: list[str] = []
        try:
            await scan(
                lambda baud: open_transport(port, baud=baud),
                bauds,
                addresses,
                profile=profile,
                layouts=layouts,
                on_progress=bar,
                skipped=lambda baud, exc: notes.append(f"uss scan: {baud} baud not probed: {exc}"),
                on_found=report,
                identify=report.identify,
                first=args.first,
                **options,
            )
        finally:
            bar.close()
        for line in notes:
            print(line, file=sys.stderr)
        report.finish()
        return EXIT_OK if report.found else EXIT_FAILED

    try:
        return run("scan", args, body)
    except KeyboardInterrupt:
        bar.close()
        count = len(report.found)
        print(
            f"uss scan: interrupted; {count} drive{'' if count == 1 else 's'} found so far"
            + (" (listed above)" if count and not args.json else ""),
            file=sys.stderr,
        )
        if args.json:
            emit(args, report.items(), "")
        return EXIT_INTERRUPTED
