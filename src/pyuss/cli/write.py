"""``uss write ADDRESS PNU[.INDEX] VALUE``: write a parameter value of a drive.

VALUE is an integer (``28672``, ``0x7000``, ``-5``) or a floating point number (``50.0``, sent
as a 32-bit IEEE value). A word is written with request 2 (array element: 7), a double word
with 3 (8) - a float, an integer outside -32768..65535, or ``--dword``; ``--eeprom`` stores the
value in the drive's non-volatile memory as well (requests 14, 13, 12, 11). Prints the value
the drive answered with.
"""

from __future__ import annotations

import argparse
from typing import Any

from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_OK,
    command,
    emit,
    finish,
    label,
    open_master,
    outcome,
    parameter,
    run,
)
from pyuss.cli.read import show
from pyuss.errors import ConfigError


def register(subparsers: Any) -> None:
    parser = command(subparsers, "write", "write a parameter value of a drive", __doc__)
    parser.add_argument("parameter", metavar="PNU[.INDEX]", help="e.g. 18 or 4.2")
    parser.add_argument("value", metavar="VALUE", help="integer (0x.. hex) or float")
    parser.add_argument("--eeprom", action="store_true", help="store in the drive's EEPROM too")
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--dword", action="store_true", help="write a double word (32 bits)")
    size.add_argument("--word", action="store_true", help="write a word (16 bits)")
    finish(parser, main)


def number(text: str) -> int | float:
    """An integer (any base prefix) or a float."""
    try:
        return int(text, 0)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"VALUE {text!r} is not an integer or a number") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise ConfigError(f"VALUE {text!r} is not a finite number")
    return value


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        pnu, index = parameter(args.parameter)
        value = number(args.value)
        dword = True if args.dword else (False if args.word else None)
        data: dict[str, Any] = {"address": args.address, "pnu": pnu, "index": index}
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            answer = await outcome(
                args, data, drive.write(pnu, value, index, dword=dword, eeprom=args.eeprom)
            )
        if answer is None:
            return EXIT_FAILED
        data["value"] = answer
        stored = " (stored in EEPROM)" if args.eeprom else ""
        emit(args, data, f"{label(pnu, index)} = {show(answer)}{stored}")
        return EXIT_OK

    return run("write", args, body)
