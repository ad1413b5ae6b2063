"""Open a commissioning page in the browser for the drives on one line.

    uss web --demo                                   # simulated drives, no hardware
    uss web --port /dev/ttyUSB0 --baud 19200 --address 5 --address 7 --layout 3,2
    uss web --port /dev/ttyUSB0 --listen 0.0.0.0:8420 --read-only
    uss web --mqtt mqtt://broker:1883                # every drive the gateways publish

The first line printed is the page's address; open it in a browser. The page shows the bus
(drives, state, communication health with the counters of the USS specification, A 5.2.3;
scan), each drive (status word decoded live, actual values, trend, control panel), its
parameters (search, edit, backup, compare, restore) and the telegrams on the line (filter,
pcapng download). Ctrl+C stops the page and the master.

The page listens on 127.0.0.1 (this computer only) unless --listen names another address;
then a token is needed for every request: it is part of the printed address. --read-only
hides and refuses everything that changes a drive. See docs/web.md.

--mqtt shows a plant instead of a line: every bus and drive that `uss gateway` processes
publish on one MQTT broker, commanded through the gateways' topics (the mqtt extra: pip
install 'pyuss[mqtt]'). User, password and TLS come in the URL (mqtts://user:pass@host), the
--mqtt-* options or the [web] table of the configuration file (docs/web.md, "A plant on one
page"); --mqtt alone takes the broker from the file's [web] mqtt. The scan and the telegram
monitor need the line itself and are not offered over the broker.

A lost port or connection is reopened (the first try at once, then after 0.5 s, the wait
doubling up to 10 s) and the page shows the drives offline meanwhile; ``?reconnect=0`` in the
port's URL turns that off: then a lost port stops the page with exit code 1.

Exit codes: 0 stopped by Ctrl+C or SIGTERM; 1 the port could not be opened or was lost with
``reconnect=0``; 2 bad input (arguments, a listen address in use).
"""

from __future__ import annotations

import argparse
import asyncio
import secrets
import sys
from collections.abc import Sequence
from typing import Any

from pyuss.cli._help import subcommand
from pyuss.cli._master import add_line_options, drive_address, integer, line_file
from pyuss.cli._output import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from pyuss.errors import ConfigError
from pyuss.profiles import get_profile, profile_names
from pyuss.protocol.layout import Layout
from pyuss.system import stop_on_signals
from pyuss.transport.address import parse_host_port

__all__ = ["parse_listen", "register", "run"]


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers,
        "web",
        "a commissioning page in the browser: bus, drives, parameters, trend, monitor",
        __doc__,
    )
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--port",
        metavar="URL",
        help="serial port or URL of the line: /dev/ttyUSB0, COM3, tcp://HOST:PORT, "
        "bus://HOST:PORT (default: the line's in the configuration file)",
    )
    where.add_argument(
        "--demo",
        action="store_true",
        help="three simulated drives on a virtual bus at 38400 baud, no hardware needed",
    )
    where.add_argument(
        "--mqtt",
        nargs="?",
        const="",
        metavar="URL",
        help="a plant over an MQTT broker: every drive the uss gateway processes publish "
        "(mqtt://HOST[:PORT], mqtts:// for TLS; alone: the broker of the file's [web] mqtt)",
    )
    broker = parser.add_argument_group("the broker of --mqtt (else the [web] table of the file)")
    broker.add_argument("--mqtt-user", metavar="NAME", help="user name at the broker")
    broker.add_argument("--mqtt-password", metavar="TEXT", help="password at the broker")
    broker.add_argument("--mqtt-ca", metavar="FILE", help="CA certificate(s) for TLS")
    broker.add_argument("--mqtt-cert", metavar="FILE", help="client certificate for TLS")
    broker.add_argument("--mqtt-key", metavar="FILE", help="client certificate's key")
    broker.add_argument(
        "--mqtt-insecure", action="store_true", help="TLS without checking the broker's name"
    )
    broker.add_argument("--mqtt-prefix", metavar="TOPIC", help="the gateways' prefix (uss)")
    add_line_options(parser)
    parser.add_argument("--baud", type=integer, help="baud rate of the line (default 9600)")
    parser.add_argument(
        "--address",
        type=drive_address,
        action="append",
        default=[],
        metavar="N",
        help="a drive to show, 0..31 or its name in the configuration file (repeatable; none: "
        "the line's drives in the file, else scan from the page)",
    )
    parser.add_argument(
        "--profile",
        metavar="NAME",
        help=f"device profile of the drives ({', '.join(profile_names())}; auto: ask each "
        "drive which family it is; default: the file's, else none: drives of unknown kind, their "
        "parameters as words, no family's facts)",
    )
    parser.add_argument(
        "--layout",
        metavar="PKW,PZD",
        help="telegram layout of the drives: PKW 0, 3, 4 or v, PZD 0..16 (default: the profile's)",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=2.0,
        metavar="S",
        help="seconds a parameter job or command may take (default 2)",
    )
    parser.add_argument(
        "--listen",
        default="127.0.0.1:8420",
        metavar="HOST:PORT",
        help="where the page listens (default 127.0.0.1:8420; port 0 picks a free one); "
        "any address but this computer's own needs the token printed at start",
    )
    parser.add_argument(
        "--token",
        metavar="TEXT",
        help="the token the page asks for (default: a random one when listening beyond this "
        "computer, none on 127.0.0.1)",
    )
    parser.add_argument(
        "--read-only",
        action="store_true",
        help="show everything, change nothing: no commands, no parameter writes, no scan",
    )
    parser.set_defaults(func=run)


def parse_listen(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``[::1]:8420``, ``:8420`` for 127.0.0.1) as host and port."""
    where = parse_host_port(
        text, f"--listen {text!r}", form="HOST:PORT, for example 127.0.0.1:8420"
    )
    return where.host, where.port


def run(args: argparse.Namespace) -> int:
    try:
        return asyncio.run(_serve(args))
    except ConfigError as exc:
        print(f"uss web: {exc}", file=sys.stderr)
        return EXIT_USAGE


async def _serve(args: argparse.Namespace) -> int:
    from pyuss.web import require

    require()
    from pyuss.web.backend import DEMO_DRIVES, Backend, DriveSpec
    from pyuss.web.guard import is_loopback
    from pyuss.web.server import WebServer

    host, port = parse_listen(args.listen)
    if not args.timeout > 0:
        raise ConfigError(f"--timeout {args.timeout}: must be > 0 seconds")
    if args.profile not in (None, "auto"):
        try:
            get_profile(args.profile)  # NAME or NAME@EDITION
        except ConfigError as exc:
            raise ConfigError(
                f"--profile {args.profile!r}: one of {', '.join(profile_names())} (NAME@EDITION "
                f"for an edition of its manual) or auto ({exc})"
            ) from None
    token = args.token
    if token is not None and not token.strip():
        raise ConfigError("--token must not be empty")
    if token is None and not is_loopback(host):
        token = secrets.token_urlsafe(18)
    if args.mqtt is not None:
        if args.address or args.line or args.profile or args.layout or args.baud:
            raise ConfigError(
                "--mqtt shows the drives the gateways publish: leave out --address, --line, "
                "--profile, --layout and --baud"
            )
        remote = _remote_plant(args)  # the mqtt extra checked first
        from pyuss.web.plant import PlantBackend

        plant_backend = PlantBackend(remote)
        return await _run(plant_backend, WebServer(
            plant_backend, host=host, port=port, token=token, read_only=args.read_only
        ), token, args.read_only)  # fmt: skip
    args.line_profile = None
    if args.demo:
        if args.address or args.line:
            raise ConfigError("--demo brings its own drives: leave out --address and --line")
        backend = Backend(demo=True, job_timeout=args.timeout)
        specs = list(DEMO_DRIVES)
    else:
        specs = [DriveSpec(a, p, layout) for a, p, layout in await _drives(args)]
        backend = Backend(port=args.port, baud=args.baud, drives=specs, job_timeout=args.timeout)
    scan = scan_profile(args.profile, args.line_profile, [spec.profile for spec in specs])
    server = WebServer(
        backend, host=host, port=port, token=token, read_only=args.read_only, scan_profile=scan
    )
    return await _run(backend, server, token, args.read_only)


async def _run(backend: Any, server: Any, token: str | None, read_only: bool) -> int:
    await backend.start()
    try:
        url = await server.start()
        print(url, flush=True)
        if token is not None:
            print(f"token: {token} (needed for every request; part of the address above)")
        mode = "read-only, " if read_only else ""
        print(f"{mode}serving {backend.port}; Ctrl+C stops", flush=True)
        lost: asyncio.Event | None = getattr(backend, "lost", None)  # (a line's, not a plant's)
        if await _wait_for_stop(lost):
            return EXIT_FAILED  # the bus's log line says why
    finally:
        await server.close()
        await backend.close()
    return EXIT_OK


WEB_KEYS = ("mqtt", "username", "password", "ca", "cert", "key", "insecure", "prefix", "keepalive")
"""The keys of the ``[web]`` table of the configuration file (the broker of ``--mqtt``)."""


def _remote_plant(args: argparse.Namespace) -> Any:
    """The `pyuss.plant.remote.RemotePlant` of ``--mqtt``: the broker and its options from the
    URL, the ``--mqtt-*`` options and the ``[web]`` table of the configuration file (the
    options win over the file); the mqtt extra is needed."""
    from pyuss.gateway.extras import MissingExtra, require

    try:
        require("mqtt")
    except MissingExtra as exc:
        raise ConfigError(f"--mqtt: {exc}") from None
    from pyuss.gateway.options import mqtt_options
    from pyuss.lines import find
    from pyuss.points.config import Where
    from pyuss.userfile import parse_toml, read_text

    table: dict[str, Any] = {}
    path = find(args.config)
    base = None
    if path is not None:
        data = parse_toml(read_text(path, "the configuration"), str(path))
        web = data.get("web", {})
        try:
            table = dict(Where("web").table(web, WEB_KEYS))
        except ConfigError as exc:
            raise ConfigError(f"{path}: {exc}") from None
        base = path.parent
    if args.mqtt:
        table["mqtt"] = args.mqtt
    if not table.get("mqtt"):
        raise ConfigError("--mqtt: give the broker's URL (mqtt://HOST:PORT) or [web] mqtt")
    given = {
        "username": args.mqtt_user,
        "password": args.mqtt_password,
        "ca": args.mqtt_ca,
        "cert": args.mqtt_cert,
        "key": args.mqtt_key,
        "prefix": args.mqtt_prefix,
        "insecure": args.mqtt_insecure or None,
    }
    table.update({key: value for key, value in given.items() if value is not None})
    table["broker"] = table.pop("mqtt")
    where = Where("web") if path is None or args.mqtt else Where(f"{path}: web")
    try:
        options = mqtt_options(table, where, base)
    except ConfigError as exc:
        message = str(exc).replace("web.broker", "--mqtt" if args.mqtt else "web.mqtt")
        raise ConfigError(message) from None
    from pyuss.plant.remote import RemotePlant

    return RemotePlant(options, timeout=max(args.timeout, 5.0))


async def _drives(args: argparse.Namespace) -> list[tuple[int, str | None, Layout | None]]:
    """The line (``args.port``, ``args.baud`` filled from the configuration file where not
    given) and its drives to show: address, profile and layout of each. Those of ``--address``
    (a number or a name of the file), else the drives of the file's line; ``--profile`` and
    ``--layout`` win over the file's; ``--profile auto`` asks each drive its family."""
    named = [a for a in args.address if isinstance(a, str)]
    drives: list[tuple[int, str | None, str | None]] = [
        (a, None, None) for a in args.address if isinstance(a, int)
    ]
    if args.config is not None or args.line is not None or named or args.port is None:
        lines = line_file(args, named[0] if named else None)
        if lines is None:
            raise ConfigError(
                "give --port URL or --demo, or name the line in a configuration file "
                "(docs/lines.md)"
            )
        port_given = args.port is not None
        targets = [lines.target(args.line, str(a), port_given=port_given) for a in args.address]
        if not targets:
            targets = [lines.target(args.line, None, port_given=port_given)]
        line = targets[0].line
        if any(t.line is not line for t in targets):
            raise ConfigError(
                "the drives given are on different lines of the configuration file: "
                "uss web shows one line (--line NAME)"
            )
        if line is not None:
            args.port = args.port or line.port
            args.baud = args.baud or line.baud
            args.line_profile = line.profile if line.name in lines.profiles else None
            if not args.address:
                targets = lines.targets(line)
        drives = [(t.address, t.profile, t.layout) for t in targets if t.address is not None]
    args.baud = args.baud or 9600
    port, baud = args.port, args.baud
    found: list[tuple[int, str | None, Layout | None]] = []
    for number, profile, layout_text in drives:
        text = args.layout or layout_text
        layout = Layout.parse(text) if text else None
        profile = args.profile or profile  # None: a drive of unknown kind
        if profile == "auto":
            from pyuss.master.identify import identify_family
            from pyuss.transport.url import open_transport

            profile, layout = await identify_family(
                lambda: open_transport(port, baud=baud),
                number,
                layout,
                job_timeout=args.timeout,
                unknown=lambda text: print(f"uss web: {text}", file=sys.stderr),
            )
        found.append((number, profile, layout))
    if args.profile == "auto" and not found:
        raise ConfigError("--profile auto: give the drives (--address, or a line with drives)")
    return list({a: (a, p, layout) for a, p, layout in found}.values())


def scan_profile(given: str | None, line: str | None, drives: Sequence[str | None]) -> str:
    """The profile the page's scan probes by unless the page names another: ``--profile``
    (not auto), else the one the configuration file names for the line, else the one all
    the line's drives have (as ``uss scan --save`` writes them, or as ``--profile auto``
    found them), else "generic"."""
    if given not in (None, "auto"):
        return str(given)
    if line is not None:
        return line
    shared = set(drives)
    only = shared.pop() if len(shared) == 1 else None
    return only if only is not None else "generic"


async def _wait_for_stop(lost: asyncio.Event | None = None) -> bool:
    """Wait for Ctrl+C or SIGTERM, or ``lost``; whether it was ``lost``."""
    with stop_on_signals() as stop:
        waits = {asyncio.ensure_future(stop.wait())}
        if lost is not None:
            waits.add(asyncio.ensure_future(lost.wait()))
        try:
            await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for wait in waits:
                wait.cancel()
        return lost is not None and lost.is_set()
