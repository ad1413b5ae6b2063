"""Buses for master tests: scripted slaves or simulated drives on a virtual bus behind a
started master, and simulated drives in a thread of their own reached over raw TCP (or ptys)."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import Any

from master.scripted import ScriptedSlave
from pyuss.bus import FaultPlan, Recorder, VirtualBus
from pyuss.master import Drive, Master
from pyuss.master.testing import simulated_drives
from pyuss.params import Describe, ParamBook
from pyuss.protocol.layout import Layout
from pyuss.protocol.receiver import Received, Receiver
from pyuss.slave import JobLatency, SlaveEngine


@dataclass
class Setup:
    bus: VirtualBus
    master: Master
    slaves: dict[int, ScriptedSlave]
    recorder: Recorder | None


LAYOUT_32 = Layout(3, 2)


class _UnknownParameters(Master):
    """A master that knows nothing of its drives' parameters (scripted slaves)."""

    def drive(self, address: int, **options: Any) -> Drive:
        handle = super().drive(address, **options)
        if handle.params.profile:
            handle.params = ParamBook(describe=Describe.NEVER)
        return handle


@asynccontextmanager
async def scripted_bus(
    addresses: Sequence[int] = (5,),
    *,
    baud: int = 38400,
    layout: Layout = LAYOUT_32,
    faults: FaultPlan | None = None,
    record: bool = False,
    **master_options: Any,
) -> AsyncIterator[Setup]:
    """A bus at ``baud`` with one scripted slave per address and a started master. Nothing is
    known of the scripted slaves' parameters (no parameter file, no descriptions): values read
    as the words they send (`Drive.read` of a parameter nothing is known of)."""
    bus = VirtualBus(baud, faults=faults)
    recorder = Recorder().attach(bus) if record else None
    slaves = {a: await ScriptedSlave(bus, a, layout).start() for a in addresses}
    master = _UnknownParameters(bus.attach("master"), layout=layout, **master_options)
    try:
        async with master:
            yield Setup(bus, master, slaves, recorder)
    finally:
        for slave in slaves.values():
            await slave.stop()
        await bus.close()


def line_telegrams(recorder: Recorder, baud: int, sender: str = "master") -> list[Received]:
    """The telegrams ``sender`` put on the line, decoded from the recording (times in seconds
    since the bus started)."""
    receiver = Receiver(baud)
    out: list[Received] = []
    for record in recorder.records:
        if record.sender != sender:
            continue
        for event in receiver.feed(bytes((record.byte,)), record.t):
            if isinstance(event, Received):
                out.append(event)
    return out


@dataclass
class SimSetup:
    bus: VirtualBus
    master: Master
    engines: dict[int, SlaveEngine]
    recorder: Recorder | None


@asynccontextmanager
async def simulated_bus(
    drives: Sequence[tuple[int, str, Layout | None]],
    *,
    baud: int = 38400,
    record: bool = False,
    faults: FaultPlan | None = None,
    latency: JobLatency | None = None,
    **master_options: Any,
) -> AsyncIterator[SimSetup]:
    """A virtual bus with simulated drives ``(address, profile, layout)`` and a started
    master; the master knows the drives' profile when they share one (else each handle is
    given its own)."""
    profiles = {profile for _, profile, _ in drives}
    if len(profiles) == 1:
        master_options.setdefault("profile", profiles.pop())
    bus = VirtualBus(baud, faults=faults)
    recorder = Recorder().attach(bus) if record else None
    try:
        async with (
            simulated_drives(bus, drives, latency=latency) as engines,
            Master(bus.attach("master"), **master_options) as master,
        ):
            yield SimSetup(bus, master, engines, recorder)
    finally:
        await bus.close()


class SimulatorThread:
    """Simulated drives on a virtual bus in a thread of their own, reached as raw TCP stations
    of the bus (``line="tcp"``: ``paths[0]`` is ``tcp://127.0.0.1:PORT``, every connection a
    station ``tcp1``, ``tcp2``, ... in the order they come) or through ``ptys`` ptys the bus
    serves (``line="pty"``: their device paths, stations ``pty1``, ...): what a master sees of
    drives in another program (no timing on the line, bytes stamped when read).

    ``drives``: ``(address, profile, layout)``; ``call(fn)`` runs ``fn(setup)`` on the bus's
    loop (to inject faults or look at the simulator).
    """

    def __init__(
        self,
        drives: Sequence[tuple[int, str, Layout | None]],
        *,
        baud: int = 38400,
        line: str = "tcp",
        ptys: int = 1,
        faults: FaultPlan | None = None,
        latency: JobLatency | None = None,
        record: bool = False,
    ) -> None:
        if line not in ("tcp", "pty"):
            raise ValueError(f"line is 'tcp' or 'pty', not {line!r}")
        self.drives = drives
        self.baud = baud
        self.line = line
        self.ptys = ptys
        self.faults = faults
        self.latency = latency
        self.record = record
        self.paths: list[str] = []
        self.bus: VirtualBus | None = None
        self.recorder: Recorder | None = None
        self.engines: dict[int, SlaveEngine] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None

    def __enter__(self) -> SimulatorThread:
        self._thread = threading.Thread(target=self._main, name="simulated bus", daemon=True)
        self._thread.start()
        if not self._ready.wait(10):
            raise RuntimeError("the simulated bus did not start")
        if self._error is not None:
            raise self._error
        return self

    def __exit__(self, *exc: object) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        if self._thread is not None:
            self._thread.join(10)

    def station(self, n: int = 1) -> str:
        """The bus's name of the ``n``-th station on the line (of the ``n``-th connection that
        is on it now, over TCP)."""
        return f"{self.line}{n}"

    def call(self, func: Any) -> Any:
        assert self._loop is not None

        async def run() -> Any:
            return func(self)

        return asyncio.run_coroutine_threadsafe(run(), self._loop).result(10)

    def _main(self) -> None:
        asyncio.run(self._serve())

    async def _serve(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        bus = self.bus = VirtualBus(self.baud, faults=self.faults)
        if self.record:
            self.recorder = Recorder().attach(bus)
        try:
            async with simulated_drives(bus, self.drives, latency=self.latency) as engines:
                self.engines = engines
                if self.line == "pty":
                    self.paths = await bus.serve_pty(self.ptys)
                else:
                    host, port = await bus.serve_tcp()
                    self.paths = [f"tcp://{host}:{port}"]
                self._ready.set()
                await self._stop.wait()
        except BaseException as exc:
            self._error = exc
            self._ready.set()
        finally:
            await bus.close()
