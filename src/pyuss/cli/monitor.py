"""Listen to a USS line without ever sending, and show what goes over it in words.

    uss monitor --port /dev/ttyUSB0 --baud 19200                      # 2-wire, layouts inferred
    uss monitor --port /dev/ttyUSB0 --baud 19200 --layout 3,2 --layout 7=v,0
    uss monitor --port /dev/ttyUSB0 --port-rx /dev/ttyUSB1 --baud 9600   # 4-wire: two ports
    uss monitor --port bus://127.0.0.1:4000 --baud 19200 --write line.pcapng --summary
    uss monitor --read line.pcapng                                       # replay a capture

Prints one line per exchange (request and answer): time, address, layout, the parameter job
and its answer in words, control and status words with the bits that changed, setpoint and
actual value, response delay, and every error after ``!!``; ``(unsure: ...)`` when the
pairing on a 2-wire line is a guess and a ``?`` after the layout when the layout is. With
``--json`` one JSON object per exchange instead; with ``--summary`` a table per address
(the counters of USS specification A 5.2.3, error rates, response times), refreshed every
``--interval`` seconds. At the end the summary table goes to stderr (stdout with ``--summary``).

``--port`` is master to slave (on a 2-wire line: everything), ``--port-rx`` (or a second
``--port``) slave to master on a 4-wire line. A ``bus://`` station joins the virtual bus
listen-only. Serial ports, ptys and ``tcp://`` stamp bytes when they are read (USB adapters
deliver every 1 to 16 ms), so timing is judged with a tolerance of 20 ms there
(``--tolerance MS``; 0 on ``bus://``, whose timestamps are exact): a late burst does not cut a
telegram, and an answer read together with its request still had its start pause. ``--gap MS``
is the idle time that starts a telegram (default: the start pause of 2 character times, USS
specification A 5.1.2). ``--write FILE`` saves a capture: ``*.pcapng`` for Wireshark
(``uss wireshark install``) or ``*.jsonl``; ``--read FILE`` replays one (or a
``uss bus --record`` recording) through the same decoder.

Without ``--port`` (or with ``--config FILE`` or ``--line NAME``) the line comes from the
configuration file that ``uss scan --save`` writes (docs/lines.md): its port and baud rate,
the layout of each drive it names, and each drive's profile for its parameter names and
values; options given win over the file (``--profile`` for every drive, ``--layout`` for all
layouts). ``uss monitor`` bare in a folder with ``uss.toml`` listens to its line.

Runs until Ctrl-C (or SIGTERM, ``--duration``, ``--count``, the end of ``--read``): exit code
0. A port that fails gives exit code 1, bad arguments or files exit code 2.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import sys
import time
import urllib.parse
from collections.abc import Callable, Iterable
from typing import Any, TextIO

from pyuss._tasks import cancel_and_wait
from pyuss.cli._help import subcommand
from pyuss.cli._master import add_line_options, line_file
from pyuss.cli._output import EXIT_FAILED, EXIT_OK, EXIT_USAGE, error_object, wall_clock
from pyuss.cli.monitor_output import ProfileValues, exchange_json
from pyuss.errors import ConfigError, TransportError
from pyuss.lines import looked_in
from pyuss.monitor.capture import CaptureWriter, open_writer, read_capture
from pyuss.monitor.core import Monitor, default_gap
from pyuss.monitor.infer import LayoutBook
from pyuss.monitor.live import Listener, replay, watch
from pyuss.monitor.model import Exchange
from pyuss.monitor.pcapng import check_linktype
from pyuss.monitor.render import exchange_line, summary_table
from pyuss.protocol.timing import BAUD_RATES, check_baud
from pyuss.system import clock, stop_on_signals
from pyuss.transport.base import STAMP_TOLERANCE
from pyuss.transport.url import open_transport

__all__ = ["register", "run"]

_CLEAR = "\x1b[H\x1b[2J"


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers,
        "monitor",
        "listen to a USS line, decode and pair telegrams, write captures",
        __doc__,
    )
    source = parser.add_argument_group("what to listen to")
    source.add_argument(
        "--port",
        action="append",
        default=[],
        metavar="URL",
        help="the port to listen on: a serial port (/dev/ttyUSB0), tcp://HOST:PORT or "
        "bus://HOST:PORT; on a 4-wire line the master-to-drive pair (a second --port is "
        "--port-rx)",
    )
    source.add_argument(
        "--port-rx",
        metavar="URL",
        help="the port on the drive-to-master pair of a 4-wire line",
    )
    source.add_argument(
        "--read",
        metavar="FILE",
        help="decode a capture (*.pcapng, *.jsonl) or a uss bus --record file instead",
    )
    source.add_argument(
        "--baud",
        type=int,
        help=f"baud rate of the line: {', '.join(map(str, BAUD_RATES))} (USS specification "
        "B 2.4; needed with --port, unless the configuration file's line gives it)",
    )
    add_line_options(source)
    decode = parser.add_argument_group("decoding")
    decode.add_argument(
        "-l",
        "--layout",
        action="append",
        default=[],
        metavar="[ADR=]PKW,PZD",
        help="telegram layout of every drive (3,2) or of some (5=4,2; 1+2=v,0): number of PKW "
        "and PZD words; the others are worked out from the traffic (USS specification C 7)",
    )
    decode.add_argument(
        "--profile",
        metavar="NAME",
        help="device profile, for parameter numbers from 2000 on in the IND page bits "
        "(micromaster4: P2010 rather than PNU 10) and parameter values typed and scaled by its "
        "parameter file (P1120 = 10.00 s)",
    )
    decode.add_argument(
        "--gap",
        type=float,
        metavar="MS",
        help="idle time on the line that starts a new telegram (default: the start pause of 2 "
        "characters; USS specification A 5.1.2)",
    )
    decode.add_argument(
        "--tolerance",
        type=float,
        metavar="MS",
        help="how late the port may stamp a byte: timing is judged beyond it (default 20 ms; "
        "0 on bus://, exact timestamps)",
    )
    decode.add_argument(
        "--response-limit",
        type=float,
        metavar="MS",
        help="report an answer as missing when it has not begun MS after its request "
        "(default 20, at least the start pause; USS specification A 5.2.1.1)",
    )
    decode.add_argument(
        "--late-limit",
        type=float,
        metavar="MS",
        help="an answer up to this long after its request counts as late, not missing "
        "(default 10 x the response limit)",
    )
    output = parser.add_argument_group("output")
    output.add_argument(
        "-w",
        "--write",
        action="append",
        default=[],
        metavar="FILE",
        help="save what was seen to FILE: *.pcapng opens in Wireshark, *.jsonl is JSON lines "
        "(repeatable)",
    )
    output.add_argument(
        "--linktype",
        type=int,
        metavar="N",
        help="link type written into pcapng captures, 147..162 (default 147, LINKTYPE_USER0; "
        "the dissector of uss wireshark install decodes it)",
    )
    output.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object per exchange for scripts (keys in docs/monitor.md)",
    )
    output.add_argument(
        "--summary",
        action="store_true",
        help="show a table per address instead: counters, error rates, response times (USS "
        "specification A 5.2.3)",
    )
    output.add_argument(
        "--interval",
        type=float,
        default=1.0,
        metavar="S",
        help="refresh the summary every S seconds (default 1)",
    )
    output.add_argument(
        "--time",
        choices=("rel", "abs"),
        default="rel",
        help="show times as seconds since the first telegram (rel, the default) or as the time "
        "of day (abs)",
    )
    output.add_argument(
        "--color",
        choices=("auto", "always", "never"),
        default="auto",
        help="highlight errors in colour (default: when stdout is a terminal)",
    )
    stop = parser.add_argument_group("stopping")
    stop.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    stop.add_argument("--count", type=int, metavar="N", help="stop after N exchanges")
    parser.set_defaults(func=run)


def json_error_line(error: dict[str, Any]) -> dict[str, Any]:
    """A failure in the stream of ``--json`` lines: the keys of an exchange (null), the time
    now and ``error`` (the JSON error object of every command)."""
    keys = (
        "index", "t", "kind", "address", "mode", "layout", "layout_source", "request",
        "answer", "delay_ms", "problems", "unsure", "notes", "summary",
    )  # fmt: skip
    line: dict[str, Any] = dict.fromkeys(keys)
    line.update(time=wall_clock(), error=error)
    return line


def _fail(args: argparse.Namespace, exc: BaseException, code: int) -> int:
    """A failure: one line on stderr, or with ``--json`` a line of the stream."""
    if args.json:
        with contextlib.suppress(BrokenPipeError):
            print(json.dumps(json_error_line(error_object(exc, code))), flush=True)
    else:
        print(f"uss monitor: {exc}", file=sys.stderr)
    return code


def _tolerance(args: argparse.Namespace, default: float) -> float:
    if args.tolerance is None:
        return default
    value = float(args.tolerance)
    if not 0 <= value < float("inf"):
        raise ConfigError(f"--tolerance {args.tolerance}: must be >= 0 milliseconds")
    return value / 1000


def _ms(value: float | None, option: str) -> float | None:
    if value is None:
        return None
    if not value > 0 or value != value or value == float("inf"):
        raise ConfigError(f"{option} {value}: must be a positive number of milliseconds")
    return value / 1000


def _listen_only(url: str) -> str:
    """A ``bus://`` URL as a listen-only station (the monitor never sends), whatever the
    URL's own ``listen_only`` says."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme.lower() != "bus":
        return url
    query = [
        (key, value)
        for key, value in urllib.parse.parse_qsl(parts.query, keep_blank_values=True)
        if key != "listen_only"
    ]
    query.append(("listen_only", "1"))
    return urllib.parse.urlunsplit(parts._replace(query=urllib.parse.urlencode(query)))


class _Output:
    """Prints exchanges (or keeps the summary), writes captures, counts."""

    def __init__(
        self,
        args: argparse.Namespace,
        monitor: Monitor,
        writers: list[CaptureWriter],
        stream: TextIO,
        epoch: float,
        wall: float | None = None,
    ) -> None:
        self.args = args
        self.monitor = monitor
        self.writers = writers
        self.stream = stream
        self.epoch = epoch
        self.wall = wall
        """What turns the monitor's times into Unix time (None: not known)."""
        self.origin: float | None = None
        self.count = 0
        self.closed = False
        self.done: Callable[[], None] = lambda: None
        color = args.color == "always" or (args.color == "auto" and stream.isatty())
        self.color = color and not args.json
        self._values: dict[str, ProfileValues] = {}
        """The value texts of each profile the line's drives are decoded by."""

    def __call__(self, exchanges: Iterable[Exchange]) -> None:
        for ex in exchanges:
            if self.args.count is not None and self.count >= self.args.count:
                self.done()
                return
            self.count += 1
            for writer in self.writers:
                writer.write(ex)
            if self.origin is None:
                self.origin = ex.time
            if not self.args.summary:
                self.show(self.render(ex) + "\n")
            if self.args.count is not None and self.count >= self.args.count:
                self.done()
        self.show("")

    def show(self, text: str) -> None:
        """Write to the output; a reader that went away (``| head``) ends the run quietly."""
        if self.closed:
            return
        try:
            self.stream.write(text)
            self.stream.flush()
        except BrokenPipeError:
            self.closed = True
            with contextlib.suppress(OSError, ValueError):
                os.dup2(os.open(os.devnull, os.O_WRONLY), self.stream.fileno())
            self.done()

    def decoding(self, address: int | None) -> tuple[int | None, ProfileValues | None]:
        """The page size and value texts of the drive at ``address`` (`drive_profile`)."""
        name = drive_profile(self.args, address)
        if name is not None and name not in self._values:
            self._values[name] = ProfileValues(name)
        return page_size(self.args, address), None if name is None else self._values[name]

    def render(self, ex: Exchange) -> str:
        assert self.origin is not None
        pages, known = self.decoding(ex.address)
        if self.args.json:
            return json.dumps(
                exchange_json(ex, origin=self.origin, epoch=self.wall, page_size=pages, known=known)
            )
        if self.args.time == "abs":
            return exchange_line(
                ex, origin=self.epoch, absolute=True, color=self.color, page_size=pages, known=known
            )
        return exchange_line(ex, origin=self.origin, color=self.color, page_size=pages, known=known)

    def table(self) -> str:
        now = self.monitor.now
        return summary_table(self.monitor.summary, 0.0 if now is None else now)


def _open_writers(
    paths: list[str],
    baud: int,
    four_wire: bool,
    epoch: float,
    args: argparse.Namespace,
    monitor: Monitor,
) -> list[CaptureWriter]:
    writers: list[CaptureWriter] = []
    try:
        for path in paths:
            writers.append(
                open_writer(
                    path,
                    baud=baud,
                    four_wire=four_wire,
                    epoch=epoch,
                    linktype=args.linktype,
                    gap=monitor.gap,
                    tolerance=monitor.tolerance,
                    profile=args.profile,
                )
            )
    except ConfigError:
        for writer in writers:
            writer.discard()
        raise
    return writers


def _finish(writers: list[CaptureWriter]) -> None:
    errors = []
    for writer in writers:
        try:
            writer.close()
        except ConfigError as exc:
            errors.append(str(exc))
    if errors:
        raise ConfigError("; ".join(errors))


def page_size(args: argparse.Namespace, address: int | None = None) -> int | None:
    """Parameter numbers per IND page of the devices of ``--profile`` (or of the profile the
    configuration file names for the drive at ``address``; None: no paging)."""
    name = drive_profile(args, address)
    if name is None:
        return None
    from pyuss.profiles import get_profile

    return get_profile(name).pnu_page_size


def drive_profile(args: argparse.Namespace, address: int | None) -> str | None:
    """The profile the drive at ``address`` is decoded by: ``--profile``, else the one the
    configuration file names for it (`use_line`), else none."""
    given: str | None = getattr(args, "profile", None)
    if given is not None or address is None:
        return given
    profiles: dict[int, str | None] = getattr(args, "drive_profiles", {})
    return profiles.get(address, getattr(args, "line_profile", None))


def use_line(args: argparse.Namespace) -> None:
    """Take what is not given from the configuration file's line (docs/lines.md), as the
    commands that talk to drives do (`pyuss.cli._master.use_lines`): the port and baud rate
    (not with ``--read``), the layouts of the line and of each drive (unless ``--layout`` is
    given) and each drive's profile (``args.drive_profiles``; ``--profile`` wins for all).
    The file is read when ``--config`` or ``--line`` is given, or neither ``--port`` nor
    ``--read``."""
    args.drive_profiles, args.line_profile = {}, None
    listening = bool(args.port) or args.port_rx is not None or args.read is not None
    if args.config is None and args.line is None and listening:
        return
    lines = line_file(args, None)
    if lines is None:
        return
    line = lines.target(args.line, None, port_given=listening).line
    if line is None:
        return
    if args.read is None:
        args.port = args.port or [line.port]
        args.baud = line.baud if args.baud is None else args.baud
    drives = lines.targets(line)
    if not args.layout:
        every = [] if line.layout is None else [str(line.layout)]
        own = [f"{t.address}={t.drive.layout}" for t in drives if t.drive and t.drive.layout]
        args.layout = every + own
    args.drive_profiles = {t.address: t.profile for t in drives if t.address is not None}
    args.line_profile = line.profile if line.name in lines.profiles else None
    families = {*args.drive_profiles.values(), args.line_profile} - {None}
    if args.profile is None and len(families) == 1 and None not in args.drive_profiles.values():
        args.profile = families.pop()  # one family on the line: its captures say so too


def _check(args: argparse.Namespace) -> tuple[list[str], LayoutBook]:
    use_line(args)
    for address in (None, *args.drive_profiles):
        page_size(args, address)  # an unknown profile is bad input
    ports = list(args.port)
    if args.port_rx is not None:
        ports.append(args.port_rx)
    if args.read is not None and ports:
        raise ConfigError("give either --read FILE or --port URL, not both")
    if args.read is None and not ports:
        raise ConfigError(
            "nothing to listen to: give --port URL (and --port-rx URL) or --read, or name the "
            f"line in a configuration file (none found: {looked_in()})"
        )
    if len(ports) > 2:
        raise ConfigError("at most two ports: --port (master to slave) and --port-rx")
    if ports and args.baud is None:
        raise ConfigError("--baud is needed with --port")
    if args.baud is not None:
        check_baud(args.baud)
    if args.linktype is not None:
        check_linktype(args.linktype)
    if args.count is not None and args.count < 1:
        raise ConfigError(f"--count {args.count}: must be at least 1")
    if args.duration is not None and not args.duration > 0:
        raise ConfigError(f"--duration {args.duration}: must be > 0 seconds")
    if not args.interval > 0:
        raise ConfigError(f"--interval {args.interval}: must be > 0 seconds")
    if len(set(map(os.path.abspath, args.write))) != len(args.write):
        raise ConfigError("--write: the same file is given twice")
    return ports, LayoutBook.parse(args.layout)


def _monitor(
    args: argparse.Namespace,
    baud: int,
    four_wire: bool,
    layouts: LayoutBook,
    gap: float | None,
    tolerance: float,
) -> Monitor:
    return Monitor(
        baud,
        four_wire=four_wire,
        layouts=layouts,
        gap=default_gap(baud) if gap is None else gap,
        response_limit=_ms(args.response_limit, "--response-limit"),
        late_limit=_ms(args.late_limit, "--late-limit"),
        tolerance=tolerance,
    )


def run(args: argparse.Namespace) -> int:
    try:
        ports, layouts = _check(args)
        if args.read is not None:
            capture = read_capture(args.read)
            if args.profile is None and capture.profile is not None:
                args.profile = capture.profile  # decoded as when it was captured
                try:
                    page_size(args)
                except ConfigError as exc:
                    raise ConfigError(
                        f"{args.read}: captured with --profile {capture.profile}: {exc}; give "
                        "--profile NAME"
                    ) from None
            if args.baud is not None and args.baud != capture.baud:
                raise ConfigError(
                    f"--baud {args.baud}: the capture {args.read} is at {capture.baud} baud"
                )
            gap = capture.gap if args.gap is None else _ms(args.gap, "--gap")
            tolerance = _tolerance(args, capture.tolerance)
            monitor = _monitor(args, capture.baud, False, layouts, gap, tolerance)
            writers = _open_writers(
                args.write, capture.baud, capture.four_wire, capture.epoch, args, monitor
            )
        else:
            urls = [_listen_only(url) for url in ports]
            gap = _ms(args.gap, "--gap")
            transports = [Listener(open_transport(u, baud=args.baud)) for u in urls]
            exact = all(t.exact_timestamps for t in transports)
            tolerance = _tolerance(args, 0.0 if exact else STAMP_TOLERANCE)
            monitor = _monitor(args, args.baud, len(urls) == 2, layouts, gap, tolerance)
            epoch = time.time() - clock()
            writers = _open_writers(args.write, args.baud, len(urls) == 2, epoch, args, monitor)
    except ConfigError as exc:
        return _fail(args, exc, EXIT_USAGE)
    stream = sys.stdout
    if args.read is not None:
        # Captures hold Unix times; a bus recording counts from the bus's start.
        wall = None if capture.kind == "bus recording" else capture.epoch
        output = _Output(args, monitor, writers, stream, capture.epoch, wall)
        return _replay(args, capture, monitor, output, writers)
    output = _Output(args, monitor, writers, stream, epoch, epoch)
    try:
        code = asyncio.run(_live(args, monitor, transports, urls, output))
    except BaseException:
        for writer in writers:
            writer.discard()
        raise
    try:
        _finish(writers)
    except ConfigError as exc:
        return _fail(args, exc, EXIT_FAILED)
    if code == EXIT_OK or output.count:
        _final_summary(args, output)
    return code


def _final_summary(args: argparse.Namespace, output: _Output) -> None:
    table = output.table()
    if args.summary:
        output.show((_CLEAR if output.stream.isatty() else "") + table + "\n")
    else:
        print(table, file=sys.stderr)


def _replay(
    args: argparse.Namespace,
    capture: Any,
    monitor: Monitor,
    output: _Output,
    writers: list[CaptureWriter],
) -> int:
    stopped = False

    def done() -> None:
        nonlocal stopped
        stopped = True

    output.done = done
    try:
        for exchange in replay(capture, monitor):
            output([exchange])
            if stopped:
                break
        _finish(writers)
    except ConfigError as exc:
        for writer in writers:
            writer.discard()
        return _fail(args, exc, EXIT_USAGE)
    except BaseException:
        for writer in writers:
            writer.discard()
        raise
    _final_summary(args, output)
    return EXIT_OK


async def _live(
    args: argparse.Namespace,
    monitor: Monitor,
    transports: list[Listener],
    urls: list[str],
    output: _Output,
) -> int:
    loop = asyncio.get_running_loop()
    with stop_on_signals() as stop:
        output.done = stop.set
        opened: list[Listener] = []
        refresher = None
        try:
            try:
                for transport in transports:
                    await transport.open()
                    opened.append(transport)
            except TransportError as exc:
                return _fail(args, exc, EXIT_FAILED)
            wiring = "4-wire" if len(urls) == 2 else "2-wire"
            print(
                f"uss monitor: listening on {' and '.join(urls)} ({wiring}, {monitor.baud} baud, "
                f"gap {monitor.gap * 1000:.3f} ms, tolerance {monitor.tolerance * 1000:g} ms)",
                file=sys.stderr,
                flush=True,
            )
            if args.duration is not None:
                loop.call_later(args.duration, stop.set)
            if args.summary:
                refresher = asyncio.create_task(_refresh(output, args.interval, stop))
            try:
                await watch(monitor, opened, output, stop)
            except TransportError as exc:
                return _fail(args, exc, EXIT_FAILED)
            return EXIT_OK
        finally:
            if refresher is not None:
                await cancel_and_wait(refresher)
            for transport in opened:
                with contextlib.suppress(TransportError):
                    await transport.close()


async def _refresh(output: _Output, interval: float, stop: asyncio.Event) -> None:
    while not stop.is_set():
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(interval):
                await stop.wait()
        if stop.is_set():
            return
        output.show((_CLEAR if output.stream.isatty() else "") + output.table() + "\n\n")
