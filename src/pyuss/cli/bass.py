"""Read and write operating data of Baumueller drives over their BASS service interface
(RS-232), or simulate drives on a BASS ring (Baumueller communication software manual,
chapter 1).

    uss bass read  ADDRESS ID        --port URL [--baud 9600] [--timeout S] [--retries N]
                                     [--signed] [--json]
    uss bass write ADDRESS ID VALUE  --port URL [...] [--digits 4|8] [--json]
    uss bass ring  --pty | --listen tcp-listen://127.0.0.1:PORT
                   [--drives 1,2,3] [--locked ADDRESS]... [--duration S]

ADDRESS is the drive's DIP address 0..255, ID the parameter ID 0..65535, VALUE a number
(decimal, 0x hex, negative allowed); all accept 0x hex. The port is opened 8N1 (manual 1).
``ring`` runs simulated drives on a closed RS-232 loop (manual 1.4.2): it prints where a PC
can reach it (a pty device path, or tcp://HOST:PORT for ``--port``) and serves until SIGINT or
SIGTERM, which are the normal end (exit 0). Each drive has IDs 170, 171, 126 and the IDs 2 and
51 of the manual's examples.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import sys
from collections.abc import Callable
from typing import Any

from pyuss.bass.codec import BAUD, BassRequest
from pyuss.bass.errors import BassTelegramError
from pyuss.bass.master import DEFAULT_RETRIES, DEFAULT_TIMEOUT, BassExchange, BassMaster
from pyuss.bass.ring import MAX_STATIONS, BassRing, DictOperatingData, demo_elements
from pyuss.cli._help import actions, subcommand
from pyuss.cli._output import EXIT_FAILED, EXIT_OK, EXIT_USAGE, print_error
from pyuss.errors import ConfigError, UssError
from pyuss.protocol.timing import BAUD_RATES
from pyuss.system import stop_on_signals
from pyuss.transport import PtyPort, TcpServerTransport, Transport, open_transport


def _number(text: str, what: str, low: int, high: int) -> int:
    try:
        value = int(text, 0)
    except ValueError:
        raise ConfigError(f"{what} {text!r} is not a number") from None
    if not low <= value <= high:
        raise ConfigError(f"{what} {value} is outside {low}..{high}")
    return value


def _address(text: str) -> int:
    return _number(text, "address", 0, 0xFF)


def _ident(text: str) -> int:
    return _number(text, "ID", 0, 0xFFFF)


def _value(text: str) -> int:
    return _number(text, "value", -0x8000_0000, 0xFFFF_FFFF)


def _drives(text: str) -> list[int]:
    addresses = [_address(part.strip()) for part in text.split(",") if part.strip()]
    if not 1 <= len(addresses) <= MAX_STATIONS:
        raise ConfigError(f"a ring has 1 to {MAX_STATIONS} drives, not {len(addresses)}")
    return addresses


def _port_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--port",
        required=True,
        metavar="URL",
        help="the RS-232 line to the drives: a serial port (/dev/ttyUSB0, COM3), a pty or "
        "tcp://HOST:PORT",
    )
    parser.add_argument(
        "--baud",
        type=int,
        default=BAUD,
        help=f"baud rate: {', '.join(map(str, BAUD_RATES))} (BASS drives run at 9600, the "
        "default; manual 1)",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT,
        help="seconds to wait for the echo and the answer of each attempt (default 1)",
    )
    parser.add_argument(
        "--retries",
        type=int,
        default=DEFAULT_RETRIES,
        help="send the request again this many times when no answer comes (default 2)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help='print one JSON object for scripts; failures as {"ok": false, "error": '
        "{...}} (docs/master.md, JSON output)",
    )


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers,
        "bass",
        "Baumueller BASS service protocol (RS-232): read, write, simulated ring",
        __doc__,
    )
    sub = actions(parser, "bass_command")

    read = sub.add_parser(
        "read", help="read one element of a drive's operating data (command 003C, manual 1.2)"
    )
    read.add_argument("address", metavar="ADDRESS", help="the drive's DIP address, 0..255")
    read.add_argument("ident", metavar="ID", help="the parameter ID, 0..65535, e.g. 170")
    read.add_argument("--signed", action="store_true", help="show the value as a signed number")
    _port_options(read)
    read.set_defaults(func=_cmd_read)

    write = sub.add_parser(
        "write", help="write one element of a drive's operating data (command 003E, manual 1.2)"
    )
    write.add_argument("address", metavar="ADDRESS", help="the drive's DIP address, 0..255")
    write.add_argument("ident", metavar="ID", help="the parameter ID, 0..65535, e.g. 2")
    write.add_argument("value", metavar="VALUE", help="the value, e.g. 7500, -5 or 0x1D4C")
    write.add_argument(
        "--digits",
        type=int,
        choices=(4, 8),
        help="send the value as 4 hex digits (one word) or 8 (a double word); default: as "
        "few as it needs",
    )
    _port_options(write)
    write.set_defaults(func=_cmd_write)

    ring = sub.add_parser(
        "ring", help="simulate drives on a closed RS-232 loop, until stopped (manual 1.4.2)"
    )
    ring.add_argument(
        "--drives",
        default="1",
        metavar="LIST",
        help="the drives' DIP addresses in wiring order, e.g. 1,2,3 (default 1)",
    )
    where = ring.add_mutually_exclusive_group()
    where.add_argument(
        "--listen",
        metavar="URL",
        help="serve as a TCP server, tcp-listen://127.0.0.1:PORT (PORT 0: any free one); "
        "tcp://HOST:PORT is printed",
    )
    where.add_argument(
        "--pty",
        action="store_true",
        help="serve on a new pseudo-terminal; its path is printed",
    )
    ring.add_argument(
        "--locked",
        action="append",
        default=[],
        metavar="ADDRESS",
        help="a drive that refuses BASS writes (ID 126 bit 0 clear, error 5); repeatable",
    )
    ring.add_argument(
        "--duration", type=float, metavar="SECONDS", help="stop by itself after SECONDS"
    )
    ring.set_defaults(func=_cmd_ring)


def _run(args: argparse.Namespace, job: Callable[[argparse.Namespace], int]) -> int:
    try:
        return job(args)
    except ConfigError as exc:
        return _failed(args, exc, EXIT_USAGE)
    except UssError as exc:  # a refusal, no answer, a line that failed
        return _failed(args, exc, EXIT_FAILED)


def _failed(args: argparse.Namespace, exc: UssError, code: int) -> int:
    """One line on stderr; with ``--json`` the JSON error object of every command on stdout,
    beside ``"ok": false``."""
    if getattr(args, "json", False):
        print_error(exc, code, ok=False)
    else:
        print(f"uss bass {args.bass_command}: {exc}", file=sys.stderr)
    return code


async def _exchange(args: argparse.Namespace, request: BassRequest) -> BassExchange:
    transport = open_transport(args.port, baud=args.baud, parity="N")
    async with transport:
        master = BassMaster(transport, timeout=args.timeout, retries=args.retries)
        return await master.exchange(request)


def _report(args: argparse.Namespace, request: BassRequest, value: int | None) -> int:
    try:
        exchange = asyncio.run(_exchange(args, request))
    except ConfigError:
        raise
    except UssError as exc:  # refused, no answer, the line failed: the request is known
        if not args.json:
            raise
        print_error(exc, EXIT_FAILED, ok=False, address=request.address, id=request.ident)
        return EXIT_FAILED
    answer = exchange.answer
    if value is None:
        value = answer.to_int(signed=args.signed)
    result = {"ok": True, "address": request.address, "id": request.ident, "value": value}
    if args.json:
        print(json.dumps(result | {"data": answer.data, "attempts": exchange.attempts}))
    else:
        print(f"{value} (0x{answer.data})" if answer.data else str(value))
    return EXIT_OK


def _check_link(args: argparse.Namespace) -> None:
    if args.baud not in BAUD_RATES:
        rates = ", ".join(map(str, BAUD_RATES))
        raise ConfigError(f"--baud {args.baud} is not one of {rates} (BASS drives: 9600)")
    if not args.timeout > 0:
        raise ConfigError(f"--timeout must be positive, not {args.timeout}")
    if args.retries < 0:
        raise ConfigError(f"--retries must be 0 or more, not {args.retries}")


def _cmd_read(args: argparse.Namespace) -> int:
    def job(args: argparse.Namespace) -> int:
        _check_link(args)
        request = BassRequest.read(_address(args.address), _ident(args.ident))
        return _report(args, request, None)

    return _run(args, job)


def _cmd_write(args: argparse.Namespace) -> int:
    def job(args: argparse.Namespace) -> int:
        _check_link(args)
        value = _value(args.value)
        try:
            request = BassRequest.write(
                _address(args.address), _ident(args.ident), value, args.digits
            )
        except BassTelegramError as exc:
            raise ConfigError(str(exc)) from None
        return _report(args, request, value)

    return _run(args, job)


async def _serve_ring(ring: BassRing, transport: Transport, duration: float | None) -> int:
    with stop_on_signals() as stop:
        async with ring.serving(transport):
            if isinstance(transport, PtyPort):
                print(transport.device_path)
            elif isinstance(transport, TcpServerTransport):
                print(f"tcp://{transport.host}:{transport.port}")
            sys.stdout.flush()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(duration):
                    await stop.wait()
    answered = ", ".join(f"drive {s.address}: {s.answered}" for s in ring.stations)
    print(f"uss bass ring: requests answered: {answered}", file=sys.stderr)
    return EXIT_OK


def _cmd_ring(args: argparse.Namespace) -> int:
    def job(args: argparse.Namespace) -> int:
        addresses = _drives(args.drives)
        locked = {_address(a) for a in args.locked}
        if not locked <= set(addresses):
            missing = ", ".join(str(a) for a in sorted(locked - set(addresses)))
            raise ConfigError(f"--locked {missing}: no such drive on the ring")
        if args.duration is not None and not args.duration > 0:
            raise ConfigError(f"--duration {args.duration}: must be > 0 seconds")
        ring = BassRing(
            [
                DictOperatingData(a, demo_elements(), write_authority=a not in locked)
                for a in addresses
            ]
        )
        transport: Transport
        if args.listen is not None:
            if not args.listen.lower().startswith("tcp-listen://"):
                raise ConfigError(f"--listen {args.listen!r}: expected tcp-listen://HOST:PORT")
            transport = open_transport(args.listen, baud=BAUD, parity="N")
        elif args.pty:
            transport = PtyPort(baud=BAUD)
        else:
            raise ConfigError("nothing to serve: give --pty or --listen tcp-listen://HOST:PORT")
        return asyncio.run(_serve_ring(ring, transport, args.duration))

    return _run(args, job)
