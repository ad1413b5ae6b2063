"""Serve USS drives to the plant on Modbus TCP, MQTT and OPC UA, until stopped.

The plant comes from a configuration file (``--config plant.toml``: buses, drives, faces; see
docs/gateway.md) or, for one bus, from flags (``--port URL --address 5 --address 6``); with
neither, from the file the other commands read (``USS_CONFIG``, ``./uss.toml``,
``~/.config/pyuss/uss.toml``: docs/lines.md). The
faces are named by their addresses: ``--modbus 127.0.0.1:5020``,
``--mqtt mqtt://127.0.0.1:1883``, ``--opcua opc.tcp://127.0.0.1:4840`` (with a configuration
file, these replace the address of that face or add it). Listening faces bind to the host
given: 127.0.0.1 unless told otherwise.

Prints one line per bus and face, the event loop it runs on (uvloop where it is installed and
every bus is ``bus://``, `pyuss.loop.uvloop_choice`), and then ``ready``; runs until SIGINT or
SIGTERM (or ``--duration`` seconds), then says ``offline`` on MQTT, closes the servers and the
ports.

A lost port or connection is reopened (the first try at once, then after 0.5 s, the wait
doubling up to 10 s), and the drives come back without a restart; meanwhile the faces show
the bus and its drives offline. The log says once when the line is lost, once a minute while
it stays lost and once when it is back. ``?reconnect=0`` in a bus's port URL turns that off:
then a lost line stops the gateway, one log line saying why, with exit code 1, for a service
manager to start it again (docs/gateway.md, "Availability").

Exit codes: 0 stopped; 1 a port (with ``reconnect=0``) or broker failed beyond recovery; 2
bad configuration (one line naming the key, before any port opens), or a face whose library
is missing (the line names the pip install to run).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from typing import TYPE_CHECKING, Any

from pyuss.cli._help import subcommand
from pyuss.cli._output import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from pyuss.errors import ConfigError
from pyuss.system import stop_on_signals

if TYPE_CHECKING:
    from pyuss.loop import LoopChoice


def register(subparsers: Any) -> None:
    from pyuss.gateway.faces import faces as registry  # their flags

    parser = subcommand(
        subparsers,
        "gateway",
        "serve USS drives on Modbus TCP, MQTT (Home Assistant) and OPC UA",
        __doc__,
    )
    parser.add_argument(
        "--config",
        metavar="FILE",
        help="the plant's configuration (TOML; default without --port: $USS_CONFIG, ./uss.toml, "
        "then ~/.config/pyuss/uss.toml)",
    )
    one = parser.add_argument_group("one bus without a configuration file")
    one.add_argument("--port", metavar="URL", help="serial port or URL (/dev/ttyUSB0, bus://...)")
    one.add_argument(
        "--address",
        action="append",
        type=int,
        default=[],
        metavar="N",
        help="a drive's address 0..31 (repeat for more drives)",
    )
    one.add_argument("--baud", type=int, help="baud rate (default 9600)")
    one.add_argument(
        "--profile",
        help="device profile (default: none, drives of unknown kind - parameters as words, "
        "process values in percent, no family's facts)",
    )
    one.add_argument("--layout", metavar="PKW,PZD", help="telegram layout (default: profile's)")
    one.add_argument(
        "--parameter",
        action="append",
        default=[],
        metavar="PNU",
        help="a parameter to expose on every drive: 107 or 4.2 (repeatable)",
    )
    one.add_argument(
        "--cycle-time", type=float, metavar="S", help="bus cycle in seconds (default: fastest)"
    )
    one.add_argument("--bus-name", help="the bus's name in topics and nodes (default bus)")
    faces = parser.add_argument_group("faces")
    for spec in registry().values():
        if spec.flag is not None:
            faces.add_argument(
                f"--{spec.name}",
                metavar=spec.flag.metavar,
                help=spec.flag.help,
                dest=f"face_{spec.name}",
            )
    faces.add_argument(
        "--read-only", action="store_true", help="every face refuses writes and commands"
    )
    parser.add_argument(
        "--duration", type=float, metavar="S", help="stop after S seconds (default: run on)"
    )
    parser.set_defaults(func=run)


ONE_BUS = (
    ("--port", "port"),
    ("--address", "address"),
    ("--baud", "baud"),
    ("--profile", "profile"),
    ("--layout", "layout"),
    ("--parameter", "parameter"),
    ("--cycle-time", "cycle_time"),
    ("--bus-name", "bus_name"),
)
"""The flags of one bus without a configuration file: with one, each is refused, never
left unapplied (a gateway at another baud rate or with other drives than asked)."""


def build_config(args: argparse.Namespace) -> Any:
    """The `GatewayConfig` the arguments ask for; `ConfigError` naming the flag or key."""
    from pyuss.gateway.config import GatewayConfig, load_config
    from pyuss.gateway.faces import faces
    from pyuss.lines import find, looked_in
    from pyuss.points.config import plant_from_flags

    path = args.config
    if path is None and args.port is None:
        found = find()  # USS_CONFIG, ./uss.toml, ~/.config/pyuss/uss.toml
        if found is None:
            raise ConfigError(
                f"--port: give a port URL, or --config FILE (no configuration file found: "
                f"{looked_in()})"
            )
        path = str(found)
    if path is not None:
        given = [flag for flag, dest in ONE_BUS if getattr(args, dest) not in (None, [])]
        if given:
            raise ConfigError(
                f"{given[0]}: the buses come from the configuration file {path}: give "
                f"{', '.join(given)} there (in its [[bus]] tables), not as flags"
            )
        config = load_config(path)
    else:
        plant = plant_from_flags(
            port=args.port,
            addresses=args.address,
            baud=9600 if args.baud is None else args.baud,
            profile=args.profile,
            layout=args.layout,
            name="bus" if args.bus_name is None else args.bus_name,
            cycle_time=args.cycle_time,
            parameters=args.parameter,
        )
        config = GatewayConfig(plant)

    flags: list[str] = []
    for spec in faces().values():
        if spec.flag is None:
            continue
        flags.append(f"--{spec.name}")
        value = getattr(args, f"face_{spec.name}", None)
        if value is not None:
            try:
                options = spec.flag.apply(config.face(spec.name), value)
            except ConfigError as exc:
                raise ConfigError(f"--{spec.name}: {exc}") from None
            config = config.with_face(spec.name, options)
    if args.read_only:
        for spec in faces().values():
            options = config.face(spec.name)
            if options is not None:
                try:
                    config = config.with_face(spec.name, spec.read_only(options))
                except ConfigError as exc:
                    raise ConfigError(f"--read-only: the {spec.name} face: {exc}") from None
    if all(config.face(name) is None for name in faces()):
        give = ", ".join(flags[:-1]) + f" or {flags[-1]}" if len(flags) > 1 else "".join(flags)
        raise ConfigError(f"no face: give {give} (or their tables)")
    if args.duration is not None and not args.duration > 0:
        raise ConfigError(f"--duration {args.duration}: must be > 0 seconds")
    return config


def run(args: argparse.Namespace) -> int:
    try:
        config = build_config(args)
        from pyuss.gateway.run import Gateway

        gateway = Gateway(config)
    except ConfigError as exc:
        print(f"uss gateway: {exc}", file=sys.stderr)
        return EXIT_USAGE
    loop = _loop(config)
    try:
        return loop.run(serve(gateway, args.duration, loop))
    except ConfigError as exc:
        print(f"uss gateway: {exc}", file=sys.stderr)
        return EXIT_USAGE


def _loop(config: Any) -> LoopChoice:
    """uvloop where installed and every bus is ``bus://`` (`pyuss.loop.uvloop_choice`)."""
    from pyuss.loop import uvloop_choice

    ports = [bus.port for bus in config.plant.buses]
    return uvloop_choice(bool(ports) and all(p.startswith("bus://") for p in ports))


async def serve(gateway: Any, duration: float | None, loop_choice: LoopChoice | None = None) -> int:
    code = EXIT_OK
    with stop_on_signals() as stop:
        await gateway.start()
        try:
            for bus in gateway.plant.buses.values():
                config = bus.model.config
                print(
                    f"bus {config.name}: {config.port} at {config.baud} baud, drives "
                    + ", ".join(f"{d.name}={d.address}" for d in bus.model.drives),
                    flush=True,
                )
            for name, where in gateway.endpoints():
                print(f"{name}: {where}", flush=True)
            if loop_choice is not None:
                print(f"event loop: {loop_choice}", flush=True)
            print("ready", flush=True)
            stopped = asyncio.ensure_future(stop.wait())
            lost = asyncio.ensure_future(gateway.plant.lost())  # the bus's log line says why
            try:
                await asyncio.wait({stopped, lost}, timeout=duration, return_when="FIRST_COMPLETED")
                if lost.done():
                    code = EXIT_FAILED
            finally:
                stopped.cancel()
                lost.cancel()
        finally:
            await gateway.close()
    return code
