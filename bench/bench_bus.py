"""How close the virtual bus delivers characters to their ideal end times, and its CPU cost.

A master and a slave exchange 14-byte telegrams (C 8.1 example 2) with a start pause before
each request and about 1 ms of slave processing; a probe station records, for every character,
delivery time minus ideal end time (the lag: never negative, since the bus never delivers
early), and the same for the last character of each telegram, the moment a receiver reacts (the
bus hands the rest of a run over near its end by design, docs/bus.md: the lag of a character
inside a telegram is up to the telegram's length). Then the same through ptys, comparing two
ways of stamping what a serial port reads: pyuss's worker thread (`SerialTransport`) and a
reader in the event loop that also runs the bus; each chunk's stamp minus the ideal end time of
its last byte.
Everything runs on the event loop ``uss bus`` uses (`pyuss.loop`, microsecond timers).
CPU, over wall time while the traffic runs: the bus's own (CPU time spent in putting
characters on the line and handing them over, `VirtualBus.send` and the delivery timer), and
the whole process's (the bus plus the two stations and the probe, all in this process).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import statistics
import time
import tty
from collections.abc import Callable

from pyuss.bus import Recorder, VirtualBus
from pyuss.loop import run
from pyuss.transport import SerialTransport, Transport

REQUEST = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")
RESPONSE = bytes.fromhex("02 0C 05 10 34 00 00 40 00 02 31 00 00 5C")
BAUDS = (9600, 38400, 187500)
SECONDS = 1.5


async def _read_n(transport: Transport, n: int) -> None:
    got = 0
    while got < n:
        chunk = await transport.read(1.0)
        if chunk is None:
            raise RuntimeError("the bus lost characters")
        got += len(chunk.data)


async def _traffic(bus: VirtualBus, seconds: float) -> int:
    tc = bus.char_time
    cycles = 0
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            await asyncio.sleep(3 * tc)  # start pause (A 5.1.2, 2 character times at least)
            await master.write(REQUEST)
            await _read_n(slave, len(REQUEST))
            await asyncio.sleep(0.001)
            await slave.write(RESPONSE)
            await _read_n(master, len(RESPONSE))
            cycles += 1
    return cycles


def _meter(bus: VirtualBus) -> list[float]:
    """Count the CPU time the bus spends in ``send`` and its delivery timer (one-item list)."""
    spent = [0.0]
    for name in ("send", "_tick"):
        inner = getattr(bus, name)

        def timed(*args: object, _inner: Callable[..., None] = inner) -> None:
            begin = time.thread_time()
            try:
                _inner(*args)
            finally:
                spent[0] += time.thread_time() - begin

        setattr(bus, name, timed)
    return spent


async def _in_process(baud: int) -> tuple[list[float], list[float], float, float, int]:
    bus = VirtualBus(baud)
    spent = _meter(bus)
    lags: list[float] = []
    ends: list[float] = []
    tc = bus.char_time

    def probe(data: bytes, timestamp: float, _errors: object) -> None:
        now = time.monotonic()
        n = len(data)
        first = len(lags)
        lags.extend(now - (timestamp - (n - 1 - i) * tc) for i in range(n))
        # every telegram is 14 characters: the 14th, 28th, ... end one
        ends.extend(lags[i] for i in range(first, len(lags)) if (i + 1) % len(REQUEST) == 0)

    bus.attach("probe", listen_only=True, sink=probe)
    wall0, cpu0 = time.monotonic(), time.process_time()
    cycles = await _traffic(bus, SECONDS)
    wall = time.monotonic() - wall0
    cpu = (time.process_time() - cpu0) / wall
    await bus.close()
    return lags, ends, spent[0] / wall, cpu, cycles


async def _through_pty(baud: int) -> tuple[list[float], list[float]]:
    """Lags of a worker-thread reader (`SerialTransport`) and of an event-loop reader on a
    second pty, both reading the same traffic while the bus runs in the same loop."""
    bus = VirtualBus(baud)
    recorder = Recorder().attach(bus)
    path, other = await bus.serve_pty(2)
    threaded: list[float] = []
    stamps: list[tuple[int, float]] = []
    loop = asyncio.get_running_loop()
    fd = os.open(other, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    tty.setraw(fd)

    def on_readable() -> None:
        stamp = time.monotonic()
        with contextlib.suppress(BlockingIOError):
            stamps.append((len(os.read(fd, 4096)), stamp))

    loop.add_reader(fd, on_readable)
    async with SerialTransport(path, baud=baud) as reader, bus.attach("master") as master:
        await asyncio.sleep(0.05)
        for _ in range(40):
            await master.write(REQUEST)
            await bus.drain()
            await asyncio.sleep(3 * bus.char_time)
        await asyncio.sleep(0.1)
        ends = [r.t + bus.epoch for r in recorder.records]
        got = 0
        while (chunk := await reader.read(0.2)) is not None:
            got += len(chunk.data)
            threaded.append(chunk.timestamp - ends[got - 1])
    loop.remove_reader(fd)
    os.close(fd)
    await bus.close()
    looped = []
    got = 0
    for n, stamp in stamps:
        got += n
        looped.append(stamp - ends[got - 1])
    return threaded, looped


def _ms(values: list[float]) -> str:
    return (
        f"median {statistics.median(values) * 1e3:7.3f} ms, "
        f"worst {max(values) * 1e3:7.3f} ms (n={len(values)})"
    )


def main() -> None:
    print(f"delivery lag per character (delivery time - ideal end time), {SECONDS} s each")
    for baud in BAUDS:
        lags, ends, bus_cpu, cpu, cycles = run(_in_process(baud))
        tc = 11 / baud
        print(
            f"  {baud:6d} baud, in-process, every character: {_ms(lags)}; "
            f"median/character time {statistics.median(lags) / tc:5.2f}; "
            f"CPU of one core: bus {bus_cpu * 100:5.1f} %, process {cpu * 100:5.1f} % "
            f"({cycles} request/response cycles)"
        )
        print(
            f"  {baud:6d} baud, in-process, last of a telegram: {_ms(ends)}; "
            f"median/character time {statistics.median(ends) / tc:5.2f}"
        )
        threaded, looped = run(_through_pty(baud))
        print(f"  {baud:6d} baud, pty, thread reader (SerialTransport): {_ms(threaded)}")
        print(f"  {baud:6d} baud, pty, event-loop reader:              {_ms(looped)}")


if __name__ == "__main__":
    main()
