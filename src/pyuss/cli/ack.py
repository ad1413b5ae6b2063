"""Acknowledge a drive's fault: uss ack ADDRESS

A rising edge of control word bit 7 (C Table 5.4): the word with bit 7 set, then cleared, each
answered by the drive. Prints the state the drive reports afterwards: "acknowledged" when it
reported a fault before and none after, "no fault to acknowledge" when it reported none before
either. A drive that still reports a fault (its cause is still there) gives exit code 1.
"""

from __future__ import annotations

import argparse
from typing import Any

from pyuss.cli._master import EXIT_FAILED, EXIT_OK, command, emit, finish, open_master, run
from pyuss.errors import ConfigError


def register(subparsers: Any) -> None:
    parser = command(subparsers, "ack", "acknowledge a drive's fault", __doc__)
    finish(parser, main)


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            if drive.layout.pzd < 1:
                raise ConfigError(
                    f"layout {drive.layout}: acknowledging needs the control word (PZD1, C 5)"
                )
            before = await drive.next_update(timeout=args.timeout)
            status = await drive.acknowledge(timeout=args.timeout)
            status = await drive.next_update(timeout=args.timeout)
        data = {
            "address": args.address,
            "fault_before": before.fault,
            "fault": status.fault,
            "state": status.state,
            "status": status.word,
            "status_hex": f"{status.word:04X}",
        }
        # what the drive's answers say: a fault before and none after is acknowledged
        if status.fault:
            verdict = "still in fault" if before.fault else "in fault"
        else:
            verdict = "acknowledged" if before.fault else "no fault to acknowledge"
        emit(
            args,
            data,
            f"drive {args.address}: {verdict}: {status.state} (status word {status.word:04X}h)",
        )
        return EXIT_FAILED if status.fault else EXIT_OK

    return run("ack", args, body)
