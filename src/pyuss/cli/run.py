"""``uss run ADDRESS --setpoint VALUE`` / ``--jog 1|2``: run a drive and follow it live.

Sets the main setpoint (PZD2, 4000h = 100 %): ``50`` or ``50 %`` in percent, ``25 Hz`` or
``1500 rpm`` where the profile names the reference parameter that is 100 % (P2000 of a
MICROMASTER 4, read from the drive), and switches the drive on (control word 047Eh, then
047Fh); or, with ``--jog 1`` or ``--jog 2``, switches it on at setpoint 0 and jogs it (control
bit 8 or 9 while operation is enabled, C Table 5.4) at the drive's own jog setpoint. It
shows its state, status word and actual value (in the reference's unit too) while it ramps -
on one line that updates itself in a terminal, one line per ``--interval`` otherwise, JSON
lines with ``--json``. Ctrl+C or SIGTERM (or the end of ``--duration``) switches it off
cleanly: OFF1 (047Eh), then the master keeps the telegrams going until the drive reports that
operation is no longer enabled (at most ``--stop-timeout`` seconds); a second Ctrl+C stops at
once with OFF2 (coast). Exit code 0 after ``--duration``, 130 after Ctrl+C or SIGTERM, 1 when
the drive reports a fault, gives no answer for ``--timeout`` seconds, or the port fails.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import re
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
from pyuss.commission.status import reference_value
from pyuss.errors import ConfigError, UssError
from pyuss.master.drive import Drive
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
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument(
        "--setpoint",
        metavar="VALUE",
        help="main setpoint: percent (50, 50 %%), or Hz/rpm where the profile names the "
        "reference parameter (25 Hz)",
    )
    what.add_argument(
        "--jog",
        type=int,
        choices=(1, 2),
        help="jog 1 or 2 (control bit 8 or 9) at the drive's jog setpoint instead",
    )
    parser.add_argument("--duration", type=float, metavar="S", help="switch off after S seconds")
    parser.add_argument(
        "--stop-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="longest wait for the drive to stop after OFF1 (default 30)",
    )
    parser.add_argument(
        "--interval", type=float, metavar="S", help="seconds between lines (default 0.1 / 1)"
    )
    finish(parser, main)


Reference = tuple[float, str] | None
"""The reference parameter's value and unit (100 % = 4000h), where the profile names one."""


def setpoint_percent(text: str, reference: Reference, profile: str) -> float:
    """A ``--setpoint`` in percent: ``50`` / ``50 %`` as they are, ``25 Hz`` through the
    reference parameter."""
    match = re.fullmatch(r"\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S*)\s*", text)
    if match is None:
        raise ConfigError(f"--setpoint {text!r}: give a number, with % or the reference's unit")
    value, unit = float(match.group(1)), match.group(2)
    if unit in ("", "%"):
        percent = value
    elif reference is not None and unit.casefold() == reference[1].casefold():
        if not reference[0]:
            raise ConfigError(f"--setpoint {text!r}: the drive's reference is 0 {reference[1]}")
        percent = value / reference[0] * 100.0
    else:
        where = (
            f"the reference parameter is in {reference[1]}"
            if reference is not None
            else f"profile {profile} names no reference parameter with a unit"
        )
        raise ConfigError(f"--setpoint {text!r}: {where}; give percent or that unit")
    percent_to_raw16(percent)  # out of range: bad input
    return percent


def line(status: DriveStatus | None, setpoint: float | str, reference: Reference = None) -> str:
    """``operation enabled  status 0237h  setpoint  50.00 % (25.00 Hz)  actual ...``."""
    if status is None:
        return "waiting for the drive..."

    def shown(percent: float) -> str:
        text = f"{percent:7.2f} %"
        if reference is not None:
            text += f" ({percent / 100 * reference[0]:.2f} {reference[1]})"
        return text

    actual = status.actual_percent
    target = setpoint if isinstance(setpoint, str) else shown(setpoint)
    now = "-" if actual is None else shown(actual)
    return f"{status.state:<24} status {status.word:04X}h  setpoint {target}  actual {now}"


class Live:
    """Shows the drive's latest status now and then."""

    def __init__(self, args: argparse.Namespace, drive: Drive) -> None:
        self.args = args
        self.drive = drive
        self.setpoint: float | str = f"jog {args.jog}" if args.jog else 0.0
        self.reference: Reference = None
        self.tty = sys.stdout.isatty() and not args.json
        self.interval = args.interval or (0.1 if self.tty else 1.0)

    def show(self, final: bool = False) -> None:
        try:
            self._show(final)
        except BrokenPipeError:  # the reader went away (``| head``): stop showing, keep going
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            os.close(devnull)

    def _show(self, final: bool) -> None:
        status = self.drive.status
        if self.args.json:
            data: dict[str, Any] = {
                "setpoint": self.setpoint,
                **(status.to_dict() if status else {}),
            }
            if self.reference is not None and status is not None:
                percent = status.actual_percent
                data["actual"] = None if percent is None else percent / 100 * self.reference[0]
                data["unit"] = self.reference[1]
            print(json.dumps(data), flush=True)
        elif self.tty:
            end = "\n" if final else ""
            print("\r" + line(status, self.setpoint, self.reference), end=end, flush=True)
        else:
            print(line(status, self.setpoint, self.reference), flush=True)

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
        if args.setpoint is not None and not re.search(r"[A-Za-z]", args.setpoint):
            setpoint_percent(args.setpoint, None, args.profile)  # bad input before the port opens
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
        live.reference = await reference_value(drive)
        if args.setpoint is not None:
            live.setpoint = setpoint_percent(args.setpoint, live.reference, drive.profile.name)
        shown = asyncio.Event()
        follower = asyncio.create_task(live.follow(shown))
        try:
            if args.jog:
                # C Table 5.4: jog bits act while operation is enabled and the drive stands
                # with setpoint 0: switch on at 0 %, then jog.
                await drive.setpoint(0.0)
                await drive.on()
                await drive.jog(args.jog)
            else:
                assert isinstance(live.setpoint, float)
                await drive.setpoint(live.setpoint)
                await drive.on()
            watcher = asyncio.create_task(watch(drive, args.timeout))
            stopper = asyncio.create_task(stop.wait())
            done, pending = await asyncio.wait(
                {watcher, stopper}, timeout=args.duration, return_when=asyncio.FIRST_COMPLETED
            )
            for task in pending:
                task.cancel()
            if watcher in done:
                watcher.result()  # raises when the drive stopped answering or the port failed
                code = EXIT_FAILED
                print(f"\nuss run: drive {args.address} reports a fault", file=sys.stderr)
            await switch_off(args, drive, stop, signals)
        except ConfigError:
            raise
        except UssError as exc:
            print(f"\nuss run: {exc}", file=sys.stderr)
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


async def watch(drive: Drive, timeout: float) -> None:
    """Return when the drive reports a fault; raise `NotSending` when it gave no answer for
    ``timeout`` seconds, the transport's error when the port failed."""
    while not (await drive.next_update(timeout=timeout)).fault:
        pass


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
        await drive.wait_until(lambda s: not s.running, timeout=args.stop_timeout)

    task = asyncio.create_task(stopped())
    again = asyncio.create_task(stop.wait())
    done, _ = await asyncio.wait({task, again}, return_when=asyncio.FIRST_COMPLETED)
    if again in done and len(signals) > count:
        task.cancel()
        await drive.off2()
        return
    again.cancel()
    await task
