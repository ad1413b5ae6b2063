"""``uss scan``: find the drives on a line, their baud rate and telegram layout.

Every address of ``--address`` (default 0-31) is probed at every rate of ``--baud`` (a list,
default 9600; ``all`` for the 13 rates of B 2.4) with "no job" telegrams whose control word is
0000h: bit 10 clear means "process data not valid" (C Table 5.4), so the drives take nothing
from them. A drive with a fixed telegram length answers only a telegram of its own length, so
the common fixed layouts are tried in turn (``--layout`` gives the list instead, repeatable);
a variable-length drive is recognised by the length of its answers. A progress bar goes to
stderr when it is a terminal. A rate the port cannot be opened at (a ``bus://`` line runs at
one rate only) is not probed, with a note on stderr. Exit code 0 when at least one drive
answered, 1 when none did.

Each drive found with a parameter area is then asked who it is: the family column names it
where the drive shows its identity in a parameter (r0964 product type on MICROMASTER 420/440,
P2023 on SINAMICS V20, P743/P707 on NORD SK 500E; docs/drives.md), and the profile column the
profile to give to the other commands. ``--profile auto`` probes as ``generic`` does.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_OK,
    command,
    emit,
    finish,
    master_options,
    run,
)
from pyuss.errors import ConfigError
from pyuss.master.identify import identify_found
from pyuss.master.profile import resolve_profile
from pyuss.master.scan import Found, probe_layouts, scan
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import MAX_ADDRESS
from pyuss.transport.queued import BAUD_RATES, check_baud
from pyuss.transport.url import open_transport


def register(subparsers: Any) -> None:
    parser = command(
        subparsers, "scan", "find drives, their baud rate and telegram layout", __doc__
    )
    parser.add_argument(
        "--address", default="0-31", metavar="RANGE", help="addresses, e.g. 0-31 or 1,5,7-9"
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
                f"--address {text!r}: expected numbers and ranges like 0-31,40"
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
    """A progress bar on stderr (only when it is a terminal)."""

    def __init__(self) -> None:
        self.enabled = sys.stderr.isatty()
        self.shown = False

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or not total:
            return
        width = 30
        filled = width * done // total
        sys.stderr.write(f"\rscanning [{'#' * filled}{'.' * (width - filled)}] {done}/{total}")
        sys.stderr.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()


def render(found: list[Found], families: dict[int, tuple[str, str]] | None = None) -> str:
    if not found:
        return "no drive answered"
    families = families or {}
    lines = ["address  baud    layout  status  response  family"]
    for f in found:
        status = "-" if f.status is None else f"{f.status:04X}h"
        family = families.get(f.address, ("-", ""))[0]
        lines.append(
            f"{f.address:>7}  {f.baud:<6}  {f.layout!s:<6}  {status:<6}  "
            f"{f.response_time * 1000:.2f} ms  {family}"
        )
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        addresses = ranges(args.address)
        bauds = rates(args.baud)
        layouts = [Layout.parse(text) for text in args.layout or ()]
        options = master_options(args)
        name = options.pop("profile")
        profile = resolve_profile("generic" if name == "auto" else name)
        probe_layouts(profile, layouts)  # checks the layouts against the profile early
        port = args.port
        open_transport(port, baud=bauds[0])  # a bad URL is bad input (exit 2) before probing
        bar = Bar()
        notes: list[str] = []
        try:
            found = await scan(
                lambda baud: open_transport(port, baud=baud),
                bauds,
                addresses,
                profile=profile,
                layouts=layouts,
                progress=bar,
                skipped=lambda baud, exc: notes.append(f"uss scan: {baud} baud not probed: {exc}"),
                **options,
            )
        finally:
            bar.close()
        for note in notes:
            print(note, file=sys.stderr)
        families = await identify_found(lambda baud: open_transport(port, baud=baud), found)
        items = []
        for f in found:
            family, use = families.get(f.address, ("", ""))
            items.append({**f.to_dict(), "family": family or None, "profile": use or None})
        emit(args, items, render(found, families))
        return EXIT_OK if found else EXIT_FAILED

    return run("scan", args, body)
