"""Run a drive and watch it: uss run ADDRESS --setpoint PCT

Sets the main setpoint, switches the drive on and shows its state, status word and actual
value while it ramps - on one line that updates itself in a terminal, one line per
``--interval`` otherwise. Ctrl+C or SIGTERM (or the end of ``--duration``) switches it off
cleanly: OFF1, then the telegrams go on until the drive reports that operation is no longer
enabled (at most ``--stop-timeout`` seconds); a second Ctrl+C stops it at once with OFF2
(coast). Exit code 0 after ``--duration``, 130 after Ctrl+C or SIGTERM, 1 when the drive
reports a fault, gives no answer for ``--timeout`` seconds, does not stop within
``--stop-timeout``, or the port fails.

The setpoint goes into PZD2 (4000h = 100 %); on is control word 047Eh, then 047Fh, OFF1 047Eh,
OFF2 047Ch (USS specification C 5.2.1, C Tables 5.4 and 5.5).

With ``--json`` every line is one object with the same keys: ``time`` (ISO 8601 wall clock of
the answer shown), ``address``, ``setpoint``, ``state``, ``status``, ``status_hex``, ``actual``,
``actual_percent``, ``control`` (null before the first answer) and ``error`` (null, or the
error object of a failure, on one more line when it happens).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import signal
import sys
from typing import Any

from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    command,
    finish,
    open_master,
    run,
)
from pyuss.cli._output import error_object, wall_clock
from pyuss.errors import ConfigError, UssError
from pyuss.master.drive import Drive
from pyuss.master.errors import DriveFault
from pyuss.master.process import DriveStatus
from pyuss.master.scheduler import CYCLIC
from pyuss.protocol.pzd import percent_to_raw16


def register(subparsers: Any) -> None:
    parser = command(
        subparsers,
        "run",
        "switch a drive on, follow its ramp live, switch it off on Ctrl+C",
        __doc__,
    )
    parser.add_argument(
        "--setpoint",
        type=float,
        required=True,
        metavar="PCT",
        help="main setpoint in percent of the reference value, -200..199.99 (PZD2, 4000h = 100 %%; "
        "USS specification C 5.2.2)",
    )
    parser.add_argument(
        "--duration",
        type=float,
        metavar="S",
        help="switch the drive off after S seconds (default: run until Ctrl+C)",
    )
    parser.add_argument(
        "--stop-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="after OFF1, wait at most S seconds for the drive to report that it stopped "
        "(status bit 2 clear, USS specification C Table 5.5; default 30)",
    )
    parser.add_argument(
        "--interval",
        type=float,
        metavar="S",
        help="seconds between status lines (default 0.1 in a terminal, 1 otherwise)",
    )
    finish(parser, main)


def line(status: DriveStatus | None, setpoint: float) -> str:
    if status is None:
        return "waiting for the drive..."
    actual = status.actual_percent
    shown = "-" if actual is None else f"{actual:7.2f} %"
    return (
        f"{status.state:<24} status {status.word:04X}h  setpoint {setpoint:7.2f} %  actual {shown}"
    )


_KEYS = (
    "time", "address", "setpoint", "state", "status", "status_hex", "actual",
    "actual_percent", "control", "error",
)  # fmt: skip


def record(
    args: argparse.Namespace, status: DriveStatus | None, error: dict[str, Any] | None = None
) -> dict[str, Any]:
    """A JSON line: the same keys whatever is known (module docstring)."""
    return {
        "time": wall_clock(None if status is None else status.time),
        "address": args.address,
        "setpoint": args.setpoint,
        "state": None if status is None else status.state,
        "status": None if status is None else status.word,
        "status_hex": None if status is None else f"{status.word:04X}",
        "actual": None if status is None else list(status.actual),
        "actual_percent": None if status is None else status.actual_percent,
        "control": None if status is None else status.control,
        "error": error,
    }


def json_error_line(error: dict[str, Any]) -> dict[str, Any]:
    """A failure before anything is known of the drive, as a line of the stream."""
    line = dict.fromkeys(_KEYS)
    line.update(time=wall_clock(), error=error)
    return line


class Live:
    """Shows the drive's latest status now and then."""

    def __init__(self, args: argparse.Namespace, drive: Drive) -> None:
        self.args = args
        self.drive = drive
        self.tty = sys.stdout.isatty() and not args.json
        self.interval = args.interval or (0.1 if self.tty else 1.0)

    def show(self, final: bool = False) -> None:
        try:
            self._show(final)
        except BrokenPipeError:  # the reader went away (``| head``): stop showing, keep going
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            os.close(devnull)

    def record(self, error: dict[str, Any] | None = None) -> dict[str, Any]:
        return record(self.args, self.drive.status, error)

    def fail(self, exc: UssError) -> None:
        """Report a failure: a line on stderr, or with ``--json`` one more line with its
        error object."""
        if self.args.json:
            with contextlib.suppress(BrokenPipeError):
                print(json.dumps(self.record(error_object(exc, EXIT_FAILED))), flush=True)
        else:
            print(f"\nuss run: {exc}", file=sys.stderr)

    def _show(self, final: bool) -> None:
        status = self.drive.status
        if self.args.json:
            print(json.dumps(self.record()), flush=True)
        elif self.tty:
            end = "\n" if final else ""
            print("\r" + line(status, self.args.setpoint), end=end, flush=True)
        else:
            print(line(status, self.args.setpoint), flush=True)

    async def follow(self, done: asyncio.Event) -> None:
        while not done.is_set():
            self.show()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.interval):
                    await done.wait()


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        if args.duration is not None and not args.duration > 0:
            raise ConfigError(f"--duration {args.duration}: must be > 0 seconds")
        if not args.stop_timeout > 0:
            raise ConfigError(f"--stop-timeout {args.stop_timeout}: must be > 0 seconds")
        if args.interval is not None and not args.interval > 0:
            raise ConfigError(f"--interval {args.interval}: must be > 0 seconds")
        percent_to_raw16(args.setpoint)  # a setpoint out of range is bad input
        loop = asyncio.get_running_loop()
        stop = asyncio.Event()
        signals: list[int] = []

        def on_signal(number: int) -> None:
            signals.append(number)
            stop.set()

        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, on_signal, sig)
        try:
            return await drive_it(args, stop, signals)
        finally:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.remove_signal_handler(sig)

    return run("run", args, body)


async def drive_it(args: argparse.Namespace, stop: asyncio.Event, signals: list[int]) -> int:
    code = EXIT_OK
    async with open_master(args, mode=CYCLIC) as bus:
        drive = bus.drive(args.address)
        if drive.layout.pzd < 2:
            raise ConfigError(
                f"layout {drive.layout}: running a drive needs PZD1 (control word) and PZD2 "
                "(main setpoint), give --layout with 2 or more PZD words (C 5)"
            )
        live = Live(args, drive)
        shown = asyncio.Event()
        follower = asyncio.create_task(live.follow(shown))
        try:
            await drive.setpoint(args.setpoint)
            await drive.on()
            watcher = asyncio.create_task(watch(drive, args.timeout))
            stopper = asyncio.create_task(stop.wait())
            done, pending = await asyncio.wait(
                {watcher, stopper}, timeout=args.duration, return_when=asyncio.FIRST_COMPLETED
            )
            for task in pending:
                task.cancel()
            if watcher in done:
                # raises when the drive stopped answering or the port failed
                live.fail(DriveFault(watcher.result()))
                code = EXIT_FAILED
            await switch_off(args, drive, stop, signals)
        except ConfigError:
            raise
        except UssError as exc:
            live.fail(exc)
            code = EXIT_FAILED
            with contextlib.suppress(UssError):
                await drive.off1(timeout=1.0)
        finally:
            shown.set()
            await follower
            live.show(final=True)
    if signals and code == EXIT_OK:
        return EXIT_INTERRUPTED
    return code


async def watch(drive: Drive, timeout: float) -> DriveStatus:
    """Return the first status that reports a fault; raise `NotSending` when the drive gave no
    answer for ``timeout`` seconds, the transport's error when the port failed."""
    while not (status := await drive.next_update(timeout=timeout)).fault:
        pass
    return status


async def switch_off(
    args: argparse.Namespace, drive: Drive, stop: asyncio.Event, signals: list[int]
) -> None:
    """OFF1 and wait for the drive to stop; a second signal - or any signal once stopping
    began - coasts it down at once (OFF2)."""
    count = len(signals)
    if count < 2:
        await drive.off1()
    if len(signals) >= 2 or len(signals) > count:  # also one that came while OFF1 was sent
        await drive.off2()
        return
    stop.clear()

    async def stopped() -> None:
        await drive.wait_until(
            lambda s: not s.running,
            timeout=args.stop_timeout,
            what="the stopped state after OFF1 (status bit 2 'operation enabled' clear, "
            "C Table 5.5)",
        )

    task = asyncio.create_task(stopped())
    again = asyncio.create_task(stop.wait())
    done, _ = await asyncio.wait({task, again}, return_when=asyncio.FIRST_COMPLETED)
    if again in done and len(signals) > count:
        task.cancel()
        await drive.off2()
        return
    again.cancel()
    await task
