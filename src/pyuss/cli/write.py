"""Write a parameter value of a drive: uss write ADDRESS PNU[.INDEX] VALUE

VALUE is an integer (28672, 0x7000, -5) or a floating point number (50.0, sent as a 32-bit
IEEE 754 value). ``--eeprom`` stores the value in the drive's non-volatile memory as well.
Prints the value the drive answered with.

A word is written with request 2 (array element: 7), a double word - a float, an integer
outside -32768..65535, or ``--dword`` - with 3 (8), and with ``--eeprom`` requests 14, 13, 12,
11 (USS specification C 4.2.1.1).

When no answer to the write comes in time (``--timeout``) the drive may still have carried it
out: only its answer may have been lost on the line. ``uss write`` then says so and exits 1;
with ``--verify`` it reads the value back and tells: the drive holds the value (exit 0, "read
back"), or it does not (exit 1, the write was not carried out and may be repeated). With
``--json`` the result says ``"outcome": "answered"`` or ``"read_back"``; a failure's error
object carries ``outcome`` (``not_sent``, ``unknown``, ``not_applied``) and
``may_have_applied``.
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
from pyuss.master.drive import Drive
from pyuss.master.errors import JobTimeout
from pyuss.master.verify import read_back
from pyuss.protocol.pkw import ResponseId


def register(subparsers: Any) -> None:
    parser = command(subparsers, "write", "write a parameter value of a drive", __doc__)
    parser.add_argument(
        "parameter",
        metavar="PNU[.INDEX]",
        help="parameter number, with .INDEX for an element of an array parameter, e.g. 18 or 4.2",
    )
    parser.add_argument(
        "value", metavar="VALUE", help="the value: an integer (0x for hex) or a float"
    )
    parser.add_argument(
        "--eeprom",
        action="store_true",
        help="store the value in the drive's non-volatile memory (EEPROM) too",
    )
    size = parser.add_mutually_exclusive_group()
    size.add_argument(
        "--dword",
        action="store_true",
        help="send the value as a double word, 32 bits: for 32-bit parameters with small values",
    )
    size.add_argument("--word", action="store_true", help="send the value as a word, 16 bits")
    parser.add_argument(
        "--verify",
        action="store_true",
        help="when the answer to the write is lost, read the value back to tell whether the "
        "drive took it",
    )
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


# -- the outcome of a write whose answer was lost (--verify) ---------------------------------

ANSWERED = "answered"
READ_BACK = "read_back"


async def write_verified(
    drive: Drive,
    pnu: int,
    value: int | float,
    index: int | None,
    dword: bool | None,
    eeprom: bool,
    verify: bool,
) -> tuple[int | float, str]:
    """Write; returns the value and how it is known (`ANSWERED`, or `READ_BACK` when the
    answer was lost and ``verify`` read the value back). Without ``verify`` a lost answer
    raises the `JobTimeout` with a hint to use it."""
    try:
        return await drive.write(pnu, value, index, dword=dword, eeprom=eeprom), ANSWERED
    except JobTimeout as error:
        if not error.may_have_applied:
            raise
        if not verify:
            error.args = (f"{error.args[0]} (uss write --verify does)",)
            raise
        held = await read_back(drive, error)
    if isinstance(value, float):
        return held.float32(), READ_BACK
    double = held.id in (ResponseId.VALUE_DWORD, ResponseId.ARRAY_DWORD)
    signed = value < 0
    return (held.dword(signed=signed) if double else held.word(signed=signed)), READ_BACK


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        pnu, index = parameter(args.parameter)
        value = number(args.value)
        dword = True if args.dword else (False if args.word else None)
        data: dict[str, Any] = {"address": args.address, "pnu": pnu, "index": index}
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            written = await outcome(
                args,
                data,
                write_verified(drive, pnu, value, index, dword, args.eeprom, args.verify),
            )
        if written is None:
            return EXIT_FAILED
        answer, how = written
        data.update(value=answer, outcome=how)
        stored = " (stored in EEPROM)" if args.eeprom else ""
        lost = " (its answer was lost; read back: the drive holds it)" if how == READ_BACK else ""
        emit(args, data, f"{label(pnu, index)} = {show(answer)}{stored}{lost}")
        return EXIT_OK

    return run("write", args, body)
