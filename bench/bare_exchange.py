"""The least a process can do to poll drives over ``bus://``: the floor under the gateway's cost.

``python bench/bare_exchange.py URL DRIVES BAUD SECONDS`` joins the bus as ``uss gateway``
does (a timed station that holds each answer until it is whole, `pyuss.bus.wire`), then polls
drives 1..DRIVES with PKW 4 + PZD 2 telegrams made once, as fast as the wire allows: each
answer, once whole, is followed at once by the next request, to start a start pause after the
answer's end (USS specification A 5.1.2). Nothing is decoded, no master, no state, no face: one
wake-up of the process, one read and one write per exchange, on uvloop where it is installed.
Several buses, as a gateway of several buses polls them: ``URL,URL,... DRIVES,DRIVES,...`` (a
count of drives per bus), all in the one process.
It prints one JSON line: exchanges a second and the process's CPU time per exchange, over
SECONDS after a second of warm-up.

What the gateway does per drive update beyond this - the master's checks and timing, the
drive model, the faces - is what the gateway's figures add to it; this figure is what no
Python program exchanging telegrams with a ``bus://`` bus in another process can go under on
the same machine.
"""

from __future__ import annotations

import asyncio
import json
import sys
import time
from urllib.parse import urlsplit

from pyuss.bus.wire import FrameDecoder, encode_send
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.protocol.timing import char_time, start_pause

NET_BYTES = 12
"""PKW 4 + PZD 2 words: an answer is as long as its request, 16 characters."""
WINDOW = 0.020
"""How long after its request an answer's first character may come (the hold's margin)."""


class Bare(asyncio.Protocol):
    def __init__(self, drives: int, baud: int) -> None:
        self.requests = [
            Telegram(a, AddressMode.NORMAL, bytes(NET_BYTES)).encode() for a in range(1, drives + 1)
        ]
        self.size = len(self.requests[0])
        self.pause = start_pause(baud)
        self.on_line = self.size * char_time(baud)
        self.char = char_time(baud)
        self.frames = FrameDecoder()
        self.hello = b""
        self.ready: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self.got = 0
        self.next = 0
        self.exchanges = 0
        self.transport: asyncio.Transport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]  # (uvloop's is no subclass)
        hello = {"name": None, "echo": False, "listen_only": False, "timed": True}
        hello |= {"hold": True, "hold_answer": True}
        transport.write(json.dumps(hello).encode() + b"\n")

    def data_received(self, data: bytes) -> None:
        if not self.ready.done():
            self.hello += data
            if b"\n" in self.hello:
                line, _, rest = self.hello.partition(b"\n")
                answer = json.loads(line)
                if not answer.get("ok") or not answer.get("hold_answer"):
                    raise SystemExit(f"the bus did not take the station as the gateway's: {answer}")
                self.ready.set_result(None)
                self.send(time.monotonic())
                if rest:
                    self.data_received(rest)
            return
        for payload, end, _errors in self.frames.feed(data):
            self.got += len(payload)
            if self.got >= self.size:  # the answer is whole: the next request at once
                self.got = 0
                self.exchanges += 1
                self.send(end + self.pause)

    def send(self, start: float) -> None:
        request = self.requests[self.next]
        self.next = (self.next + 1) % len(self.requests)
        hold = start + self.on_line + WINDOW + self.char
        assert self.transport is not None
        self.transport.write(encode_send(start, request) + encode_send(hold, b""))


async def measure(urls: list[str], sizes: list[int], baud: int, seconds: float) -> dict[str, float]:
    loop = asyncio.get_running_loop()
    bares = []
    for url, drives in zip(urls, sizes, strict=True):
        where = urlsplit(url)
        _, bare = await loop.create_connection(
            lambda drives=drives: Bare(drives, baud), where.hostname, where.port
        )
        bares.append(bare)
    for bare in bares:
        await bare.ready
    await asyncio.sleep(1.0)
    count, cpu, wall = sum(b.exchanges for b in bares), time.process_time(), time.perf_counter()
    await asyncio.sleep(seconds)
    count = sum(b.exchanges for b in bares) - count
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    return {"exchanges_per_s": count / wall, "cpu_us": cpu / max(1, count) * 1e6}


def main() -> None:
    urls, sizes = sys.argv[1].split(","), [int(n) for n in sys.argv[2].split(",")]
    baud, seconds = int(sys.argv[3]), float(sys.argv[4])
    try:
        import uvloop
    except ImportError:
        loop = "asyncio"
        print(json.dumps(asyncio.run(measure(urls, sizes, baud, seconds)) | {"loop": loop}))
    else:
        result = uvloop.run(measure(urls, sizes, baud, seconds))
        print(json.dumps(result | {"loop": "uvloop"}))


if __name__ == "__main__":
    main()
