"""Find the drives on a line: their addresses, baud rate, telegram layout and family.

Every address of ``--address`` (default 0-31) is probed at every rate of ``--baud`` (a list,
default 9600; ``auto`` for the usual rates 9600, 19200, 38400, 57600, 115200 and 187500;
``all`` for the 13 rates of USS specification B 2.4) with "no job" telegrams
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
says so). Exit code 0 when at least one drive answered, 1 when none did; when none did, stderr
(without ``--json``) says what was tried (rates, addresses, layouts) and what to check: the
parameters each family keeps its bus baud rate and address in (its parameter file's
``[interface]`` table: P2010 and P2011 on MICROMASTER 4 and SINAMICS, P511 and P512 on NORD),
the wiring of A and B, and the termination.

Each drive found with a parameter area is asked who it is as soon as it is found, on the line
still open at its rate: the family column names it where the drive shows its identity in a
parameter (r0964 product type on MICROMASTER 420/440, P2023 on SINAMICS V20, P743/P707 on NORD
SK 500E; docs/drives.md), and the profile column the profile to give to the other commands.
A drive that shows no family stays one of unknown kind (``-``; ``null`` in JSON): no profile is
named for it on the strength of its answering. The firmware column shows the firmware version
where the family's file names the parameter that holds it (r0018 on MICROMASTER 4 and SINAMICS).

``--save [FILE]`` writes what was found as a line description (``uss.toml`` in the working
directory unless FILE is given; docs/lines.md): one line ``line1`` with the port, the rate most
drives answered at, their layout and profile, and a drive ``drive<ADDRESS>`` per drive, so that
``uss read 5 P1120`` then needs no ``--port`` and no ``--profile``. A file that exists is
refused before the scan (exit 2) unless ``--force``; the file is written atomically, and only
when a drive answered. The probes follow the USS specification's
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
from pyuss.commission import survey
from pyuss.commission.survey import Surveyed
from pyuss.errors import ConfigError
from pyuss.lines import FILE_NAME
from pyuss.master.profile import resolve_profile
from pyuss.master.scan import USUAL_BAUDS, Found, Progress, probe_layouts, scan
from pyuss.master.scheduler import Master
from pyuss.profiles import Profile
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
    parser.add_argument(
        "--save",
        nargs="?",
        const=FILE_NAME,
        metavar="FILE",
        help=f"write the line found as a configuration file (default FILE: ./{FILE_NAME}; "
        "docs/lines.md)",
    )
    parser.add_argument(
        "--force", action="store_true", help="with --save: replace FILE if it exists"
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
    if text.strip().lower() == "auto":
        return list(USUAL_BAUDS)
    out: list[int] = []
    for part in text.split(","):
        try:
            baud = check_baud(int(part.strip()))
        except ValueError:
            raise ConfigError(
                f"--baud {text!r}: expected a list such as 9600,19200, auto or all"
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


HEADER = "address  baud    layout  status  response  profile         firmware  family"

IDENTIFY_TIMEOUT = 1.0
"""Seconds each identification read may take."""


def row(drive: Surveyed) -> str:
    """The line of one drive in the table."""
    f = drive.found
    status = "-" if f.status is None else f"{f.status:04X}h"
    response = "-" if f.measured is None else f"{f.measured * 1000:.2f} ms"
    return (
        f"{f.address:>7}  {f.baud:<6}  {f.layout!s:<6}  {status:<6}  {response:<8}  "
        f"{drive.profile or '-':<14}  {drive.firmware or '-':<8}  {drive.family or '-'}"
    )


class Report:
    """Asks each drive who it is as it is found, then prints it (text) or keeps it for one
    JSON list at the end."""

    def __init__(self, args: argparse.Namespace, bar: Bar) -> None:
        self.args = args
        self.bar = bar
        self.found: list[Surveyed] = []
        self.asked: dict[tuple[int, int], Surveyed] = {}

    async def identify(self, bus: Master, found: Found) -> Found:
        """The `pyuss.master.scan.Identify` hook: who it is, on the scanning master."""
        surveyed = await survey.identify(bus, found, timeout=IDENTIFY_TIMEOUT)
        self.asked[found.address, found.baud] = surveyed
        return found

    def __call__(self, found: Found) -> None:
        drive = self.asked.get((found.address, found.baud), Surveyed(found))
        self.found.append(drive)
        if self.args.json:
            return
        self.bar.clear()
        if len(self.found) == 1:
            print(HEADER)
        print(row(drive), flush=True)

    def items(self) -> list[dict[str, Any]]:
        return [drive.to_dict() for drive in self.found]

    def finish(self) -> None:
        if self.args.json:
            emit(self.args, self.items(), "")
        elif not self.found:
            print("no drive answered", flush=True)


def nothing_found(
    bauds: list[int], addresses: str, layouts: list[Layout], profile: Profile | None
) -> str:
    """What stderr says when no drive answered: what was tried, and what to check."""
    settings = survey.bus_settings(profile)
    lines = [
        f"uss scan: no drive answered at {', '.join(map(str, bauds))} baud, addresses "
        f"{addresses}, layouts {' '.join(map(str, layouts))}; check:",
        "  - each drive's bus baud rate and address, set on the drive"
        + (f": {settings[0]}" if profile is not None else ":"),
        *(f"      {line}" for line in (settings if profile is None else ())),
        "  - the wiring: RS-485 A to A and B to B on every drive (swapped, none answers), and "
        "a common ground",
        "  - the termination: 120 ohm at both ends of the line, none between",
    ]
    if set(USUAL_BAUDS) - set(bauds):
        lines.append("  - other rates: --baud auto tries " + ", ".join(map(str, USUAL_BAUDS)))
    return "\n".join(lines)


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


def save(args: argparse.Namespace, port: str, drives: list[Surveyed]) -> None:
    """Write the line found to ``--save`` and say so (not with ``--json``: the list alone)."""
    data, left = survey.line_table(port, drives)
    survey.save_line(data, args.save, overwrite=args.force)
    (line,) = data["bus"]
    for drive in left:
        print(
            f"uss scan: drive {drive.address} answered at {drive.found.baud} baud, not at the "
            f"line's {line['baud']}: left out of {args.save}",
            file=sys.stderr,
        )
    if args.json:
        return
    count = len(line["drive"])
    print(
        f"{args.save}: line {line['name']}, {line['baud']} baud, {count} "
        f"drive{'' if count == 1 else 's'} ({', '.join(d['name'] for d in line['drive'])})",
        flush=True,
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
        if args.save is not None:
            survey.check_new(args.save, overwrite=args.force)  # before the scan
        elif args.force:
            raise ConfigError("--force belongs to --save (replace the file it names)")
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
        if not report.found:
            given = None if name in (None, "auto") else profile
            if not args.json:  # JSON: the empty list alone
                print(
                    nothing_found(bauds, args.address, probe_layouts(profile, layouts), given),
                    file=sys.stderr,
                )
            return EXIT_FAILED
        if args.save is not None:
            save(args, port, report.found)
        return EXIT_OK

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
