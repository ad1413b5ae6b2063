"""The same traffic, heard on one virtual bus through a ``bus://`` station (exact timestamps)
and through a pty station (stamped when the reading thread gets the bytes, as a USB adapter
delivers them), decodes to the same exchanges, with at most 1 % errors on the pty.

Both listeners run at once, as ``uss monitor`` runs them (``open_transport``, `Listener`,
`watch`, the tolerance their timestamps call for), while a master in cyclic mode and parameter
jobs talk to two simulated drives. The pty's stamps may come up to the tolerance (20 ms) late;
the test measures how late each byte really was against the exact station, and only a stretch
where the machine held the reading thread back longer than that (a loaded test machine) is
left out of the comparison: there the rule does not apply.
"""

from __future__ import annotations

import asyncio
import difflib
from dataclasses import dataclass, field

import pytest

from pyuss.bus import VirtualBus
from pyuss.master import Master
from pyuss.master.testing import simulated_drives
from pyuss.monitor import Exchange, Monitor
from pyuss.monitor.live import Listener, watch
from pyuss.protocol import Layout
from pyuss.transport.base import STAMP_TOLERANCE, Chunk, stamp_tolerance
from pyuss.transport.url import open_transport

BAUD = 19200
RUN = 3.0


@dataclass
class Heard:
    """What one listener read, chunk by chunk, and what its monitor made of it."""

    listener: Listener
    chunks: list[Chunk] = field(default_factory=list)
    exchanges: list[Exchange] = field(default_factory=list)

    async def read(self, timeout: float | None = None) -> Chunk | None:
        chunk = await self.listener.read(timeout)
        if chunk is not None:
            self.chunks.append(chunk)
        return chunk

    def clock(self) -> float:
        return self.listener.clock()

    def byte_times(self) -> tuple[bytes, list[float], list[float]]:
        """The bytes, when each ended as the stamps tell (back to back up to the stamp), and
        when the chunk holding it was stamped."""
        data = b"".join(c.data for c in self.chunks)
        ends: list[float] = []
        stamps: list[float] = []
        for chunk in self.chunks:
            n = len(chunk.data)
            ends += [chunk.timestamp - (n - 1 - i) * 11 / BAUD for i in range(n)]
            stamps += [chunk.timestamp] * n
        return data, ends, stamps


def key(exchange: Exchange) -> tuple[object, ...]:
    request, answer = exchange.request, exchange.answer
    return (
        exchange.kind,
        None if request is None else request.raw,
        None if answer is None else answer.raw,
    )


def span(exchange: Exchange) -> tuple[float, float]:
    frames = exchange.frames
    return frames[0].start, frames[-1].end


@pytest.mark.pty
async def test_a_pty_station_decodes_the_bus_traffic_as_the_bus_station_does() -> None:
    bus = VirtualBus(BAUD)
    (pty_path,) = await bus.serve_pty(1)
    host, port = await bus.serve_tcp(framed=True)
    heard: dict[str, Heard] = {}
    monitors: dict[str, Monitor] = {}
    for name, url in (("bus", f"bus://{host}:{port}?listen_only=1"), ("pty", pty_path)):
        transport = open_transport(url, baud=BAUD)
        heard[name] = Heard(Listener(transport))
        # As uss monitor chooses it: 0 on bus:// (exact), 20 ms on the pty.
        monitors[name] = Monitor(BAUD, tolerance=stamp_tolerance(transport))
        await heard[name].listener.open()
    assert (monitors["bus"].tolerance, monitors["pty"].tolerance) == (0.0, STAMP_TOLERANCE)
    stop = asyncio.Event()
    watchers = [
        asyncio.create_task(watch(monitors[n], [h], h.exchanges.extend, stop))  # type: ignore[list-item]
        for n, h in heard.items()
    ]
    drives = [(5, "generic", Layout(3, 2)), (6, "generic", Layout(3, 2))]
    async with (
        simulated_drives(bus, drives),
        Master(bus.attach("master"), layout="3,2", cycle_time=None) as master,
    ):
        first, second = master.drive(5), master.drive(6)
        loop = asyncio.get_running_loop()
        end = loop.time() + RUN
        while loop.time() < end:
            assert await first.read(52) == 0x4000
            await second.setpoint(25.0)
            await first.write(18, 0x1234)
        await asyncio.sleep(0.2)
    await asyncio.sleep(0.3)  # the last bytes reach both listeners
    stop.set()
    await asyncio.gather(*watchers)
    for h in heard.values():
        await h.listener.close()
    await bus.close()

    exact, coarse = heard["bus"], heard["pty"]
    data, line_ends, _ = exact.byte_times()
    pty_data, _, read_at = coarse.byte_times()
    assert pty_data == data, "the pty station lost or added bytes"
    # Where the machine held the pty reader back longer than the tolerance, the stamps broke
    # the contract the rule rests on: those stretches are left out (and counted).
    late = [(e, r) for r, e in zip(read_at, line_ends, strict=True) if r - e > STAMP_TOLERANCE]

    def out_of_reach(start: float, end: float, *, read: bool) -> bool:
        """Whether a late byte lies near ``start``..``end`` (line times, or read times)."""
        margin = 2 * STAMP_TOLERANCE
        return any(start - margin <= t[read] <= end + margin for t in late)

    bus_keys = [key(ex) for ex in exact.exchanges]
    pty_keys = [key(ex) for ex in coarse.exchanges]
    in_reach = [not out_of_reach(*span(ex), read=False) for ex in exact.exchanges]
    assert len(bus_keys) >= 100 and sum(in_reach) >= 0.5 * len(bus_keys), (
        len(bus_keys),
        len(late),
    )
    # Every exchange the bus station decodes (within reach) is decoded the same on the pty.
    matcher = difflib.SequenceMatcher(None, bus_keys, pty_keys, autojunk=False)
    pairs = {}
    for block in matcher.get_matching_blocks():
        pairs.update({block.a + k: block.b + k for k in range(block.size)})
    missing = [i for i, ok in enumerate(in_reach) if ok and i not in pairs]
    # Errors on the pty that the bus station does not see (a drive that answers late under
    # load is late on both; the pty judges it within its tolerance).
    bus_side = {j: i for i, j in pairs.items()}
    errors = [
        ex
        for j, ex in enumerate(coarse.exchanges)
        if ex.problems
        and not out_of_reach(*span(ex), read=True)
        and (j not in bus_side or not exact.exchanges[bus_side[j]].problems)
    ]
    limit = 0.01 * sum(in_reach)
    assert len(missing) <= limit, [bus_keys[i] for i in missing[:5]]
    assert len(errors) <= limit, [(ex.problems, ex.unsure) for ex in errors[:5]]
    if late:
        print(f"{len(late)} bytes were read more than the tolerance late (a loaded machine)")
