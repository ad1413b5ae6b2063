"""Run a drive and watch it: uss run ADDRESS --setpoint VALUE, or --jog 1|2

Sets the main setpoint - 50 or 50 % in percent, 25 Hz or 1500 rpm where the profile names the
reference parameter that is 100 % (P2000 of a MICROMASTER 4, read from the drive; a drive of
unknown kind, without ``--profile``, takes and shows percent) - and switches the drive on;
or, with ``--jog 1`` or ``--jog 2``, jogs it at the drive's own jog setpoint: a drive of the
USS specification's profile (or of unknown kind) is switched on at setpoint 0 and then jogs,
a MICROMASTER 4 or SINAMICS (whose jog bits switch it on) jogs from standstill with
ON/OFF1 = 0 (057Eh for jog 1). It shows its state, status word and actual value (in
the reference's unit too) while it ramps - on one line that updates itself in a terminal, one
line per ``--interval`` otherwise. Ctrl+C or SIGTERM (or the end of ``--duration``) switches it
off cleanly: OFF1, then the telegrams go on until the drive reports that operation is no longer
enabled (at most ``--stop-timeout`` seconds); a second Ctrl+C stops it at once with OFF2
(coast). Exit code 0 after ``--duration``, 130 after Ctrl+C or SIGTERM, 1 when the drive
reports a fault, gives no answer for ``--timeout`` seconds, does not stop within
``--stop-timeout``, or the port fails.

First the drive's command and setpoint sources are read where its family's file names them
(SINAMICS, MICROMASTER 420/440: P0700 and P1000): a drive that takes its control word or its
setpoint from elsewhere than USS would ignore the run, so it is refused with exit code 1, the
message naming the parameter, its value and the value to set ("the drive ignores the control
word: P0700.0 = 1 (operator panel), set P0700.0 = 5 for USS"), and nothing is sent to the
control word or the setpoint.

A lost port or connection is reopened (the first try at once, then after 0.5 s, the wait
doubling up to 10 s); nothing is sent meanwhile. The run goes on only if the line is back
before ``--timeout`` passes without an answer - a gap in the run the person watches -, else it
ends as for a drive that does not answer (exit code 1): the drive is not commanded again when
the line returns. ``?reconnect=0`` in the port's URL makes a lost port end the run at once.

The setpoint goes into PZD2 (4000h = 100 %); on is control word 047Eh, then 047Fh, OFF1 047Eh,
OFF2 047Ch, jog control bit 8 or 9 while operation is enabled (USS specification C 5.2.1,
C Tables 5.4 and 5.5), or with ON/OFF1 = 0 where the family's jog switches the drive on.

With ``--json`` every line is one object with the same keys: ``time`` (ISO 8601 wall clock of
the answer shown), ``address``, ``setpoint`` (percent, or ``jog N``), ``state``, ``status``,
``status_hex``, ``actual`` (in ``unit``: the reference's, else %), ``unit``, ``actual_percent``,
``actual_raw`` (the PZD words), ``control`` (null before the first answer) and ``error`` (null,
or the error object of a failure, on one more line when it happens).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import re
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
from pyuss.commission.sources import refuse_unless_uss
from pyuss.commission.status import reference_value
from pyuss.errors import ConfigError, UssError
from pyuss.master.drive import Drive
from pyuss.master.errors import DriveFault
from pyuss.master.process import DriveStatus
from pyuss.master.scheduler import CYCLIC
from pyuss.points import checked_setpoint
from pyuss.points.checks import DECIMAL, NOT_FINITE
from pyuss.system import stop_on_signals


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
        help="main setpoint: percent, -200..199.99 (50, 50 %%), or Hz/rpm where the profile "
        "names the reference parameter (25 Hz) (PZD2, 4000h = 100 %%; USS specification "
        "C 5.2.2)",
    )
    what.add_argument(
        "--jog",
        type=int,
        choices=(1, 2),
        help="jog 1 or 2 at the drive's own jog setpoint instead (control bit 8 or 9, USS "
        "specification C Table 5.4; a MICROMASTER 4 or SINAMICS jogs from standstill with "
        "ON/OFF1 = 0)",
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


Reference = tuple[float, str] | None
"""The reference parameter's value and unit (100 % = 4000h), where the profile names one."""


def split_setpoint(text: str) -> tuple[str, str]:
    """A ``--setpoint``'s number and unit (``%`` when none): ``25 Hz``, ``1500 1/min``, in ASCII
    digits; inf and nan go on to the model's check of a setpoint, which refuses them by name;
    anything else (``50 %%``, ``1_0``, a word) is no number (`ConfigError`)."""
    match = re.fullmatch(
        rf"\s*({DECIMAL})\s*(%|[a-z]\S*|1/\S+)?\s*", text, re.ASCII | re.IGNORECASE
    )
    if match:
        return match.group(1), match.group(2) or "%"
    if text.strip().lower().lstrip("+-") in NOT_FINITE:
        return text, "%"
    raise ConfigError(f"--setpoint {text[:40]!r}: setpoint {text[:40]!r} is not a number")


def setpoint_percent(text: str, reference: Reference, profile: str | None) -> float:
    """A ``--setpoint`` in percent: ``50`` / ``50 %`` as they are, ``25 Hz`` through the
    reference parameter; checked by the drive model's one check of a setpoint
    (`pyuss.points.checked_setpoint`: finite, within the word's range), as sent."""
    value, unit = split_setpoint(text)
    if unit != "%" and (reference is None or unit.casefold() != reference[1].casefold()):
        where = (
            f"the reference parameter is in {reference[1]}"
            if reference is not None
            else f"profile {profile} names no reference parameter with a unit"
            if profile is not None
            else "the drive is of unknown kind (no --profile), so its reference parameter (100 %) "
            "is not known"
        )
        raise ConfigError(f"--setpoint {text!r}: {where}; give percent or that unit")
    try:
        checked = checked_setpoint(
            value,
            "percent" if unit == "%" else "value",
            reference=None if reference is None else reference[0],
            unit="%" if reference is None else reference[1],
            where="the drive",
        )
    except ConfigError as exc:
        raise ConfigError(f"--setpoint {text[:40]!r}: {exc}") from None
    return checked.percent


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


_KEYS = (
    "time", "address", "setpoint", "state", "status", "status_hex", "actual", "unit",
    "actual_percent", "actual_raw", "control", "error",
)  # fmt: skip


def record(
    address: int,
    setpoint: float | str,
    status: DriveStatus | None,
    reference: Reference = None,
    error: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """A JSON line: the same keys whatever is known (module docstring)."""
    line = json_error_line(error)
    line.update(address=address, setpoint=setpoint)
    if status is None:
        return line
    percent = status.actual_percent
    line.update(
        time=wall_clock(status.time),
        state=status.state,
        status=status.word,
        status_hex=f"{status.word:04X}",
        actual=percent if reference is None or percent is None else percent / 100 * reference[0],
        unit="%" if reference is None else reference[1],
        actual_percent=percent,
        actual_raw=list(status.actual),
        control=status.control,
    )
    return line


def json_error_line(error: dict[str, Any] | None) -> dict[str, Any]:
    """A line of the stream with nothing known of the drive (a failure before the first)."""
    line: dict[str, Any] = dict.fromkeys(_KEYS)
    line.update(time=wall_clock(), error=error)
    return line


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

    def record(self, error: dict[str, Any] | None = None) -> dict[str, Any]:
        return record(self.drive.address, self.setpoint, self.drive.status, self.reference, error)

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
        if args.setpoint is not None and split_setpoint(args.setpoint)[1] == "%":
            setpoint_percent(args.setpoint, None, args.profile)  # bad input before the port opens
        signals: list[int] = []
        with stop_on_signals(signals.append) as stop:
            return await drive_it(args, stop, signals)

    return run("run", args, body)


async def drive_it(args: argparse.Namespace, stop: asyncio.Event, signals: list[int]) -> int:
    code = EXIT_OK
    async with open_master(args, mode=CYCLIC, reconnect=True) as bus:
        drive = bus.drive(args.address)
        if drive.layout.pzd < 2:
            raise ConfigError(
                f"layout {drive.layout}: running a drive needs PZD1 (control word) and PZD2 "
                "(main setpoint), give --layout with 2 or more PZD words (C 5)"
            )
        await refuse_unless_uss(drive, timeout=args.timeout)  # a refusal sends nothing
        live = Live(args, drive)
        live.reference = await reference_value(drive)
        if args.setpoint is not None:
            live.setpoint = setpoint_percent(
                args.setpoint, live.reference, drive.profile.name if drive.profile_named else None
            )
        shown = asyncio.Event()
        follower = asyncio.create_task(live.follow(shown))
        try:
            if args.jog:
                # C Table 5.4: jog bits act while operation is enabled and the drive stands
                # with setpoint 0: switch on at 0 %, then jog. A family whose jog switches
                # the drive on jogs from standstill with ON/OFF1 = 0 and ignores jog bits
                # while switched on.
                await drive.setpoint(0.0)
                if not (drive.profile_named and drive.profile.database().words.jog_switches_on):
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
