"""List and search the parameters pyuss knows of a drive: uss params [SEARCH...]

Without a port it lists the profile's parameter file (``--profile``, default ``generic``) and
``--params FILE``; with ``--port URL ADDRESS`` it asks the drive as well (without
``--profile`` a drive of unknown kind: no family's file, only what ``--params``, the drive's
descriptions and ``--scan`` find): ``--describe always`` reads every parameter's
own description (C 6; the drive's name, type, scaling, access and limits win over the files),
``--scan FROM-TO`` looks for parameters no file knows by asking the drive for their
descriptions over that range, and ``--values`` reads the current value of each. SEARCH words
pick parameters by number (``1120``, ``P112`` for every number starting with 112) or by words
in the name, unit or documentation (all must match; case does not matter).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from pyuss.cli import _params
from pyuss.cli._help import subcommand
from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_OK,
    add_line_options,
    emit,
    error_dict,
    integer,
    master_options,
    names_drive,
    run,
    use_lines,
)
from pyuss.errors import ConfigError, UssError
from pyuss.master.drive import Drive
from pyuss.params.book import MACRO_WORDS, ParamBook, macro_profiles
from pyuss.params.model import ParamInfo
from pyuss.params.names import MAX_PNU
from pyuss.params.values import format_value, physical
from pyuss.profiles import get_profile, profile_names


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers, "params", "list the known parameters of a profile or drive, searchable", __doc__
    )
    parser.add_argument(
        "words",
        nargs="*",
        metavar="[ADDRESS] SEARCH",
        help="with --port or --line: the drive's address first (or its name in the "
        "configuration file, docs/lines.md); then numbers or words to look for",
    )
    parser.add_argument("--port", metavar="URL", help="ask the drive on this port as well")
    add_line_options(parser)
    parser.add_argument("--baud", type=integer, help="baud rate (default 9600)")
    parser.set_defaults(default_baud=9600, default_profile=None)
    parser.add_argument(
        "--profile",
        metavar="NAME",
        help=f"device profile ({', '.join(profile_names())}; default without a drive: "
        "generic's list; with a drive: none, a drive of unknown kind, whose parameters only "
        "the drive, --params and --scan tell)",
    )
    parser.add_argument("--layout", metavar="PKW,PZD", help="telegram layout (with --port)")
    parser.add_argument(
        "--timeout", type=float, default=2.0, metavar="S", help="seconds per job (default 2)"
    )
    parser.add_argument("--response-delay", type=float, metavar="MS", help=argparse.SUPPRESS)
    parser.add_argument("--tolerance", type=float, metavar="MS", help=argparse.SUPPRESS)
    parser.add_argument(
        "--scan",
        metavar="FROM-TO",
        help="with --port: find parameters no file knows by asking for descriptions (C 6)",
    )
    parser.add_argument(
        "--values", action="store_true", help="with --port: read each parameter's value too"
    )
    parser.add_argument("--json", action="store_true", help="print JSON for scripts")
    _params.add_options(parser)
    parser.set_defaults(func=main)


OFFLINE_PROFILE = "generic"
"""The list shown without a drive and without ``--profile``: the USS specification's drive
profile. A drive asked (``--port``) without ``--profile`` is of unknown kind instead."""


def pnu_range(text: str, drive: Drive | None = None) -> range:
    """``FROM-TO`` (both included) or one number; with ``drive``, within the numbers its
    profile can address (checked before the scan sends anything)."""
    first, dash, last = text.partition("-")
    try:
        low = int(first, 0)
        high = int(last, 0) if dash else low
    except ValueError:
        raise ConfigError(f"--scan {text!r}: give FROM-TO, for example 0-999") from None
    if not 0 <= low <= high:
        raise ConfigError(f"--scan {text!r}: FROM must be <= TO, both >= 0")
    most = MAX_PNU if drive is None else drive.profile.max_pnu
    if high > most:
        whose = (
            ""
            if drive is None
            else f" of profile {drive.profile.name}"
            if drive.profile_named
            else " of this drive"
        )
        raise ConfigError(f"--scan {text!r}: the parameter numbers{whose} are 0..{most}")
    return range(low, high + 1)


def limits(info: ParamInfo) -> str:
    """``0.00..650.00``: the limits a write must keep (empty when only the type's apply)."""
    if not info.is_numeric or info.is_bit_field:
        return ""
    if info.minimum is None and info.maximum is None and not info.allowed:
        return ""
    low, high = info.low, info.high
    if low is None or high is None:
        return ""
    show = [format_value(info, physical(info, v), unit=False, texts=False) for v in (low, high)]
    return f"{show[0]}..{show[1]}"


def row(info: ParamInfo, value: str | None = None) -> str:
    shape = info.type_name + (f"[{info.array}]" if info.array is not None else "")
    text = f"{info.label():<7} {info.name:<18} {shape:<12} {info.access.value:<9}"
    span = limits(info)
    text += f" {span + (' ' + info.unit if info.unit and span else ''):<20}"
    if not span and info.unit:
        text = text.rstrip() + f" {info.unit}"
    if info.texts:
        text += " " + ", ".join(f"{k}={v.strip()}" for k, v in list(info.texts.items())[:4])
        if len(info.texts) > 4:
            text += ", ..."
    if value is not None:
        text += f"  = {value}"
    return text.rstrip()


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        words = list(args.words)
        online = args.port is not None or args.line is not None
        if online or (words and names_drive(args, words[0])):
            if not words:
                raise ConfigError("give the drive's ADDRESS (or name) after --port or --line")
            args.address = words.pop(0)
            use_lines(args, args.address)
        else:
            args.profile = args.profile or OFFLINE_PROFILE
        if args.profile is not None:
            get_profile(args.profile)
        if args.port is None:
            if args.scan or args.values:
                raise ConfigError("--scan and --values ask a drive: give --port URL ADDRESS")
            book = ParamBook.for_profile(get_profile(args.profile))
            if args.params:
                book.use_file(args.params)
            return show(args, book, book.search(words), {})
        where = args.address
        from pyuss.cli._master import open_master
        from pyuss.commission.backup import scan

        master_options(args)
        values: dict[int, str] = {}
        failed = False
        words_only: list[int] = []
        async with open_master(args) as bus:
            drive = bus.drive(where)
            _params.setup(args, drive)
            book = drive.params
            if args.scan:
                progress = _params.Progress("scan", enabled=None if not args.json else False)
                try:
                    there = await scan(drive, pnu_range(args.scan, drive), progress=progress)
                finally:
                    progress.close()
                if not words:  # found by their values: nothing known but that they are there
                    words_only = [pnu for pnu in there if pnu not in book]
            found = book.search(words)
            for info in found:
                await drive.info(info.pnu)  # --describe always: the drive's own description
            found = book.search(words)
            if args.values:
                for pnu in [info.pnu for info in found] + words_only:
                    try:
                        reading = await drive.read_param(pnu)
                        values[pnu] = format_value(reading.info, reading.value)
                    except ConfigError:
                        raise
                    except UssError as exc:
                        failed = True
                        values[pnu] = f"(not read: {error_dict(exc)['message']})"
            _params.save(args, drive)
        show(args, book, found, values, words_only)
        return EXIT_FAILED if failed else EXIT_OK

    return run("params", args, body)


def show(
    args: argparse.Namespace,
    book: ParamBook,
    found: list[ParamInfo],
    values: dict[int, str],
    words_only: Sequence[int] = (),
) -> int:
    """Print the parameters found; ``words_only``: those a scan found that nothing is known
    of (a drive without descriptions), read as words."""
    if args.json:
        items = [
            info.to_dict() | ({"value_text": values[info.pnu]} if info.pnu in values else {})
            for info in found
        ] + [
            {"pnu": pnu, "label": book.label(pnu), "known": False}
            | ({"value_text": values[pnu]} if pnu in values else {})
            for pnu in words_only
        ]
        emit(args, {"profile": book.profile, "parameters": items}, "")
        return EXIT_OK
    for info in found:
        print(row(info, values.get(info.pnu)))
    for pnu in words_only:
        value = f"  = {values[pnu]}" if pnu in values else ""
        print(f"{book.label(pnu):<7} {'(nothing known: words)':<40}{value}".rstrip())
    if not found and not words_only:
        macro = set(MACRO_WORDS) & {w.casefold() for w in args.words}
        none = macro and not any(info.macro for info in book)
        print(no_macros(book) if none else "no parameter matches")
    return EXIT_OK


def no_macros(book: ParamBook) -> str:
    """Why ``uss params macro`` found nothing: the family's file has no macro parameter
    (``macro = true``, docs/drive.md); and which built-in files have."""
    having = macro_profiles()
    others = (
        f"profiles whose files have macro parameters: {', '.join(having)}"
        if having
        else "no built-in profile's file has macro parameters yet"
    )
    if not book.profile:
        return (
            "a drive of unknown kind has no family's parameter file, so no macro parameters "
            f"are known: give --profile NAME ({others})"
        )
    return f"the {book.profile} parameter file has no macro parameters ({others})"
