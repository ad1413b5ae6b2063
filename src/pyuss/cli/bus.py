"""Run a virtual RS-485 line that other programs use like a real one, until stopped.

Prints one line per way in: the device path of each pty (open it as a serial port), then
``tcp://HOST:PORT`` (raw serial-over-TCP stations, one per connection) and
``bus://HOST:PORT`` (pyuss stations that keep exact timing and line errors), and runs until
SIGINT or SIGTERM (or ``--duration`` seconds), then closes everything, finishes the
recording and prints a summary on stderr. Stopping is the normal end: exit code 0.

``--echo`` makes stations hear their own characters, as 2-wire adapters do: alone, every pty
and tcp station; with names (``--echo pty1,tcp2``), only those.

Each station may have 4096 characters waiting for the line; what it writes beyond that is
dropped (and counted), and what it had not sent when it leaves is dropped, so one station
cannot jam the line for long. When all 32 sending places are taken, a new station gets the
place of the raw tcp station silent longest (1 s at least): idle connections never lock
``bus://`` stations out (docs/bus.md).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import sys
from typing import Any

from pyuss.bus import FaultKind, FaultPlan, Recorder, VirtualBus
from pyuss.bus.core import MAX_SENDERS
from pyuss.cli._help import subcommand
from pyuss.cli._output import EXIT_OK, EXIT_USAGE
from pyuss.errors import ConfigError
from pyuss.system import stop_on_signals
from pyuss.transport.address import parse_host_port
from pyuss.transport.queued import BAUD_RATES


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers,
        "bus",
        "run a virtual RS-485 bus (ptys, TCP) with true character timing",
        __doc__,
    )
    parser.add_argument(
        "--baud",
        type=int,
        default=9600,
        help=f"baud rate of the line: {', '.join(map(str, BAUD_RATES))}; characters take their "
        "true time at it (USS specification B 2.4; default 9600)",
    )
    parser.add_argument(
        "--pty",
        type=int,
        default=0,
        metavar="N",
        help="open N pseudo-terminals as stations, pty1..ptyN (at most 32), each used as a "
        "serial port; their paths are printed first",
    )
    parser.add_argument(
        "--tcp",
        metavar="HOST:PORT",
        help="accept stations over raw TCP, as from a serial-to-Ethernet converter (PORT 0: "
        "any free one)",
    )
    parser.add_argument(
        "--bus-tcp",
        metavar="HOST:PORT",
        help="accept pyuss stations (bus://), which keep exact timestamps and line errors",
    )
    parser.add_argument(
        "--echo",
        nargs="?",
        const="",
        metavar="STATIONS",
        help="stations that hear their own characters, as 2-wire adapters do: every pty and "
        "tcp station, or only those named (--echo pty1,tcp2); bus:// stations choose their own",
    )
    parser.add_argument(
        "--record",
        metavar="FILE",
        help="record every character on the line to FILE (JSON lines, for uss monitor --read)",
    )
    parser.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="SPEC",
        help="inject faults: KIND[:key=value,...] with KIND one of "
        f"{', '.join(k.value for k in FaultKind)}, e.g. flip:p=0.01 or "
        "deaf:station=pty2,at=5,for=2 (repeatable; docs/bus.md lists the keys)",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="start value of the random choices of --fault, so a run can be repeated (default 0)",
    )
    parser.add_argument(
        "--duration", type=float, metavar="SECONDS", help="stop by itself after SECONDS"
    )
    parser.set_defaults(func=run)


def _endpoint(text: str, option: str) -> tuple[str, int]:
    where = parse_host_port(text, f"{option} {text!r}")
    return where.host, where.port


def run(args: argparse.Namespace) -> int:
    try:
        plan = FaultPlan.parse(args.fault)
        bus = VirtualBus(args.baud, faults=plan, seed=args.seed)
        tcp = None if args.tcp is None else _endpoint(args.tcp, "--tcp")
        framed = None if args.bus_tcp is None else _endpoint(args.bus_tcp, "--bus-tcp")
        if not 0 <= args.pty <= MAX_SENDERS:
            raise ConfigError(
                f"--pty {args.pty}: give 0..{MAX_SENDERS} ptys "
                f"(B 1: a bus has one master and up to 31 slaves)"
            )
        if not args.pty and tcp is None and framed is None:
            raise ConfigError("nothing to serve: give --pty N, --tcp HOST:PORT or --bus-tcp")
        if args.duration is not None and not args.duration > 0:
            raise ConfigError(f"--duration {args.duration}: must be > 0 seconds")
        if not framed:  # bus:// stations name themselves: any name may come
            for fault in plan.faults:
                if fault.station is not None:
                    _check_station(fault.station, "--fault", args.pty, tcp is not None)
        echo = _echo_stations(args.echo, args.pty, tcp is not None)
        recorder = None if not args.record else Recorder(args.record, keep=False).attach(bus)
    except ConfigError as exc:
        print(f"uss bus: {exc}", file=sys.stderr)
        return EXIT_USAGE
    started: list[bool] = []
    try:
        return asyncio.run(_serve(bus, args, tcp, framed, echo, started))
    except ConfigError as exc:  # found once serving begins: --pty where there are none
        print(f"uss bus: {exc}", file=sys.stderr)
        return EXIT_USAGE
    finally:
        if recorder is not None:
            if started:
                recorder.close()
            else:  # the bus never ran: no recording of nothing
                recorder.discard()


def _check_station(name: str, option: str, ptys: int, tcp: bool) -> None:
    """A station this bus can have: ``pty1``..``ptyN`` and ``tcp1``... (one per connection).
    A fault or echo aimed at another one would silently never apply."""
    number = name[3:]
    if name.startswith("pty") and number.isdigit() and 1 <= int(number) <= ptys:
        return
    if tcp and name.startswith("tcp") and number.isdigit() and int(number) >= 1:
        return
    known = [f"pty1..pty{ptys}"] if ptys else []
    known += ["tcp1, tcp2, ... (one per connection)"] if tcp else []
    raise ConfigError(f"{option}: no station {name!r} on this bus (stations: {', '.join(known)})")


def _echo_stations(text: str | None, ptys: int, tcp: bool) -> bool | frozenset[str]:
    """``--echo``: absent (nobody), alone (every pty and tcp station) or a list of names."""
    if text is None or text == "":
        return text is not None
    names = [name.strip() for name in text.split(",")]
    for name in names:
        _check_station(name, "--echo", ptys, tcp)
    return frozenset(names)


async def _serve(
    bus: VirtualBus,
    args: argparse.Namespace,
    tcp: tuple[str, int] | None,
    framed: tuple[str, int] | None,
    echo: bool | frozenset[str],
    started: list[bool],
) -> int:
    with stop_on_signals() as stop:
        try:
            lines = await bus.serve_pty(args.pty, echo=echo) if args.pty else []
            if tcp is not None:
                host, port = await bus.serve_tcp(*tcp, echo=echo)
                lines.append(f"tcp://{host}:{port}")
            if framed is not None:
                host, port = await bus.serve_tcp(*framed, framed=True)
                lines.append(f"bus://{host}:{port}")
            started.append(True)
            for line in lines:
                print(line)
            sys.stdout.flush()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(args.duration):
                    await stop.wait()
        finally:
            await bus.close()
    stats = bus.stats
    faults = ", ".join(f"{k} {v}" for k, v in sorted(stats.faults.items())) or "none"
    print(
        f"uss bus: {stats.chars} characters, {stats.collisions} collisions "
        f"({stats.garbled} garbled characters), {stats.lost} lost, faults: {faults}",
        file=sys.stderr,
    )
    if stats.overflow or stats.unsent or stats.evicted:
        print(
            f"uss bus: {stats.overflow} characters dropped from full station queues, "
            f"{stats.unsent} not sent by stations that left, {stats.evicted} idle tcp "
            "stations closed to make room",
            file=sys.stderr,
        )
    return EXIT_OK
