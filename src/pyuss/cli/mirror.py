"""Check the line to a drive: send mirror telegrams, which the drive returns unchanged.
uss mirror ADDRESS

Each try prints the response time (end of the request to the start of the answer) and the
round trip. Exit code 1 when a try got no answer or a changed one.

A mirror telegram has bit 6 of ADR set (USS specification A 5.3).
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
    integer,
    open_master,
    run,
)
from pyuss.errors import ConfigError, UssError


def register(subparsers: Any) -> None:
    parser = command(
        subparsers, "mirror", "send mirror telegrams and check they come back unchanged", __doc__
    )
    parser.add_argument(
        "--count", type=integer, default=1, metavar="N", help="send N telegrams (default 1)"
    )
    parser.add_argument(
        "--data",
        metavar="HEX",
        help="net data to send, in hex (default: a test pattern of the drive's telegram length)",
    )
    finish(parser, main)


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        if not 1 <= args.count <= 100000:
            raise ConfigError(f"--count {args.count}: give 1..100000")
        data = None
        if args.data is not None:
            try:
                data = bytes.fromhex(args.data)
            except ValueError:
                raise ConfigError(f"--data {args.data!r} is not hex") from None
        tries: list[dict[str, Any]] = []
        async with open_master(args) as bus:
            bus.drive(args.address, poll=False)
            for n in range(1, args.count + 1):
                try:
                    result = await bus.mirror(args.address, data)
                except ConfigError:
                    raise
                except UssError as exc:
                    tries.append({"ok": False, "error": error_dict(exc)})
                    if not args.json:
                        print(f"mirror {n}: {exc}", file=sys.stderr)
                    continue
                # 0 or less: not measured (an answer read sooner than a line brings it, over
                # a pty or a socket); a slave keeps the start pause first (A 5.2.1.1)
                measured = result.response_time if result.response_time > 0 else None
                tries.append(
                    {
                        "ok": True,
                        "response_time": measured,
                        "round_trip": result.round_trip,
                        "sent": result.sent.hex(" ").upper(),
                    }
                )
                if not args.json:
                    response = "-" if measured is None else f"{measured * 1000:.2f} ms"
                    print(
                        f"mirror {n}: ok, {len(result.sent)} bytes, response {response}, "
                        f"round trip {result.round_trip * 1000:.2f} ms"
                    )
        good = sum(1 for t in tries if t["ok"])
        emit(
            args,
            {"address": args.address, "tries": tries},
            f"{good} of {len(tries)} came back unchanged",
        )
        return EXIT_OK if good == len(tries) else EXIT_FAILED

    return run("mirror", args, body)
