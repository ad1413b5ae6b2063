"""The page's monitor view: the telegrams on the line, decoded by a `pyuss.monitor.Monitor`.

On a real line the monitor sees the master's own traffic through
`pyuss.web.tap.TapTransport` (both directions, as on a 4-wire line) and is told that time
passes, so that a missing answer shows; in the demo it is a listen-only station of the
virtual bus. The decoded telegrams are numbered from 1 and the newest `EXCHANGE_BUFFER` of
them kept, for the live view (the lines of ``uss monitor``) and its pcapng download.
"""

from __future__ import annotations

import asyncio
import tempfile
from collections import deque
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pyuss._tasks import cancel_and_wait
from pyuss.errors import UssError
from pyuss.monitor.core import Monitor, default_gap
from pyuss.monitor.infer import LayoutBook
from pyuss.monitor.model import Exchange
from pyuss.monitor.render import exchange_line
from pyuss.protocol.layout import Layout
from pyuss.transport.base import Chunk, Transport, stamp_tolerance
from pyuss.web.tap import TapTransport

__all__ = ["EXCHANGE_BUFFER", "LineTelegrams"]

EXCHANGE_BUFFER = 5000
"""Decoded telegrams kept for the monitor view and its pcapng download."""


class LineTelegrams:
    """The decoded telegrams of the page's line (see the module text); ``epoch`` is the wall
    time of the line's clock at 0, which the page shows its times in."""

    def __init__(self) -> None:
        self.exchanges: deque[tuple[int, Exchange]] = deque(maxlen=EXCHANGE_BUFFER)
        self.newest = 0
        """The number of the newest decoded telegram (0: none yet)."""
        self.epoch = 0.0
        self.monitor: Monitor | None = None
        self.stop = asyncio.Event()
        """Set when the master stops: the monitor's tasks end."""
        self._task: asyncio.Task[None] | None = None

    async def listen(self, listener: Transport, baud: int, layouts: Mapping[int, Layout]) -> None:
        """Decode what the listen-only station ``listener`` hears (the demo's virtual bus)."""
        self.stop = asyncio.Event()
        self.monitor = Monitor(baud, layouts=LayoutBook(per_address=layouts), gap=default_gap(baud))
        await listener.open()
        self._task = asyncio.create_task(self._watch(listener))

    def tap(self, inner: Transport, baud: int, layouts: Mapping[int, Layout]) -> TapTransport:
        """The master's transport ``inner`` seen through a tap that feeds the monitor."""
        self.stop = asyncio.Event()
        self.monitor = Monitor(
            baud,
            four_wire=True,
            layouts=LayoutBook(per_address=layouts),
            gap=default_gap(baud),
            tolerance=stamp_tolerance(inner),
        )
        transport = TapTransport(inner, self._feed)
        self._task = asyncio.create_task(self._tick(transport))
        return transport

    async def close(self) -> None:
        """End the monitor's task (after `stop` is set)."""
        self.stop.set()
        if self._task is not None:
            await cancel_and_wait(self._task, ignore=(UssError,))
            self._task = None

    def _publish(self, exchanges: list[Exchange]) -> None:
        for exchange in exchanges:
            self.newest += 1
            self.exchanges.append((self.newest, exchange))

    def exchange_dict(self, seq: int, exchange: Exchange) -> dict[str, Any]:
        """One decoded telegram for the page: when, address, kind, problems, the line of
        `uss monitor`."""
        return {
            "seq": seq,
            "time": exchange.time + self.epoch,
            "address": exchange.address,
            "kind": exchange.kind,
            "problems": [p.value for p in exchange.problems],
            "line": exchange_line(exchange, origin=self.epoch, absolute=True),
        }

    def since(self, seq: int, limit: int) -> tuple[list[dict[str, Any]], int]:
        """Decoded telegrams numbered above ``seq``, the newest ``limit`` of them, and how
        many newer than ``seq`` were left out."""
        newer = [(n, ex) for n, ex in self.exchanges if n > seq]
        left_out = max(self.newest - seq - len(newer), 0) + max(len(newer) - limit, 0)
        return [self.exchange_dict(n, ex) for n, ex in newer[-limit:]], left_out

    def _feed(self, port: int, chunk: Chunk) -> None:
        if self.monitor is None:
            return
        out = self.monitor.feed(chunk.data, chunk.timestamp, chunk.errors, port=port)
        if out:
            self._publish(out)

    async def _tick(self, transport: Transport) -> None:
        """Tell the monitor of the tapped line that time passes (for missing answers)."""
        from pyuss.monitor.live import LAG, TICK

        while not self.stop.is_set():
            await asyncio.sleep(TICK)
            if self.monitor is not None:
                now = transport.clock() - LAG
                out = self.monitor.advance(now, port=0) + self.monitor.advance(now, port=1)
                if out:
                    self._publish(out)

    async def _watch(self, listener: Transport) -> None:
        from pyuss.monitor.live import watch

        assert self.monitor is not None
        try:
            await watch(self.monitor, [listener], self._publish, self.stop)
        finally:
            await listener.close()

    def pcapng(self, baud: int) -> bytes:
        """The telegrams the monitor view holds, as a pcapng capture (Wireshark)."""
        from pyuss.monitor.capture import open_writer, write_all

        assert self.monitor is not None
        with tempfile.TemporaryDirectory(prefix="pyuss-web-") as folder:
            path = Path(folder) / "line.pcapng"
            writer = open_writer(
                path,
                baud=baud,
                four_wire=self.monitor.four_wire,
                epoch=self.epoch,
                gap=self.monitor.gap,
            )
            write_all(writer, (ex for _, ex in list(self.exchanges)))
            return path.read_bytes()
