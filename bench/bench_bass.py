"""BASS figures: codec speed, reader speed, and round trips through an in-process ring.

The wire itself is slow: at 9600 baud 8N1 a read of one element (request 15 characters, echo
15, answer 19) takes about 51 ms of line time, so the software must be far below that.
"""

from __future__ import annotations

import asyncio
import time

from pyuss.bass.codec import BassAnswer, BassLineReader, BassRequest, decode_answer
from pyuss.bass.master import BassMaster
from pyuss.bass.ring import BassRing, demo_elements

LINE_TIME_READ = (15 + 15 + 19) * 10 / 9600


def _rate(count: int, seconds: float) -> float:
    return count / seconds if seconds > 0 else float("inf")


def main() -> None:
    n = 20000
    start = time.perf_counter()
    for i in range(n):
        BassRequest.write(i & 0xFF, 2, i).encode()
    encode = _rate(n, time.perf_counter() - start)

    line = BassAnswer.value(3, 51, 0x1D3E).encode()
    start = time.perf_counter()
    for _ in range(n):
        decode_answer(line)
    decode = _rate(n, time.perf_counter() - start)

    stream = line * 2000
    reader = BassLineReader()
    start = time.perf_counter()
    reader.feed(stream)
    reader_bps = _rate(len(stream), time.perf_counter() - start)

    async def ring_round_trips(count: int) -> float:
        ring = BassRing.with_addresses(range(16), elements=demo_elements())
        async with ring.port() as port:
            master = BassMaster(port, timeout=1.0)
            begin = time.perf_counter()
            for i in range(count):
                await master.read(i % 16, 170)
            return time.perf_counter() - begin

    trips = 2000
    per_trip = asyncio.run(ring_round_trips(trips)) / trips

    ratio = LINE_TIME_READ / per_trip
    print(f"encode request         {encode:12.0f} lines/s")
    print(f"decode answer          {decode:12.0f} lines/s")
    print(f"line reader            {reader_bps:12.0f} bytes/s ({reader_bps / 960:.0f} x 9600 baud)")
    print(f"read via 16-drive ring {per_trip * 1e6:12.1f} us per read")
    print(f"wire time of one read  {LINE_TIME_READ * 1e3:12.1f} ms (ratio {ratio:.0f})")


if __name__ == "__main__":
    main()
