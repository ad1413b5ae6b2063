"""Talk to a PMA KS VARIO controller over PROFIBUS-DP through its parameter channel, or
simulate one (KS VARIO PROFIBUS-DP interface description).

    uss ksvario simulate [--pty | --port URL] [--station N]   serve a simulated coupler
    uss ksvario read ADDRESS [COUNT] --port DEV [--station N]  parameter channel read
    uss ksvario write ADDRESS VALUE... --port DEV               parameter channel write
    uss ksvario gsd [--output FILE]                             the device's GSD file
    uss ksvario address ADDRESS                                 decode an address word

``read``/``write`` bring the station into data exchange with a small DP master of their own,
then run the job through module A.1 (the parameter channel); ``--sim`` runs them against
an in-process simulated coupler instead of a line.
"""

from __future__ import annotations

import argparse
import asyncio
import sys

from pyuss.atomicfile import write_atomically
from pyuss.cli._help import actions, subcommand
from pyuss.errors import ConfigError, UssError
from pyuss.ksvario.address import Address, View, parse_address
from pyuss.ksvario.channel import ByteOrder, DataFormat, Value, encode_value
from pyuss.ksvario.coupler import CacheSelection, Coupler
from pyuss.ksvario.dp.fdl import LINE_BAUD_RATES, check_baud
from pyuss.ksvario.dp.master import DpMasterLink
from pyuss.ksvario.gsd import emit_gsd
from pyuss.ksvario.master import KsVarioMaster, LocalLink, default_format
from pyuss.ksvario.modules import Configuration, parse_modules
from pyuss.ksvario.simulate import dp_line, serve
from pyuss.ksvario.userprm import UserParameters
from pyuss.system import stop_on_signals

_KINDS = {
    DataFormat.INTEGER: "an integer",
    DataFormat.REAL: "a real number",
    DataFormat.REAL3: "a real number",
    DataFormat.CHAR: "a character",
    DataFormat.COMPACT_CHAR: "a text",
}

_FORMATS = {
    "int": DataFormat.INTEGER,
    "real": DataFormat.REAL,
    "real3": DataFormat.REAL3,
    "char": DataFormat.CHAR,
    "compact": DataFormat.COMPACT_CHAR,
}

_BAUD_HELP = (
    f"PROFIBUS-DP baud rate of the line: {', '.join(map(str, LINE_BAUD_RATES))} (default 19200; "
    "a pty has none)"
)


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = subcommand(
        subparsers,
        "ksvario",
        "PMA KS VARIO over PROFIBUS-DP: read, write, simulate, GSD file",
        __doc__,
    )
    sub = actions(p, "ksvario_command")

    sim = sub.add_parser(
        "simulate", help="simulate a KS VARIO bus coupler as a DP slave, until stopped"
    )
    sim.add_argument(
        "--pty",
        action="store_true",
        help="serve on a new pseudo-terminal, whose path is printed first (the default)",
    )
    sim.add_argument(
        "--port",
        help="serve on this serial port, pyserial URL or tcp-listen://HOST:PORT (port 0: a "
        "free one; the first line printed names it) instead of a pty",
    )
    sim.add_argument(
        "--station", type=int, default=5, help="its PROFIBUS-DP station address, 0..125 (default 5)"
    )
    sim.add_argument("--baud", type=int, default=19200, help=_BAUD_HELP)
    sim.add_argument(
        "--channels",
        type=int,
        default=30,
        help="how many controller channels it has, 1..30 (default 30)",
    )
    sim.set_defaults(func=_simulate)

    for name, helptext in (
        ("read", "read values of a KS VARIO through its parameter channel"),
        ("write", "write values of a KS VARIO through its parameter channel"),
    ):
        q = sub.add_parser(name, help=helptext)
        q.add_argument(
            "address",
            help="the address of the value: 0x4496, 4496h, 17558 or VIEW:AREA:DATUM, e.g. "
            "fix1:ch1:0x96 (uss ksvario address explains one)",
        )
        if name == "read":
            q.add_argument(
                "count", nargs="?", type=int, default=1, help="how many values (default 1)"
            )
        else:
            q.add_argument("values", nargs="+", help="the values to write, in address order")
        q.add_argument(
            "--format",
            choices=sorted(_FORMATS),
            help="how the values travel: int, real, real3, char, compact (ID1 0, 1, 3, 2, 4); "
            "default: real for float addresses, int otherwise",
        )
        where = q.add_mutually_exclusive_group(required=True)
        where.add_argument(
            "--port", help="the PROFIBUS-DP line: a serial port, a pty or a transport URL"
        )
        where.add_argument(
            "--sim",
            action="store_true",
            help="talk to a simulated coupler in this process instead (to try it out)",
        )
        q.add_argument(
            "--station",
            type=int,
            default=5,
            help="the coupler's PROFIBUS-DP station address, 0..125 (default 5)",
        )
        q.add_argument("--baud", type=int, default=19200, help=_BAUD_HELP)
        q.add_argument(
            "--modules",
            default="A.1",
            help="the module list the coupler is configured with; it must hold the parameter "
            "channel A.1 (default A.1)",
        )
        q.add_argument(
            "--intel",
            action="store_true",
            help="Intel byte order (low byte first), set in the user parameters",
        )
        q.add_argument(
            "--timeout",
            type=float,
            default=5.0,
            help="give the job up after this many seconds (default 5)",
        )
        q.set_defaults(func=_read if name == "read" else _write)

    g = sub.add_parser(
        "gsd", help="print the device's GSD file for the PROFIBUS configuration tool"
    )
    g.add_argument("--output", "-o", help="write it to this file instead of printing it")
    g.set_defaults(func=_gsd)

    a = sub.add_parser(
        "address", help="say what an address means: view, area and datum, in every view"
    )
    a.add_argument("address", help="the address, e.g. 0xFD09 or fix1:ch1:0x96")
    a.set_defaults(func=_address)


def _fail(message: str) -> int:
    print(f"uss ksvario: {message}", file=sys.stderr)
    return 2


def _gsd(args: argparse.Namespace) -> int:
    text = emit_gsd()
    if not args.output:
        sys.stdout.write(text.replace("\r\n", "\n"))
        return 0
    try:
        write_atomically(args.output, text.encode("ascii"), "the GSD file")
    except ConfigError as exc:
        return _fail(str(exc))
    target = args.output
    print(f"wrote {target}")
    return 0


def _address(args: argparse.Namespace) -> int:
    try:
        addr = parse_address(args.address)
    except ConfigError as exc:
        return _fail(str(exc))
    print(addr)
    for view in View:
        print(f"  {view.name.lower():9} {addr.as_view(view).encode():04X}h")
    return 0


def _simulate(args: argparse.Namespace) -> int:
    if not 0 <= args.station <= 125:
        return _fail(f"station {args.station} is out of range 0..125")
    if not 1 <= args.channels <= 30:
        return _fail(f"channels {args.channels} is out of range 1..30")
    try:
        check_baud(args.baud)
        return asyncio.run(_simulate_until_stopped(args))
    except ConfigError as exc:
        return _fail(str(exc))
    except UssError as exc:  # the line cannot be opened, or is lost
        print(f"uss ksvario: {exc}", file=sys.stderr)
        return 1


async def _simulate_until_stopped(args: argparse.Namespace) -> int:
    """Serve until SIGINT or SIGTERM: exit code 0. The handlers are installed explicitly, as
    a shell script that starts the simulator in the background leaves SIGINT ignored."""

    def ready(device: str) -> None:
        print(device, flush=True)
        print(f"KS VARIO station {args.station}, ident 1030h; Ctrl-C stops", file=sys.stderr)

    with stop_on_signals() as stop:
        await serve(
            station=args.station,
            port=args.port,
            baud=args.baud,
            channels=args.channels,
            on_ready=ready,
            stop=stop,
        )
    print(f"uss ksvario: station {args.station} stopped", file=sys.stderr)
    return 0


def _parse_values(fmt: DataFormat, texts: list[str]) -> list[Value]:
    """The values typed on the command line, each checked against what ``fmt`` carries, so a
    value the channel cannot carry is bad input before the line is opened."""
    out: list[Value] = []
    for t in texts:
        value: Value
        try:
            if fmt.is_real:
                value = float(t)
            elif fmt is DataFormat.INTEGER:
                value = int(t, 0)
            elif fmt is DataFormat.CHAR:
                value = ord(t) if len(t) == 1 else int(t, 0)
            else:
                value = t.encode("latin-1")
        except (ValueError, UnicodeEncodeError):
            raise ConfigError(f"{t!r} is not {_KINDS[fmt]}") from None
        encode_value(fmt, value, ByteOrder.MOTOROLA)  # range: ConfigError naming the value
        out.append(value)
    return out


def _format_value(addr: Address, fmt: DataFormat, value: Value) -> str:
    if isinstance(value, bytes):
        return repr(value.decode("latin-1"))
    if fmt is DataFormat.CHAR and isinstance(value, int):
        return f"{value} {chr(value)!r}"
    if fmt is DataFormat.INTEGER and addr.view is View.FIXPOINT1 and isinstance(value, int):
        return f"{value} ({value / 10:g})"
    return f"{value:g}" if isinstance(value, float) else str(value)


async def _job(args: argparse.Namespace, addr: Address, fmt: DataFormat, write: list[Value]) -> int:
    conf = Configuration(parse_modules(args.modules))
    order = ByteOrder.INTEL if args.intel else ByteOrder.MOTOROLA
    user = UserParameters(byte_order=order)
    if args.sim:
        coupler = Coupler(selection=CacheSelection.example(), user=user)
        coupler.configure(conf)
        master = KsVarioMaster(LocalLink(coupler), conf, byte_order=order, timeout=args.timeout)
        return await _run(master, args, addr, fmt, write)
    line = dp_line(args.port, baud=args.baud)
    await line.open()
    try:
        link = DpMasterLink(line, args.station, conf, user=user)
        await link.connect()
        master = KsVarioMaster(link, conf, byte_order=order, timeout=args.timeout)
        return await _run(master, args, addr, fmt, write)
    finally:
        await line.close()


async def _run(
    master: KsVarioMaster,
    args: argparse.Namespace,
    addr: Address,
    fmt: DataFormat,
    write: list[Value],
) -> int:
    if write:
        await master.write(addr, write, fmt)
        print(f"wrote {len(write)} value(s) at {addr.encode():04X}h: {master.status.describe()}")
        return 0
    values = await master.read(addr, args.count, fmt)
    # one row per value, at the address word of its first datum counted from the word typed
    # (a float datum spans two address words; a compact-char value four data)
    step = (4 if fmt is DataFormat.COMPACT_CHAR else 1) * (2 if addr.view is View.FLOAT else 1)
    for k, value in enumerate(values):
        print(f"{addr.encode() + k * step:04X}h  {_format_value(addr, fmt, value)}")
    return 0


def _prepare(args: argparse.Namespace) -> tuple[Address, DataFormat]:
    addr = parse_address(args.address)
    fmt = _FORMATS[args.format] if args.format else default_format(addr)
    if not 0 <= args.station <= 125:
        raise ConfigError(f"station {args.station} is out of range 0..125")
    if not args.sim:
        check_baud(args.baud)
    if not args.timeout > 0:
        raise ConfigError(f"--timeout {args.timeout}: must be > 0 seconds")
    conf = Configuration(parse_modules(args.modules))
    if "A.1" not in (m.key for m in conf.modules):
        raise ConfigError(f"--modules {args.modules}: the jobs need the parameter channel A.1")
    return addr, fmt


def _read(args: argparse.Namespace) -> int:
    try:
        addr, fmt = _prepare(args)
        if not 1 <= args.count <= 255:
            raise ConfigError(f"count {args.count} is out of range 1..255")
    except ConfigError as exc:
        return _fail(str(exc))
    return asyncio.run(_job(args, addr, fmt, []))


def _write(args: argparse.Namespace) -> int:
    try:
        addr, fmt = _prepare(args)
        values = _parse_values(fmt, args.values)
    except ConfigError as exc:
        return _fail(str(exc))
    return asyncio.run(_job(args, addr, fmt, values))
