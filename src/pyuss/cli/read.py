"""Read parameter values from a drive: uss read ADDRESS PNU[.INDEX] ...

Values print as the drive sends them, ``P52 = 16384 (4000h)``, or as signed numbers
(``--signed``) or 32-bit floating point numbers (``--float``). A parameter the drive refuses
prints its error number and meaning, the others are still read, and the exit code is 1.

Each value is one parameter job (USS specification C 4.2.1.1): request 1, or request 6 for the
element INDEX of an array parameter.
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
    error_dict,
    finish,
    label,
    open_master,
    parameter,
    run,
)
from pyuss.errors import ConfigError, UssError


def register(subparsers: Any) -> None:
    parser = command(subparsers, "read", "read parameter values from a drive", __doc__)
    parser.add_argument(
        "parameters",
        nargs="+",
        metavar="PNU[.INDEX]",
        help="parameter number, with .INDEX for an element of an array parameter, e.g. 52 or 683.1",
    )
    kind = parser.add_mutually_exclusive_group()
    kind.add_argument(
        "--signed", action="store_true", help="show values as signed numbers (two's complement)"
    )
    kind.add_argument(
        "--float",
        action="store_true",
        help="read 32-bit floating point values (IEEE 754; USS specification C 6)",
    )
    finish(parser, main)


def show(value: int | float) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if value < 0:
        return str(value)
    width = 8 if value > 0xFFFF else 4
    return f"{value} ({value:0{width}X}h)"


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        wanted = [parameter(text) for text in args.parameters]
        results: list[dict[str, Any]] = []
        failed = False
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            for pnu, index in wanted:
                item: dict[str, Any] = {"pnu": pnu, "index": index}
                try:
                    value: int | float
                    if args.float:
                        value = await drive.read_float(pnu, index)
                    else:
                        value = await drive.read(pnu, index, signed=args.signed)
                except ConfigError:
                    raise
                except UssError as exc:
                    failed = True
                    item["error"] = error_dict(exc)
                    if not args.json:
                        print(f"{label(pnu, index)}: {exc}", file=sys.stderr)
                else:
                    item["value"] = value
                    if not args.json:
                        print(f"{label(pnu, index)} = {show(value)}")
                results.append(item)
        if args.json:
            emit(args, {"address": args.address, "parameters": results}, "")
        return EXIT_FAILED if failed else EXIT_OK

    return run("read", args, body)
