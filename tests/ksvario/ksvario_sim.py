"""A simulated KS VARIO served from its own thread and event loop (tests): on a real pty, or on
any line `pyuss.ksvario.simulate.serve` takes (``tcp-listen://127.0.0.1:0``)."""

from __future__ import annotations

import asyncio
import threading

from pyuss.ksvario.coupler import Coupler
from pyuss.ksvario.simulate import serve


class SlaveThread:
    """The simulated KS VARIO served from its own event loop on ``port`` (None: a pty);
    ``device`` is what a DP master opens."""

    def __init__(self, coupler: Coupler, station: int, port: str | None = None) -> None:
        self.coupler = coupler
        self.station = station
        self.port = port
        self.device = ""
        self.ready = threading.Event()
        self.loop = asyncio.new_event_loop()
        self.stop = asyncio.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.error: BaseException | None = None

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)

        def ready(device: str) -> None:
            self.device = device
            self.ready.set()

        try:
            self.loop.run_until_complete(
                serve(
                    station=self.station,
                    port=self.port,
                    coupler=self.coupler,
                    on_ready=ready,
                    stop=self.stop,
                )
            )
        except BaseException as exc:  # reported by the test
            self.error = exc
            self.ready.set()

    def __enter__(self) -> SlaveThread:
        self.thread.start()
        assert self.ready.wait(10), "slave did not start"
        assert self.error is None, self.error
        return self

    def __exit__(self, *exc: object) -> None:
        self.loop.call_soon_threadsafe(self.stop.set)
        self.thread.join(10)
        self.loop.close()
