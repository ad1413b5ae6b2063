"""Simulate drives: answer a master on a line as real drives would, until stopped.

One process serves one or more bus addresses, each a simulated drive of the chosen profile with
its own parameters, on one of:

- ``--pty``: a pseudo-terminal; the FIRST line printed is its device path (open it as a serial
  port, e.g. ``/dev/pts/7``);
- ``--tcp HOST:PORT``: a TCP server carrying the line to several clients at once (an idle
  client gives way to a new one when all 8 places are taken); HOST is 127.0.0.1 when only
  ``:PORT`` is given; PORT 0 picks a free one; the first line is ``tcp://HOST:PORT`` with the
  port listened on;
- ``--serial DEVICE``: a real serial port (any pyserial URL); the first line is DEVICE;
- ``--bus HOST:PORT``: a station of a virtual bus run by ``uss bus --bus-tcp``; the first line
  is ``bus://HOST:PORT``. The station is named ``simulate-`` and the addresses (``--name``
  chooses another), so simulators of other drives join the same bus.
- ``--bus-tcp HOST:PORT``: a virtual bus of its own with the drives on it, open to ``bus://``
  stations (masters, monitors, other simulators) at HOST:PORT, as ``uss bus --bus-tcp`` is;
  the first line is ``bus://HOST:PORT`` with the port listened on. The drives answer on the
  bus's own timeline, with no hop between processes: the quickest set-up at high rates.

Without ``--baud`` the line runs at the rate the drives' baud rate parameter is set to (C 3:
generic P684.1, from ``--store`` or the file), else 9600. The interface parameters show what is
in force (P684.1 the line's rate, P687.1 the failure time). A baud rate written to a drive
alone on a pty or TCP line is in force at once; elsewhere it is stored for the next start
(docs/slave.md).

``--profile baumueller`` drives also have Baumueller's BASS service interface (Baumueller
communication software manual, part 1):
``--bass-pty``, ``--bass-tcp HOST:PORT`` or ``--bass-serial DEVICE`` serves it (RS-232, 9600
baud 8N1). Each drive is then ONE drive on two interfaces: a BASS write is
seen over USS, and a BASS write of an active parameter makes the USS side send a spontaneous
message (on by default with a BASS side; ``--no-spontaneous`` turns it off). All drives of the
process form one closed BASS ring, wired in address order, each with its bus address as DIP
address. Output order: the first line is the USS device as above, the second the BASS device
(``/dev/pts/8``, ``tcp://HOST:PORT`` or DEVICE); stderr says which is which.

It stops cleanly on SIGINT or SIGTERM (or after ``--duration`` seconds): exit code 0, and a
summary on stderr. Values written with the EEPROM request IDs go to ``--store FILE`` (with
several addresses FILE must contain ``{address}``); a damaged store file is refused (exit 2).

A drive starts "ready for USS": where its family's file has a ``[sources]`` table (SINAMICS
V20, G110, G120, MICROMASTER 420/440: P0700 command source, P1000 setpoint source) both are at
their USS value 5, so a master can switch it on at once. ``--factory`` starts it with the
factory values instead, as out of the box (V20: P0700 = 1 operator panel, P1000 = 1 MOP; the
others 2, terminals and analog input): the drive then ignores the control word and the setpoint
of USS until P0700 and P1000 are set to 5 (docs/drive.md). A value in ``--store`` wins either
way.

Other protocols: ``--profile ksvario`` runs the KS VARIO PROFIBUS-DP simulator as the one DP station
``--address`` (0..125) at a PROFIBUS-DP ``--baud``; ``--profile bass`` a closed RS-232 ring of
Baumueller drives speaking BASS (9600 baud 8N1, one drive per
``--address``). Both refuse the options of USS drives (``--params``, ``--layout``, ...).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import importlib
import math
import sys
import urllib.parse
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import TYPE_CHECKING, Any

from pyuss.bass.codec import BAUD as BASS_BAUD
from pyuss.bass.drive import DriveOperatingData, drive_ring
from pyuss.bass.ring import MAX_STATIONS, BassRing, DictOperatingData, demo_elements
from pyuss.cli._help import subcommand
from pyuss.cli._output import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from pyuss.errors import ConfigError, UssError
from pyuss.profiles import get_profile, profile_names
from pyuss.protocol.layout import Layout
from pyuss.slave.engine import JobLatency, SlaveEngine
from pyuss.slave.simulation import (
    DEFAULT_BAUD,
    DriveSettings,
    endpoint,
    open_line,
    simulated_line,
)
from pyuss.system import stop_on_signals
from pyuss.transport.base import Transport
from pyuss.transport.queued import BAUD_RATES, check_baud

if TYPE_CHECKING:
    pass

BASS_PROFILE = "baumueller"
"""The profile whose drives also have the BASS service interface (Baumueller manual, part 1)."""


@dataclasses.dataclass(frozen=True, slots=True)
class Options:
    """The checked command line, as a simulator of any protocol receives it."""

    profile: str
    addresses: tuple[int, ...]
    baud: int | None
    """``--baud``; None: the drives' baud rate parameter (USS drives), else `DEFAULT_BAUD`."""
    line: str
    """``pty``, ``tcp``, ``serial``, ``bus`` or ``bus-tcp`` (a bus of its own)."""
    where: str
    """The serial device, or HOST:PORT of ``tcp`` / ``bus`` / ``bus-tcp``."""
    params: str | None
    layout: Layout | None
    store: str | None
    failure_time: float | None
    latency: JobLatency
    response_delay: float | None
    """``--response-delay MS`` in seconds; None: as early as allowed, or `manual_delay`."""
    read_only: bool
    spontaneous: bool | None
    duration: float | None
    bass_line: str | None = None
    """``pty``, ``tcp`` or ``serial`` for the BASS service interface (baumueller); None: none."""
    bass_where: str = ""
    """The serial device, or HOST:PORT of ``tcp``, of the BASS side."""
    name: str | None = None
    """The station name on the bus (``--name``); None: ``simulate-`` and the addresses."""
    manual_delay: bool = False
    """``--response-delay manual``: each drive answers after the response delay its parameter
    file gives (``[profile] response_delay_ms``)."""
    factory: bool = False
    """``--factory``: the drives start with the factory values of their command and setpoint
    sources (``[sources]``), not ready for USS."""


Announce = Callable[[str], None]
Runner = Callable[[Options, asyncio.Event, Announce], Awaitable[None]]


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers,
        "simulate",
        "simulate drives (USS slaves) on a pty, TCP, serial port or virtual bus",
        __doc__,
    )
    names = ", ".join((*profile_names(), *OTHER_PROTOCOLS))
    parser.add_argument(
        "--profile",
        default="generic",
        metavar="NAME",
        help=f"the drive family to simulate: {names} (docs/profiles.md; default generic, the "
        "drive profile of the USS specification)",
    )
    parser.add_argument(
        "--address",
        action="append",
        type=_int,
        default=[],
        metavar="A",
        help="bus address of a drive, 0..31 (repeat for several drives; default 0); ksvario: "
        "DP station 0..125",
    )
    parser.add_argument(
        "--params",
        metavar="FILE",
        help="the drives' parameters from this file (TOML) instead of the profile's "
        "(format: docs/drive.md)",
    )
    parser.add_argument(
        "--layout",
        metavar="PKW,PZD",
        help="telegram layout the drives use: number of PKW words (0, 3, 4, or v for variable "
        "length) and of PZD words (0..16), e.g. 3,2 (USS specification C 7; default: the "
        "profile's)",
    )
    parser.add_argument(
        "--baud",
        type=_int,
        metavar="B",
        help="baud rate of the line: "
        f"{', '.join(map(str, BAUD_RATES))} (USS specification B 2.4; default: the rate the "
        "drives' baud rate parameter is set to, generic P684.1, from --store, else "
        f"{DEFAULT_BAUD}; USS specification C 3; a pty has none)",
    )
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument(
        "--pty",
        action="store_true",
        help="answer on a new pseudo-terminal; its device path is the first line printed",
    )
    where.add_argument(
        "--tcp",
        metavar="HOST:PORT",
        help="answer as a TCP server, as a serial-to-Ethernet converter does (:0 picks a port)",
    )
    where.add_argument(
        "--serial", metavar="DEVICE", help="answer on a serial port, e.g. /dev/ttyUSB0"
    )
    where.add_argument(
        "--bus",
        metavar="HOST:PORT",
        help="answer as a station of a virtual bus started with uss bus --bus-tcp",
    )
    where.add_argument(
        "--bus-tcp",
        metavar="HOST:PORT",
        help="run a virtual bus of its own with the drives on it, open to bus:// masters and "
        "monitors at HOST:PORT (:0 picks a port); the drives answer without a hop between "
        "processes, the quickest set-up at high baud rates",
    )
    parser.add_argument(
        "--name",
        metavar="NAME",
        help="with --bus or --bus-tcp: the drives' station name on the bus (default "
        "simulate-ADDRESSES, e.g. "
        "simulate-5 or simulate-5-6, so simulators of other drives can join the same bus)",
    )
    bass = parser.add_mutually_exclusive_group()
    bass.add_argument(
        "--bass-pty",
        action="store_true",
        help="baumueller: serve the BASS service interface (RS-232) on a new pty too",
    )
    bass.add_argument(
        "--bass-tcp", metavar="HOST:PORT", help="baumueller: serve BASS as a TCP server too"
    )
    bass.add_argument(
        "--bass-serial", metavar="DEVICE", help="baumueller: serve BASS on a serial port too"
    )
    parser.add_argument(
        "--store",
        metavar="FILE",
        help="keep values written to EEPROM in FILE across restarts ({address} in the name "
        "for several drives)",
    )
    parser.add_argument(
        "--factory",
        action="store_true",
        help="start the drives with their family's factory values of the command and setpoint "
        "sources (P0700, P1000: not USS), as out of the box; default: ready for USS (5)",
    )
    parser.add_argument(
        "--failure-time",
        type=float,
        metavar="SECONDS",
        help="fault the drive when no telegram came for SECONDS (0: not watched; default: the "
        "parameter file's; USS specification C 3.1)",
    )
    parser.add_argument(
        "--latency",
        type=_int,
        default=0,
        metavar="N",
        help="answer a new parameter job only after N telegrams carried it, as busy drives do "
        "(USS specification C 4.2.1.1)",
    )
    parser.add_argument(
        "--latency-time",
        type=float,
        default=0.0,
        metavar="MS",
        help="... and only MS milliseconds after it first came",
    )
    parser.add_argument(
        "--response-delay",
        metavar="MS|manual",
        help="answer MS milliseconds after a request, inside the profile's window (USS "
        "specification A 5.2.1.1), or 'manual': after the response delay the family's manual "
        "gives (the parameter file's response_delay_ms, SINAMICS V20 20 ms); default: as early "
        "as allowed",
    )
    parser.add_argument(
        "--read-only",
        action="store_true",
        help="refuse every parameter change as a drive without write authority does (response "
        "ID 8, USS specification C Table 4.2)",
    )
    parser.add_argument(
        "--spontaneous",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="report parameter changes made on the drive itself to the master (USS "
        "specification C 4.2.1.2; default: as the profile does)",
    )
    parser.add_argument(
        "--duration", type=float, metavar="SECONDS", help="stop by itself after SECONDS"
    )
    parser.set_defaults(func=run)


def _int(text: str) -> int:
    try:
        return int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None


def _chosen_line(
    prefix: str, pty: bool, tcp: str | None, serial: str | None
) -> tuple[str, str] | None:
    """``(line, where)`` of the options ``{prefix}pty``, ``{prefix}tcp`` and ``{prefix}serial``
    (None: none of them given)."""
    if pty:
        return "pty", ""
    if tcp is not None:
        return "tcp", str(endpoint(tcp, f"{prefix}tcp"))
    if serial is not None:
        if not serial.strip():
            raise ConfigError(f"{prefix}serial: give a device")
        return "serial", serial
    return None


def options(args: argparse.Namespace) -> Options:
    """Check the arguments; `ConfigError` naming what is wrong."""
    # a KS VARIO is a PROFIBUS-DP station: DP baud rates and station addresses 0..125
    ksvario = args.profile == "ksvario"
    baud: int | None = args.baud
    if ksvario:
        from pyuss.ksvario.dp.fdl import check_baud as check_dp_baud

        baud = check_dp_baud(DEFAULT_BAUD if baud is None else baud)
    elif baud is not None:
        baud = check_baud(baud)
    chosen = _chosen_line("--", args.pty, args.tcp, args.serial)
    if chosen is not None:
        line, where = chosen
    elif args.bus_tcp is not None:
        line, where = "bus-tcp", str(endpoint(args.bus_tcp, "--bus-tcp"))
    else:
        bus = endpoint(args.bus, "--bus")
        if bus.port == 0:
            raise ConfigError(f"--bus {args.bus!r}: give the port the bus listens on")
        line, where = "bus", str(bus)
    if args.name is not None:
        if line not in ("bus", "bus-tcp"):
            raise ConfigError("--name: a station name is for --bus and --bus-tcp only")
        if not args.name or "+" in args.name or not args.name.isprintable() or "&" in args.name:
            raise ConfigError(f"--name {args.name!r}: give a non-empty name without '+' or '&'")
    addresses = tuple(args.address) or (0,)
    for address in addresses:
        if ksvario and not 0 <= address <= 125:
            raise ConfigError(f"--address {address}: DP station addresses are 0..125")
        if not ksvario and not 0 <= address <= 31:
            raise ConfigError(f"--address {address}: bus addresses are 0..31")
    if len(set(addresses)) != len(addresses):
        raise ConfigError("--address: each address may be given once")
    if args.store is not None and len(addresses) > 1 and "{address}" not in args.store:
        raise ConfigError("--store: with several addresses the file name must contain {address}")
    for name, value in (("--failure-time", args.failure_time), ("--duration", args.duration)):
        if value is not None and not 0 <= value < math.inf:
            raise ConfigError(f"{name} {value}: must be a number of seconds >= 0")
    if args.duration is not None and args.duration == 0:
        raise ConfigError("--duration 0: must be > 0 seconds")
    if args.latency < 0 or not 0 <= args.latency_time < math.inf:
        raise ConfigError("--latency and --latency-time must be numbers >= 0")
    bass_line, bass_where = _bass_side(args, addresses, line, where)
    delay = None
    manual = args.response_delay == "manual"
    if args.response_delay is not None and not manual:
        try:
            milliseconds = float(args.response_delay)
        except ValueError:
            milliseconds = math.nan
        if not 0 < milliseconds < math.inf:
            raise ConfigError(
                f"--response-delay {args.response_delay}: must be a number of milliseconds "
                "> 0, or 'manual'"
            )
        delay = milliseconds / 1000
    return Options(
        profile=args.profile,
        addresses=addresses,
        baud=baud,
        line=line,
        where=where,
        params=args.params,
        layout=None if args.layout is None else Layout.parse(args.layout),
        store=args.store,
        failure_time=args.failure_time,
        latency=JobLatency(args.latency, args.latency_time / 1000),
        response_delay=delay,
        manual_delay=manual,
        read_only=args.read_only,
        spontaneous=args.spontaneous,
        duration=args.duration,
        bass_line=bass_line,
        bass_where=bass_where,
        name=args.name,
        factory=args.factory,
    )


def _bass_side(
    args: argparse.Namespace, addresses: tuple[int, ...], line: str, where: str
) -> tuple[str | None, str]:
    """The BASS side the arguments ask for: ``(line, where)``, or ``(None, "")``."""
    chosen = _chosen_line("--bass-", args.bass_pty, args.bass_tcp, args.bass_serial)
    if chosen is None:
        return None, ""
    bass_line, bass_where = chosen
    option = f"--bass-{bass_line}"
    if args.profile != BASS_PROFILE:
        raise ConfigError(
            f"{option}: only --profile {BASS_PROFILE} drives have the BASS service interface"
        )
    if len(addresses) > MAX_STATIONS:
        raise ConfigError(f"{option}: a BASS ring has at most {MAX_STATIONS} drives")
    shared = bass_line != "pty" and (line, where) == (bass_line, bass_where)
    if shared and not where.endswith(":0"):  # port 0: two free ports are picked
        raise ConfigError(f"{option} {bass_where}: the USS side uses it already")
    return bass_line, bass_where


def run(args: argparse.Namespace) -> int:
    try:
        opts = options(args)
        runner = OTHER_PROTOCOLS.get(opts.profile)
        if runner is None:
            get_profile(opts.profile)  # an unknown name is bad input
            runner = _serve_uss
    except ConfigError as exc:
        print(f"uss simulate: {exc}", file=sys.stderr)
        return EXIT_USAGE
    try:
        return asyncio.run(_main(opts, runner))
    except ConfigError as exc:
        print(f"uss simulate: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except UssError as exc:
        print(f"uss simulate: {exc}", file=sys.stderr)
        return EXIT_FAILED


async def _main(opts: Options, runner: Runner) -> int:
    with stop_on_signals() as stop:

        def announce(line: str) -> None:
            print(line, flush=True)

        async def stop_later(seconds: float) -> None:
            await asyncio.sleep(seconds)
            stop.set()

        timer = None if opts.duration is None else asyncio.create_task(stop_later(opts.duration))
        try:
            await runner(opts, stop, announce)
        finally:
            if timer is not None:
                timer.cancel()
    return EXIT_OK


# -- USS ------------------------------------------------------------------------------------


def _line(opts: Options, *, baud: int, parity: str = "E") -> tuple[Transport, Callable[[], str]]:
    """The transport and, once open, the line to print first."""
    return open_line(opts.line, opts.where, baud, parity, name=_station_name(opts))


def _station_name(opts: Options) -> str:
    """The drives' station name on a bus: ``--name``, else ``simulate-`` and the addresses."""
    return opts.name or "simulate-" + "-".join(str(a) for a in opts.addresses)


async def _serve_uss(opts: Options, stop: asyncio.Event, announce: Announce) -> None:
    spontaneous = opts.spontaneous
    if spontaneous is None and opts.bass_line is not None:
        spontaneous = True  # one drive, two interfaces: BASS changes are reported (C 4.2.1.2)
    settings = DriveSettings(
        params=opts.params,
        layout=opts.layout,
        store=opts.store,
        factory=opts.factory,
        failure_time=opts.failure_time,
        latency=opts.latency,
        response_delay=opts.response_delay,
        manual_delay=opts.manual_delay,
        write_authority=not opts.read_only,
        spontaneous=spontaneous,
    )
    async with simulated_line(
        opts.profile,
        opts.addresses,
        settings,
        line=opts.line,
        where=opts.where,
        station=_station_name(opts),
        baud=opts.baud,
    ) as sim:
        baud, server = sim.baud, sim.server
        async with _bass_side_of(opts, sim.engines, sim.transport.clock) as bass:
            uss_device = sim.first_line()
            announce(uss_device)
            if bass is not None:
                announce(bass.device)
            for engine in sim.engines:
                low, high = engine.response_window(baud)
                print(
                    f"uss simulate: address {engine.address}: profile {sim.profile.name}, "
                    f"parameters {sim.database.profile.name}, {baud} baud, layout "
                    f"{engine.layout}, answer {low * 1000:.3f}..{high * 1000:.3f} ms, failure "
                    f"time {engine.failure_time:g} s{_answering(engine, opts, baud)}",
                    file=sys.stderr,
                )
            if bass is not None:
                order = ", ".join(str(s.address) for s in bass.ring.stations)
                print(
                    f"uss simulate: USS (RS-485, {baud} baud) on {uss_device}; BASS "
                    f"(RS-232, {BASS_BAUD} baud 8N1) on {bass.device}: ring of drives {order}",
                    file=sys.stderr,
                )
            try:
                await server.run(stop)
            finally:
                server.close()
    stats = server.stats
    print(
        f"uss simulate: {stats.received} telegrams received, {stats.answers} answered "
        f"({stats.late} late), {stats.faults} discarded",
        file=sys.stderr,
    )
    if bass is not None:
        answered = ", ".join(f"drive {s.address}: {s.answered}" for s in bass.ring.stations)
        print(f"uss simulate: BASS requests answered: {answered}", file=sys.stderr)


@dataclasses.dataclass(slots=True)
class _BassSide:
    ring: BassRing
    device: str


@contextlib.asynccontextmanager
async def _bass_side_of(
    opts: Options, engines: list[SlaveEngine], clock: Callable[[], float]
) -> AsyncIterator[_BassSide | None]:
    """The BASS service interface of the drives, served while the block runs (None: none)."""
    if opts.bass_line is None:
        yield None
        return
    ring = drive_ring([(e.address, e.drive) for e in engines], clock=clock)
    transport, device = open_line(opts.bass_line, opts.bass_where, BASS_BAUD, "N")
    try:
        async with ring.serving(transport):
            yield _BassSide(ring, device())
    finally:
        for station in ring.stations:
            if isinstance(station.data, DriveOperatingData):
                station.data.close()


# -- other protocols ------------------------------------------------------------------------


def _answering(engine: SlaveEngine, opts: Options, baud: int) -> str:
    """The banner's note of the delay chosen inside the window ("" for the earliest)."""
    if opts.manual_delay:
        delay = engine.manual_delay(baud)
        if delay is None:
            return ", the parameter file gives no response delay: answering as early as allowed"
        return f", answering after {delay * 1000:.3f} ms (the manual's response delay)"
    if opts.response_delay is not None:
        low, high = engine.response_window(baud)
        return f", answering after {min(max(opts.response_delay, low), high) * 1000:.3f} ms"
    return ""


def _refuse_drive_options(opts: Options) -> None:
    """Options of the USS drive simulator are bad input for a simulator of another protocol,
    rather than silently ignored."""
    drive_only = {
        "--params": opts.params is not None,
        "--layout": opts.layout is not None,
        "--store": opts.store is not None,
        "--failure-time": opts.failure_time is not None,
        "--latency": opts.latency != JobLatency(),
        "--response-delay": opts.response_delay is not None or opts.manual_delay,
        "--read-only": opts.read_only,
        "--spontaneous": opts.spontaneous is not None,
        "--factory": opts.factory,
    }
    given = [name for name, on in drive_only.items() if on]
    if given:
        raise ConfigError(
            f"profile {opts.profile} does not take {', '.join(given)} (USS drive options)"
        )


async def _serve_ksvario(opts: Options, stop: asyncio.Event, announce: Announce) -> None:
    """The KS VARIO PROFIBUS-DP simulator: one station, the first ``--address``."""
    try:
        module = importlib.import_module("pyuss.ksvario.simulate")
    except ImportError:
        raise ConfigError("profile ksvario: the KS VARIO simulator is not installed") from None
    if len(opts.addresses) != 1:
        raise ConfigError("profile ksvario serves one station: give one --address")
    if opts.line == "bus-tcp":
        raise ConfigError(
            "profile ksvario: --bus-tcp runs a USS bus; start uss bus --bus-tcp and use --bus"
        )
    _refuse_drive_options(opts)
    port = {
        "pty": None,
        "serial": opts.where,
        "tcp": f"tcp-listen://{opts.where}",
        "bus": f"bus://{opts.where}",
    }[opts.line]
    if opts.line == "bus":
        name = opts.name or f"ksvario-{opts.addresses[0]}"
        port = f"{port}?{urllib.parse.urlencode({'name': name})}"
    await module.serve(
        station=opts.addresses[0],
        port=port,
        baud=opts.baud or DEFAULT_BAUD,
        on_ready=announce,
        stop=stop,
    )


async def _serve_bass(opts: Options, stop: asyncio.Event, announce: Announce) -> None:
    """A closed RS-232 ring of BASS drives (Baumueller communication software manual, part 1),
    one per ``--address`` (its DIP address), with the demonstration operating data of
    `pyuss.bass.ring`; 9600 baud, 8N1."""
    if opts.line in ("bus", "bus-tcp"):
        raise ConfigError("profile bass: a BASS ring is RS-232, not a station of a USS bus")
    _refuse_drive_options(opts)
    ring = BassRing([DictOperatingData(a, demo_elements()) for a in opts.addresses])
    transport, first_line = _line(opts, baud=BASS_BAUD, parity="N")
    async with ring.serving(transport):
        announce(first_line())
        await stop.wait()


OTHER_PROTOCOLS: dict[str, Runner] = {"ksvario": _serve_ksvario, "bass": _serve_bass}
"""Profiles served by simulators of other protocols: name -> runner(options, stop, announce).
A runner serves until ``stop`` is set and calls ``announce`` with the line to print first."""
