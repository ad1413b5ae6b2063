"""Write a parameter value of a drive: uss write ADDRESS PNU[.INDEX] VALUE

VALUE is read by the parameter's type (from ``--params FILE``, the drive's own description (USS
specification C 6), or the profile's parameter file): ``10``, ``10.0``, ``10 s`` or ``500 ms``
for a time in seconds, ``0x7000`` for an integer, the text of an enumerated value
(``"19200 BAUD"``), text for a string. A value of the wrong kind, between two steps of a scaled
parameter, outside the limits, or for a read-only parameter is refused before anything is sent
(one line, exit 2). Bit fields (V2) and bit patterns go through ``--raw``: VALUE is then the
word (or, for a 32-bit parameter or with ``--dword``, the double word) sent as it is. A
parameter nothing is known of takes an integer (a word if it fits -32768..65535, else a double
word) or a float: so does every parameter of a drive of unknown kind (without ``--profile``)
that ``--params FILE`` does not know, and what the drive does not take the drive refuses (exit
1). Requests 2/3 (array element: 7/8, C 4.2.2); ``--eeprom`` stores the value in the drive's
non-volatile memory as well (14/13, 12/11). Prints the value the drive answered with; when
that is another value than the one written (the drive limits or rounds it), says so on stderr
and exits 1 (``--json``: ``written``, the words sent, and an ``error`` of type ``ValueDiffers``).

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
import sys
from typing import Any

from pyuss.cli import _params
from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_OK,
    command,
    emit,
    error_dict,
    finish,
    open_master,
    outcome,
    parameter,
    run,
)
from pyuss.errors import ConfigError
from pyuss.master.drive import Drive
from pyuss.master.errors import JobTimeout, ValueDiffers
from pyuss.master.verify import read_back
from pyuss.params.model import Reading
from pyuss.params.values import format_value, words_text
from pyuss.protocol.pkw import pwe_dword, pwe_word


def register(subparsers: Any) -> None:
    parser = command(subparsers, "write", "write a parameter value of a drive", __doc__)
    parser.add_argument(
        "parameter",
        metavar="PNU[.INDEX]",
        help="parameter number, with .INDEX for an element of an array parameter, e.g. 1120 or "
        "2010.1",
    )
    parser.add_argument(
        "value",
        metavar="VALUE",
        help="the value in the parameter's type and unit: 10, 10.5 s, 0x7000, a text",
    )
    parser.add_argument(
        "--eeprom",
        action="store_true",
        help="store the value in the drive's non-volatile memory (EEPROM) too",
    )
    parser.add_argument(
        "--raw",
        action="store_true",
        help="VALUE is the word (bit pattern) to send as it is, e.g. 0x047F; no checks",
    )
    parser.add_argument(
        "--dword", action="store_true", help="with --raw: send VALUE as a double word (32 bits)"
    )
    parser.add_argument(
        "--verify",
        action="store_true",
        help="when the answer to the write is lost, read the value back to tell whether the "
        "drive took it",
    )
    _params.add_options(parser)
    finish(parser, main)


def raw_words(text: str, size: int | None, dword: bool) -> tuple[int, ...]:
    """The words of a raw VALUE: one word, or two for a 32-bit parameter or ``--dword``."""
    try:
        value = int(text.strip().replace("_", ""), 0)
    except ValueError:
        raise ConfigError(f"--raw VALUE {text!r} is not an integer (e.g. 0x047F)") from None
    double = dword or size == 2 or (size is None and value > 0xFFFF)
    if double:
        if not -0x8000_0000 <= value <= 0xFFFF_FFFF:
            raise ConfigError(f"--raw VALUE {text!r} does not fit a double word")
        return pwe_dword(value)
    if not -0x8000 <= value <= 0xFFFF:
        raise ConfigError(f"--raw VALUE {text!r} does not fit a word (--dword for 32 bits)")
    return pwe_word(value)


async def write(args: argparse.Namespace, drive: Drive, pnu: int, index: int | None) -> Reading:
    """Parse VALUE by the parameter's type and write it (or the raw words with ``--raw``)."""
    from pyuss.params.values import parse, parse_unknown

    info = await drive.info(pnu)
    if args.raw:
        size = info.words if info is not None and not info.dtype.is_string else None
        words = raw_words(args.value, size, args.dword)
        answer = await drive.write_raw(pnu, words, index, eeprom=args.eeprom)
        return Reading(pnu, index, None, answer, words_text(answer), words)
    if args.dword:
        raise ConfigError("--dword goes with --raw; a typed value has the parameter's own size")
    value: object = (
        parse(info, args.value, index) if info is not None else parse_unknown(args.value)
    )
    return await drive.write_param(pnu, value, index, eeprom=args.eeprom)


# -- the outcome of a write whose answer was lost (--verify) ---------------------------------

ANSWERED = "answered"
READ_BACK = "read_back"


async def write_verified(
    args: argparse.Namespace, drive: Drive, pnu: int, index: int | None
) -> tuple[Reading, str]:
    """`write`; returns the reading and how it is known (`ANSWERED`, or `READ_BACK` when the
    answer was lost and ``--verify`` read the value back). Without ``--verify`` a lost answer
    raises the `JobTimeout` with a hint to use it."""
    try:
        return await write(args, drive, pnu, index), ANSWERED
    except JobTimeout as error:
        if not error.may_have_applied:
            raise
        if not args.verify:
            error.args = (f"{error.args[0]} (uss write --verify does)",)
            raise
        await read_back(drive.job, error)  # raises unless the drive holds the value
    if args.raw:
        words = await drive.read_raw(pnu, index)
        return Reading(pnu, index, None, words, words_text(words)), READ_BACK
    return await drive.read_param(pnu, index), READ_BACK


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        pnu, index = parameter(args.parameter)
        data: dict[str, Any] = {"address": args.address, "pnu": pnu, "index": index}
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            _params.setup(args, drive)
            written = await outcome(args, data, write_verified(args, drive, pnu, index))
            _params.save(args, drive)
        if written is None:
            return EXIT_FAILED
        answer, how = written
        data["outcome"] = how
        stored = " (stored in EEPROM)" if args.eeprom else ""
        if how == READ_BACK:
            stored += " (its answer was lost; read back: the drive holds it)"
        label = drive.params.label(pnu, index)
        if args.raw:
            data.update(label=label, raw=list(answer.words))
            text = f"{label} = {words_text(answer.words)}{stored}"
        else:
            data.update(answer.to_dict())
            text = answer.text() + stored
        data["eeprom"] = args.eeprom
        if not answer.differs:
            emit(args, data, text)
            return EXIT_OK
        # the drive holds another value than the one written (it limits or rounds): no
        # write done as asked, though the drive took one
        assert answer.sent is not None
        name = answer.info.name if answer.info is not None and answer.info.name else ""
        sent, held = (
            (words_text(answer.sent), words_text(answer.words))
            if args.raw
            else (answer.written_text(), format_value(answer.info, answer.value))
        )
        differs = ValueDiffers(f"{label} ({name})" if name else label, sent, held)
        data["written"] = list(answer.sent)
        data["error"] = error_dict(differs)
        emit(args, data, text)
        if not args.json:
            print(f"uss write: {differs}", file=sys.stderr)
        return EXIT_FAILED

    return run("write", args, body)
