"""What the master commands (scan, read, write, describe, mirror, run) share: options, exit
codes, and how a failure is reported.

Options of every master command: ``--port URL`` (a serial port such as ``/dev/ttyUSB0``, a
pty, ``tcp://HOST:PORT``, ``bus://HOST:PORT``; any URL `pyuss.transport.open_transport`
takes), ``--baud B``, ``--profile NAME``, ``--layout PKW,PZD``, ``--timeout S`` (per
parameter job), ``--response-delay MS``, ``--tolerance MS`` (receive tolerance for ports with
coarse timestamps) and ``--json``. Without ``--profile`` every command takes the drive as one
of unknown kind: the telegrams follow the USS specification, but no family's parameter facts,
texts or reference are applied to it (`pyuss.master.scheduler.Master` without a profile):
values travel as words, and what needs a family's facts (a setpoint in Hz, fault texts) says
so and works with what the drive gives.

Exit codes: 0 done; 1 the operation failed (no answer, drive refused, mirror changed, port
failed); 2 bad input (arguments, values, a request the layout cannot carry); 130 interrupted.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import sys
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any, TypeVar

from pyuss import system
from pyuss.cli._help import subcommand
from pyuss.cli._output import EXIT_FAILED as EXIT_FAILED
from pyuss.cli._output import EXIT_INTERRUPTED as EXIT_INTERRUPTED
from pyuss.cli._output import EXIT_OK as EXIT_OK
from pyuss.cli._output import EXIT_USAGE as EXIT_USAGE
from pyuss.cli._output import error_object, failure, print_json
from pyuss.errors import ConfigError, UssError
from pyuss.lines import ENVIRONMENT, LineFile, Target, find, is_address, load, looked_in
from pyuss.master.scheduler import Master, Mode
from pyuss.params.names import parse_param_name
from pyuss.profiles import profile_names
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import MAX_ADDRESS
from pyuss.transport.queued import BAUD_RATES, check_baud
from pyuss.transport.url import open_transport

T = TypeVar("T")


def integer(text: str) -> int:
    """An integer in decimal or with a 0x/0b/0o prefix (argparse type)."""
    try:
        return int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None


def add_options(parser: argparse.ArgumentParser, *, lists: bool = False) -> None:
    """The options every master command takes; ``lists``: ``--baud`` takes a list and
    ``--layout`` may be repeated (``uss scan``). Without ``--profile`` the drive is of unknown
    kind (``args.profile`` None; `UNNAMED_HELP`)."""
    parser.add_argument(
        "--port",
        metavar="URL",
        help="the line to the drives: a serial port (/dev/ttyUSB0, COM3), a pty (/dev/pts/7), "
        "tcp://HOST:PORT (serial-to-Ethernet converter) or bus://HOST:PORT (uss bus); "
        "adapter options in the query, e.g. /dev/ttyUSB0?rs485=rts&echo=1 (docs/transport.md); "
        "default: the line's in the configuration file",
    )
    add_line_options(parser)
    rates = ", ".join(map(str, BAUD_RATES))
    parser.set_defaults(default_baud="9600" if lists else 9600, default_profile=None)
    if lists:
        parser.add_argument(
            "--baud",
            metavar="LIST",
            help="baud rates to try, e.g. 9600,19200; auto: the usual 9600, 19200, 38400, "
            f"57600, 115200, 187500; all: {rates} (USS specification B 2.4; default 9600)",
        )
    else:
        parser.add_argument(
            "--baud",
            type=integer,
            help=f"baud rate of the line: {rates} (USS specification B 2.4; default 9600)",
        )
    parser.add_argument(
        "--profile",
        metavar="NAME",
        help="the drive family, which sets parameter numbering, response delay, error texts "
        f"and default layout: {', '.join(profile_names())}; auto: ask the drive which family "
        f"it is, one that shows none is of unknown kind (docs/drives.md; {UNNAMED_HELP})",
    )
    parser.add_argument(
        "--layout",
        action="append" if lists else "store",
        metavar="PKW,PZD",
        help="probe only with this telegram layout, e.g. 3,2 (repeatable; default: the usual "
        "fixed layouts, then the variable length)"
        if lists
        else "telegram layout as set in the drive: number of PKW words (0, 3, 4, or v for "
        "variable length) and of PZD words (0..16), e.g. 3,2 (USS specification C 7; default: "
        "the profile's)",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=2.0,
        metavar="S",
        help="give a parameter job up after S seconds without its answer (USS specification "
        "C 4.2.1.1; default 2)",
    )
    parser.add_argument(
        "--response-delay",
        type=float,
        metavar="MS",
        help="how long a drive may take to begin its answer, in ms, before it counts as not "
        "sending (USS specification A 5.2.1.1; default: the profile's, 20 ms)",
    )
    parser.add_argument(
        "--tolerance",
        type=float,
        metavar="MS",
        help="extra time in ms for ports that deliver bytes in bursts: USB adapters, ptys, TCP "
        "(default 20; 0 on bus://)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help='print JSON for scripts; failures as {"error": {...}} (docs/master.md, JSON output)',
    )


UNNAMED_HELP = (
    "default: none, a drive of unknown kind - telegrams by the USS specification, no family's "
    "parameter facts, no descriptions asked for, values as words"
)


def command(subparsers: Any, name: str, summary: str, doc: str | None) -> argparse.ArgumentParser:
    """The parser of master command ``name`` with its ``ADDRESS`` argument (all but scan);
    the caller adds its own arguments, then `finish`."""
    parser = subcommand(subparsers, name, summary, doc)
    if name != "scan":
        parser.add_argument(
            "address",
            type=drive_address,
            metavar="ADDRESS",
            help="the drive's bus address, 0..31 (USS specification A 4.3), or its name in the "
            "configuration file (docs/lines.md)",
        )
    return parser


EPILOG = """\
exit codes:
  0    done
  1    the operation failed: no answer, refused by the drive, changed mirror
       telegram, no drive found, drive fault or not stopped in time, port failed
  2    bad input (arguments, values, a request the layout cannot carry)
  130  interrupted (uss run: after switching the drive off)"""


def finish(parser: argparse.ArgumentParser, func: Callable[[argparse.Namespace], int]) -> None:
    """Add the shared options, the exit codes and the function that runs the command."""
    add_options(parser, lists=parser.prog.endswith(" scan"))
    parser.epilog = EPILOG
    name = parser.prog.rsplit(" ", 1)[-1]

    def resolved(args: argparse.Namespace) -> int:
        try:
            use_lines(args, None if name == "scan" else args.address)
        except ConfigError as exc:
            report(name, args, exc, EXIT_USAGE)
            return EXIT_USAGE
        return func(args)

    parser.set_defaults(func=resolved)


def add_line_options(parser: argparse._ActionsContainer) -> None:
    """``--config FILE`` and ``--line NAME``: the lines and drives of a configuration file
    (`pyuss.lines`)."""
    parser.add_argument(
        "--config",
        metavar="FILE",
        help=f"the configuration file of lines and drives (default: ${ENVIRONMENT}, ./uss.toml, "
        "then ~/.config/pyuss/uss.toml; docs/lines.md)",
    )
    parser.add_argument(
        "--line",
        metavar="NAME",
        help="the line of the configuration file to use: its port, baud, profile and layout "
        "(default: the drive's line, or the file's only line)",
    )


def use_lines(args: argparse.Namespace, drive: int | str | None) -> None:
    """Fill ``--port``, ``--baud``, ``--profile`` and ``--layout`` where not given from the
    configuration file's line (`pyuss.lines`), and ``args.address`` with the address of
    ``drive`` (a drive's name or number; None: the command takes no drive); then the
    defaults of the options. The file is read only when it is needed: ``--config`` or
    ``--line`` given, a drive given by name, or no ``--port``. `ConfigError` for a bad file,
    an unknown or ambiguous name, and no port at all."""
    named = isinstance(drive, str) and not is_address(drive)
    if args.config is not None or args.line is not None or named or args.port is None:
        target = find_target(args, None if drive is None else str(drive))
        if target is not None:
            if named:  # a number is checked as an address below
                args.address = target.address
            line = target.line
            scan = isinstance(args.default_baud, str)  # uss scan: lists of rates and layouts
            if line is not None:
                args.port = args.port or line.port
                if args.baud is None:
                    args.baud = str(line.baud) if scan else line.baud
            if args.profile is None:
                args.profile = target.profile
            if args.layout is None and target.layout is not None:
                args.layout = [target.layout] if scan else target.layout
    if args.port is None:
        raise ConfigError(
            "--port: give the line's port URL, or name the line in a configuration file "
            f"(none found: {looked_in()})"
        )
    if drive is not None and isinstance(args.address, str):
        try:
            args.address = address(args.address)
        except argparse.ArgumentTypeError as exc:
            raise ConfigError(str(exc)) from None
    if args.baud is None:
        args.baud = args.default_baud
    if args.profile is None:
        args.profile = args.default_profile


def names_drive(args: argparse.Namespace, word: str) -> bool:
    """Whether ``word`` is the name of a drive in the configuration file (on ``--line`` when
    given), for the commands whose first word may be a drive or something else."""
    if is_address(word):
        return False
    path = find(args.config)
    if path is None:
        return False
    lines = load(path)
    line = lines.line(args.line) if args.line is not None else None
    return bool(lines.drives_named(word, line))


def find_target(args: argparse.Namespace, drive: str | None) -> Target | None:
    """The line and drive the configuration file gives ``args`` (None: no file found, and
    none needed)."""
    lines = line_file(args, drive)
    return (
        None if lines is None else lines.target(args.line, drive, port_given=args.port is not None)
    )


def line_file(args: argparse.Namespace, drive: str | None) -> LineFile | None:
    """The configuration file (``--config``, else as `pyuss.lines.find` finds it); None when
    there is none and neither ``--line`` nor ``drive``, a name, needs one."""
    path = find(args.config)
    if path is None:
        if args.line is not None:
            raise ConfigError(f"--line {args.line}: no configuration file found ({looked_in()})")
        if drive is not None and not is_address(drive):
            raise ConfigError(
                f"{drive!r} is no address 0..{MAX_ADDRESS}, and no configuration file names "
                f"drives ({looked_in()})"
            )
        return None
    return load(path)


def address(text: str) -> int:
    """A slave address 0..31 (argparse type)."""
    value = integer(text)
    if not 0 <= value <= MAX_ADDRESS:
        raise argparse.ArgumentTypeError(f"address {value} is not 0..{MAX_ADDRESS}")
    return value


def drive_address(text: str) -> int | str:
    """A slave address 0..31, or a drive's name in the configuration file (argparse type;
    the name is looked up by `use_lines`)."""
    return address(text) if is_address(text) else text


def parameter(text: str) -> tuple[int, int | None]:
    """``PNU`` or ``PNU.INDEX`` in any spelling of `pyuss.params.names` (``r0021``, ``P1120``,
    ``21``, ``947.1``, ``r0947[1]``); `ConfigError` naming the text if it is none."""
    return parse_param_name(text)


def master_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments for `Master` from the shared options (`ConfigError` if bad); no
    ``--profile``: ``profile`` None, a drive of unknown kind."""
    options: dict[str, Any] = {"profile": args.profile, "job_timeout": args.timeout}
    # (inf is no time: a silent drive would keep the command waiting for ever)
    if not 0 < args.timeout < math.inf:
        raise ConfigError(f"--timeout {args.timeout}: must be a number of seconds > 0")
    if isinstance(args.layout, str):
        options["layout"] = Layout.parse(args.layout)
    if args.response_delay is not None:
        if not 0 < args.response_delay < math.inf:
            raise ConfigError(f"--response-delay {args.response_delay}: must be a number of ms > 0")
        options["response_delay"] = args.response_delay / 1000
    if args.tolerance is not None:
        if not 0 <= args.tolerance < math.inf:
            raise ConfigError(f"--tolerance {args.tolerance}: must be a number of ms >= 0")
        options["rx_tolerance"] = args.tolerance / 1000
    return options


def open_master(
    args: argparse.Namespace,
    *,
    mode: Mode = Mode.ACYCLIC,
    reconnect: bool = False,
    **extra: Any,
) -> contextlib.AbstractAsyncContextManager[Master]:
    """A master on ``--port`` at ``--baud``, to be entered with ``async with``; with
    ``--profile auto`` its profile is the family of the drive at ``ADDRESS``
    (`pyuss.master.identify.auto_master`); a drive that shows no family is then one of unknown
    kind, as without ``--profile``, and one line on stderr says so. ``reconnect``: a lost
    port is reopened (the long-running commands; the URL's ``reconnect=0|1`` overrides it),
    else it fails the command (the one-shot commands fail fast)."""
    check_baud(args.baud)
    coarse = system.clock_warning(args.baud)
    if coarse is not None:
        print(f"uss {args.command}: {coarse}", file=sys.stderr)
    options = master_options(args)
    options.update(extra)
    if options.get("profile") == "auto":
        from pyuss.master.identify import auto_master

        del options["profile"]
        open_transport(args.port, baud=args.baud)  # a bad URL is bad input before probing
        return auto_master(
            lambda: open_transport(args.port, baud=args.baud, reconnect=reconnect),
            args.address,
            mode=mode,
            unknown=lambda text: print(f"uss {args.command}: {text}", file=sys.stderr),
            **options,
        )
    transport = open_transport(args.port, baud=args.baud, reconnect=reconnect)
    return Master(transport, mode=mode, **options)


def error_dict(exc: BaseException) -> dict[str, Any]:
    """A failure as the JSON error object of every command (`pyuss.cli._output`)."""
    return error_object(exc, EXIT_FAILED)


async def outcome(
    args: argparse.Namespace, data: dict[str, Any], operation: Awaitable[T]
) -> T | None:
    """Await one operation of a command. Bad input (`ConfigError`) and, without ``--json``,
    any failure propagate (one line, exit code 2 or 1); with ``--json`` a failure is printed
    as ``{**data, "error": ...}`` and None returned, for the caller to exit with 1."""
    try:
        return await operation
    except ConfigError:
        raise
    except UssError as exc:
        if not args.json:
            raise
        emit(args, {**data, "error": error_dict(exc)}, "")
        return None


def emit(args: argparse.Namespace, data: Any, text: str) -> None:
    """Print ``data`` as JSON with ``--json``, else ``text``."""
    if args.json:
        print(json.dumps(data, default=str))
    elif text:
        print(text)
    sys.stdout.flush()


def run(name: str, args: argparse.Namespace, body: Callable[[], Coroutine[Any, Any, int]]) -> int:
    """Run a command's coroutine; bad input gives one line on stderr (with ``--json`` the
    JSON error object on stdout) and exit code 2. Other `UssError`s are left to ``uss`` (the
    same, with exit code 1)."""
    try:
        return asyncio.run(body())
    except ConfigError as exc:
        report(name, args, exc, EXIT_USAGE)
        return EXIT_USAGE


def report(name: str, args: argparse.Namespace, exc: BaseException, code: int) -> None:
    """A command's failure: one line on stderr, or with ``--json`` the JSON error object."""
    if getattr(args, "json", False):
        print_json(failure(name, error_object(exc, code)))
    else:
        print(f"uss {name}: {exc}", file=sys.stderr)


def fail(name: str, exc: UssError) -> None:
    print(f"uss {name}: {exc}", file=sys.stderr)
