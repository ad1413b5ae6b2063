"""Slave simulator speed on the virtual bus at 187500 baud (the fastest USS rate, B 2.4).

- Turnaround: from the end of a request's last character to the start of the answer's first
  character, taken from the bus's own character times. The floor is the start pause (2
  characters = 0.117 ms, A 5.1.2); the ceiling is 20 ms (A 5.2.1.1).
- Capacity: how many drives one process serves - 31 simulated drives (addresses 1..31, a full
  bus) on one line, polled back to back by a master on the same event loop (C 8.1 example 2
  telegrams, PKW 3 + PZD 2; each request handed to the bus a start pause after the last
  answer), with their turnaround and the answers later than the profile allows. The wire
  limit of one exchange is 14 + 14 characters plus two start pauses (32 characters); the
  figure is the median exchange (the mean, which a loaded machine's hiccups pull down, beside
  it).
- Engine cost: `SlaveEngine.handle` alone, telegrams per second of CPU time, against the
  line's rate.
"""

from __future__ import annotations

import asyncio
import itertools
import statistics
import time

from common import Figure, best_of

from pyuss.bus import VirtualBus, WireChar
from pyuss.drive import SimulatedDrive
from pyuss.loop import run
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.protocol.timing import char_time
from pyuss.slave import SlaveEngine, SlaveServer

BAUD = 187500
P99_GOAL = 0.0005
LAYOUT = Layout(3, 2)
PROFILE = get_profile("generic")


def _request(address: int) -> bytes:
    data = LAYOUT.pack(Pkw(1, 52), (0x047E, 0))
    return Telegram(address, AddressMode.NORMAL, data).encode()


def _engines(addresses: range, now: float) -> list[SlaveEngine]:
    db = PROFILE.database()
    return [
        SlaveEngine(a, SimulatedDrive(db, now=now), PROFILE, layout=LAYOUT, now=now)
        for a in addresses
    ]


async def _run(addresses: range, exchanges: int) -> tuple[list[float], list[float], int, int]:
    """Poll ``addresses`` round-robin ``exchanges`` times, each request a start pause after the
    last answer; (turnarounds, exchange times from request start to request start, answers,
    late answers)."""
    bus = VirtualBus(BAUD)
    master = bus.attach("master")
    slave = bus.attach("slave")
    await master.open()
    await slave.open()
    server = SlaveServer(slave, *_engines(addresses, slave.clock()))
    stop = asyncio.Event()
    task = asyncio.create_task(server.run(stop))
    ct = char_time(BAUD)
    turnarounds: list[float] = []
    starts: list[float] = []
    state: dict[str, float | int] = {"request_end": 0.0, "answer_chars": 0, "answer_end": 0.0}
    done = asyncio.Event()

    def on_char(char: WireChar) -> None:
        if char.sender == "master":
            if state["answer_chars"] == 0 and char.start > float(state["request_end"]):
                starts.append(char.start)
            state["request_end"] = char.end
            return
        if state["answer_chars"] == 0:
            turnarounds.append(char.start - float(state["request_end"]))
        state["answer_chars"] = int(state["answer_chars"]) + 1
        if state["answer_chars"] == 14:
            state["answer_end"] = char.end
            done.set()

    bus.on_char.append(on_char)
    requests = [_request(a) for a in addresses]
    for i in range(exchanges):
        done.clear()
        state["answer_chars"] = 0
        # the start pause before the request is kept by the bus (a timed send)
        await master.write_at(requests[i % len(requests)], float(state["answer_end"]) + 2 * ct)
        async with asyncio.timeout(5.0):
            await done.wait()
    stop.set()
    await task
    server.close()
    await bus.close()
    spans = [b - a for a, b in itertools.pairwise(starts)]
    return turnarounds, spans, server.stats.answers, server.stats.late


def _spread(turnarounds: list[float]) -> tuple[list[float], float, float]:
    """The turnarounds in ms, sorted, with their median and 99th percentile."""
    ms = sorted(t * 1000 for t in turnarounds)
    return ms, statistics.median(ms), ms[min(len(ms) - 1, int(0.99 * len(ms)))]


def _engine_rate(seconds: float = 0.5) -> float:
    engine = _engines(range(5, 6), 0.0)[0]
    telegram = Telegram.decode(_request(5))
    count = 0
    start = time.process_time()
    now = 0.0
    while True:
        for _ in range(200):
            now += 0.002
            engine.handle(telegram, now)
        count += 200
        elapsed = time.process_time() - start
        if elapsed >= seconds:
            return count / elapsed


def main() -> list[Figure]:
    ct = char_time(BAUD)
    pause = 2 * ct

    def single() -> list[float]:
        return run(_run(range(5, 6), 400))[0]

    turnarounds, runs = best_of(
        single, lambda t: -_spread(t)[2], lambda t: _spread(t)[2] <= P99_GOAL * 1000
    )
    ms, median, p99 = _spread(turnarounds)
    print(
        f"turnaround at {BAUD} baud, {len(ms)} exchanges: median {median:.3f} ms "
        f"({median / (ct * 1000):.2f} characters), p99 {p99:.3f} ms, min {ms[0]:.3f} ms, "
        f"max {ms[-1]:.3f} ms"
    )
    print(
        f"  start pause {pause * 1000:.3f} ms (median x{median / (pause * 1000):.1f}); "
        f"limit 20 ms (p99 at {p99 / 20 * 100:.1f} % of it)"
        + (f" (best of {runs} runs)" if runs > 1 else "")
    )
    figures = [
        Figure(f"simulator in-process {BAUD} baud: turnaround p99", p99, 0.5, False, "ms", digits=3)
    ]

    wire = 1 / (32 * ct)

    def capacity() -> tuple[list[float], list[float], int, int]:
        return run(_run(range(1, 32), 31 * 20))

    def served(r: tuple[list[float], list[float], int, int]) -> float:
        return 1 / statistics.median(r[1]) / wire

    (turnarounds, spans, answers, late), runs = best_of(
        capacity, served, lambda r: served(r) >= 0.95
    )
    achieved = 1 / statistics.median(spans)
    mean = len(spans) / sum(spans)
    _, median, p99 = _spread(turnarounds)
    print(
        f"drives one process serves: 31 (addresses 1..31, a full bus), polled back to back: "
        f"{achieved:.0f} exchanges/s (mean {mean:.0f}; {answers} answers, {late} later than "
        f"20 ms), wire limit {wire:.0f}/s: {achieved / wire * 100:.0f} % of the line; "
        f"turnaround median {median:.3f} ms, p99 {p99:.3f} ms"
        + (f" (best of {runs} runs)" if runs > 1 else "")
    )
    figures.append(
        Figure(
            f"simulator in-process 31 drives {BAUD} baud: share of the line", achieved / wire, 0.95
        )
    )

    engine = _engine_rate()
    line = 1 / (14 * ct)
    print(
        f"engine alone (handle, PKW 3 + PZD 2): {engine:.0f} telegrams/s = "
        f"{engine / line:.1f} x a fully loaded {BAUD} baud line ({line:.0f} telegrams/s)"
    )
    return figures


if __name__ == "__main__":
    from common import table

    print(table(main()))
