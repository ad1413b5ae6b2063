"""Read parameter values from a drive: uss read ADDRESS PNU[.INDEX] ...

Each value prints as the drive engineer reads it: ``P1120 = 10.00 s (Ramp-up time)``, typed and
scaled by what is known of the parameter (``--params FILE``, the drive's own description (USS
specification C 6), the profile's parameter file). An array parameter without index is read
whole, in one telegram (IND 255) where the drive allows it, else element by element with a
progress line (C 4.2.2); ``P947.3`` reads one element. Numbers from 2000 on are given as they
are (``P2010.1``): the profile puts them into the IND page bits. ``--raw`` prints the words as
they travelled; ``--json`` gives value, raw words, unit, name and type of each. A parameter the
drive refuses prints its error number and meaning and the others are still read; the exit code
is then 1.

Without ``--profile`` the drive is taken as one of unknown kind: no family's parameter file
applies, a value prints as the word or double word it travelled as (``P150 = 1200 (04B0h)``)
unless ``--params FILE`` knows more, and descriptions are asked for only with
``--describe always`` (a drive that refuses one or does not answer it is asked no more).
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
    parameter,
    run,
)
from pyuss.errors import ConfigError, UssError
from pyuss.params.values import words_text
from pyuss.params.words import reading_text, word_of


def register(subparsers: Any) -> None:
    parser = command(subparsers, "read", "read parameter values from a drive", __doc__)
    parser.add_argument(
        "parameters",
        nargs="+",
        metavar="PNU[.INDEX]",
        help="parameter number, with .INDEX for one element of an array parameter, e.g. 1120, "
        "947 (the whole array), 2010.1",
    )
    parser.add_argument(
        "--raw",
        action="store_true",
        help="print the words as the drive sent them (PWE, USS specification C 4.2.3)",
    )
    _params.add_options(parser)
    finish(parser, main)


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        wanted = [parameter(text) for text in args.parameters]
        results: list[dict[str, Any]] = []
        failed = False
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            _params.setup(args, drive)
            family = drive.profile if drive.profile_named else None
            for pnu, index in wanted:
                label = drive.params.label(pnu, index)
                progress = _params.Progress(label, enabled=None if not args.json else False)
                try:
                    if args.raw:
                        info = drive.params.get(pnu)
                        whole = index is None and info is not None and info.is_array
                        words = await drive.read_raw(pnu, 255 if whole else index)
                        reading = None
                    else:
                        reading = await drive.read_param(pnu, index, progress=progress)
                        words = reading.words
                except ConfigError:
                    raise
                except UssError as exc:
                    failed = True
                    results.append(
                        {"pnu": pnu, "index": index, "label": label} | {"error": error_dict(exc)}
                    )
                    if not args.json:
                        print(f"{label}: {exc}", file=sys.stderr)
                    continue
                finally:
                    progress.close()
                if reading is None:
                    results.append(
                        {
                            "pnu": pnu,
                            "index": index,
                            "label": label,
                            "raw": list(words),
                        }
                    )
                    text = f"{label} = {words_text(words)}"
                else:
                    result = reading.to_dict()
                    if (word := word_of(reading, family)) is not None:
                        result["word"] = word.to_dict()
                    results.append(result)
                    text = reading_text(reading, family)
                if not args.json:
                    print(text)
            _params.save(args, drive)
        if args.json:
            emit(args, {"address": args.address, "parameters": results}, "")
        return EXIT_FAILED if failed else EXIT_OK

    return run("read", args, body)
