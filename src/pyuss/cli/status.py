"""Take one look at a drive - state, status bits, values - without switching it: uss status
ADDRESS

One telegram for the process data (C 5): the drive's state from its status word, each status
bit with its meaning, the main actual value (PZD2) in percent and, where the profile names the
reference parameter, in its unit (Hz, rpm); then the parameters the profile names for state,
actual value, setpoint, fault and warning, with units, and fault and warning numbers with the
profile's text where it has one. Without ``--profile`` the drive is of unknown kind: the state,
the status bits by the USS specification and the actual value in percent, and a line saying
that its parameters, texts and reference are not known (no family's are put in their place).
Nothing is switched: the control word stays as it is.
"""

from __future__ import annotations

import argparse
from typing import Any

from pyuss.cli import _params
from pyuss.cli._master import EXIT_OK, command, emit, finish, open_master, run
from pyuss.commission.status import look


def register(subparsers: Any) -> None:
    parser = command(subparsers, "status", "show a drive's state, status word and values", __doc__)
    _params.add_options(parser)
    finish(parser, main)


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            _params.setup(args, drive)
            seen = await look(drive, timeout=args.timeout)
            _params.save(args, drive)
        emit(args, seen.to_dict(), "\n".join(seen.lines()))
        return EXIT_OK

    return run("status", args, body)
