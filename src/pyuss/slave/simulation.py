"""Simulated USS drives on a line, as ``uss simulate`` builds them from its checked options.

One `SimulatedLine` is the drives of one process: a `pyuss.drive.SimulatedDrive` per bus
address (of the profile's parameter file or another one, with its EEPROM store, with the
factory values of its command and setpoint sources or ready for USS), a `SlaveEngine` for
each, and one `SlaveServer` that answers for all of them on the line's transport, inside the
profile's response window (at the delay asked for, or the one the parameter file gives).

Where the line is (`open_line`): a new pty, a TCP server, a serial port, a station of a
virtual bus of another process, or a virtual bus of its own open to ``bus://`` stations (the
drives then answer on the bus's own timeline). Its rate is the one asked for, else the one
the drives' baud rate parameter is set to (C 3: their store or their file), else
`DEFAULT_BAUD`; drives set to different rates are refused. The refusals name the options of
``uss simulate`` they come from.
"""

from __future__ import annotations

import contextlib
import dataclasses
import urllib.parse
from collections.abc import AsyncIterator, Callable, Sequence
from pathlib import Path

from pyuss.drive.database import ParameterDatabase
from pyuss.drive.loader import load_database
from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import ConfigError, UssError
from pyuss.profiles import Profile, get_profile
from pyuss.protocol.layout import Layout
from pyuss.slave.engine import JobLatency, SlaveEngine
from pyuss.slave.interface import InterfaceParameters
from pyuss.slave.server import SlaveServer
from pyuss.system import clock
from pyuss.transport.address import HostPort, parse_host_port
from pyuss.transport.base import Transport
from pyuss.transport.pty import PtyPort
from pyuss.transport.queued import check_baud
from pyuss.transport.tcp import TcpServerTransport
from pyuss.transport.url import open_transport

__all__ = [
    "DEFAULT_BAUD",
    "DriveSettings",
    "SimulatedLine",
    "endpoint",
    "line_baud",
    "open_line",
    "simulated_line",
]

DEFAULT_BAUD = 9600
"""The line's rate when neither the options nor a drive's baud rate parameter gives one."""


@dataclasses.dataclass(frozen=True, slots=True)
class DriveSettings:
    """How the simulated drives of one line are made and answer (every one alike)."""

    params: str | None = None
    """The parameter file; None: the profile's."""
    layout: Layout | None = None
    """The telegram layout; None: the profile's."""
    store: str | None = None
    """The EEPROM store file (``{address}`` in it for several drives); None: none."""
    factory: bool = False
    """The factory values of the command and setpoint sources, not ready for USS."""
    failure_time: float | None = None
    latency: JobLatency = dataclasses.field(default_factory=JobLatency)
    response_delay: float | None = None
    """Seconds after a request, inside the window; None: as early as allowed, or manual."""
    manual_delay: bool = False
    """After the response delay the parameter file gives."""
    write_authority: bool = True
    spontaneous: bool | None = None


@dataclasses.dataclass(slots=True)
class SimulatedLine:
    """The drives of one process serving, with what ``uss simulate`` shows of them."""

    transport: Transport
    first_line: Callable[[], str]
    """Once open: the line that names where the drives answer (a pty's device path ...)."""
    profile: Profile
    database: ParameterDatabase
    baud: int
    engines: list[SlaveEngine]
    server: SlaveServer


def endpoint(text: str, option: str) -> HostPort:
    """HOST:PORT of ``option`` (``:PORT`` on 127.0.0.1)."""
    return parse_host_port(text, f"{option} {text!r}")


def open_line(
    line: str, where: str, baud: int, parity: str, *, name: str = "simulate"
) -> tuple[Transport, Callable[[], str]]:
    """The transport of a ``line`` kind (``pty``, ``tcp``, ``bus``, ``serial``) at ``where``
    and, once open, the line naming it (``name``: the station name on a bus)."""
    if line == "pty":
        pty = PtyPort(baud=baud)
        return pty, lambda: pty.device_path
    if line == "tcp":
        listen = endpoint(where, "--tcp")
        server = TcpServerTransport(listen.host, listen.port, baud=baud)
        return server, lambda: f"tcp://{HostPort(listen.host, server.port)}"
    if line == "bus":
        url = f"bus://{where}?{urllib.parse.urlencode({'name': name})}"
        bus = open_transport(url, baud=baud)
        return bus, lambda: f"bus://{where}"
    serial_line = open_transport(where, baud=baud, parity=parity)
    return serial_line, lambda: where


def _database(profile: str, params: str | None) -> ParameterDatabase:
    return get_profile(profile).database() if params is None else load_database(params)


def _store(store: str | None, address: int) -> str | None:
    if store is None:
        return None
    path = store.replace("{address}", str(address))
    if not Path(path).parent.is_dir():
        raise ConfigError(f"--store {path}: folder {Path(path).parent} does not exist")
    return path


def line_baud(baud: int | None, drives: Sequence[tuple[int, SimulatedDrive]]) -> int:
    """The rate of the line: ``baud``, else the one the drives' baud rate parameter is set
    to (their store or their file; C 3), else `DEFAULT_BAUD`."""
    if baud is not None:
        return baud
    rates = {a: InterfaceParameters(d).baud() for a, d in drives}
    given = {a: r for a, r in rates.items() if r is not None}
    if not given:
        return DEFAULT_BAUD
    if len(set(given.values())) > 1:
        listed = ", ".join(f"drive {a}: {r}" for a, r in given.items())
        raise ConfigError(f"the drives are set to different baud rates ({listed}): give --baud")
    address, rate = next(iter(given.items()))
    drive = dict(drives)[address]
    ref = drive.db.interface["baud"]
    try:
        return check_baud(rate)
    except ConfigError:
        raise ConfigError(
            f"drive {address} is set to {rate} baud ({ref}), not a rate of B 2.4: give --baud"
        ) from None


@contextlib.asynccontextmanager
async def simulated_line(
    profile_name: str,
    addresses: Sequence[int],
    settings: DriveSettings,
    *,
    line: str,
    where: str,
    station: str,
    baud: int | None = None,
) -> AsyncIterator[SimulatedLine]:
    """The drives at ``addresses`` of profile ``profile_name`` on the ``line`` at ``where``
    (``bus-tcp``: a virtual bus of their own; ``station``: their name on a bus), its
    transport open while the block runs; the block runs the server."""
    profile = get_profile(profile_name)
    db = _database(profile_name, settings.params)
    now = clock()  # the clock of every transport
    drives = [
        (a, SimulatedDrive(db, store=_store(settings.store, a), now=now, factory=settings.factory))
        for a in addresses
    ]
    rate = line_baud(baud, drives)
    hosted = None
    if line == "bus-tcp":  # a bus of its own: the drives are an in-process station
        from pyuss.bus.virtual import VirtualBus

        hosted = VirtualBus(rate)
        listen = endpoint(where, "--bus-tcp")
        try:
            host, port = await hosted.serve_tcp(listen.host, listen.port, framed=True)
        except UssError as exc:
            await hosted.close()
            raise ConfigError(f"--bus-tcp: {exc}") from None
        transport: Transport = hosted.attach(station)
        url = f"bus://{HostPort(host, port)}"
        first_line: Callable[[], str] = lambda: url  # noqa: E731
    else:
        transport, first_line = open_line(line, where, rate, "E", name=station)
    await transport.open()
    try:
        engines = [
            SlaveEngine(
                address,
                drive,
                profile,
                layout=settings.layout,
                latency=settings.latency,
                failure_time=settings.failure_time,
                spontaneous=settings.spontaneous,
                write_authority=settings.write_authority,
                now=now,
            )
            for address, drive in drives
        ]
        server = SlaveServer(
            transport,
            *engines,
            response_delay=settings.response_delay,
            manual_delay=settings.manual_delay,
        )
        yield SimulatedLine(transport, first_line, profile, db, rate, engines, server)
    finally:
        await transport.close()
        if hosted is not None:
            await hosted.close()
