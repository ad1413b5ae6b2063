"""The page's server on a thread of its own (its own event loop) or in the test's loop,
against the demo's simulated drives, and pages of a real headless Chromium driven by
Playwright.

The browser tests save a screenshot of each view into build/screenshots/ (git-ignored) on every
run; `make screenshots` runs them and copies the pictures into docs/images/, which docs/web.md
shows. A test run leaves the tracked tree as it was."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Coroutine
from concurrent.futures import Future
from pathlib import Path
from typing import Any, TypeVar

from pyuss.web.backend import Backend
from pyuss.web.server import WebServer
from support.paths import ROOT

T = TypeVar("T")
CHROMIUM = "/usr/bin/chromium"
SHOTS = ROOT / "build" / "screenshots"
"""Where the browser tests save their screenshots (`make screenshots` copies them to docs)."""


def screenshot(page: Any, name: str, *, full_page: bool = False) -> Path:
    """Save a picture of what ``page`` shows as build/screenshots/NAME.png."""
    SHOTS.mkdir(parents=True, exist_ok=True)
    path = SHOTS / f"{name}.png"
    page.screenshot(path=path, full_page=full_page)
    return path


class LoopThread:
    """An event loop on a thread of its own, to run coroutines in (`call`): a page's server
    and backend run there."""

    server: WebServer
    backend: Any

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()

    def call(self, coro: Coroutine[Any, Any, T], timeout: float = 60) -> T:
        future: Future[T] = asyncio.run_coroutine_threadsafe(coro, self.loop)
        return future.result(timeout)

    def stop(self) -> None:
        """Close the page's server and backend (``server``, ``backend``), then `end`."""
        try:
            self.call(self.server.close())
            self.call(self.backend.close())
        finally:
            self.end()

    def end(self) -> None:
        """Stop the loop and its thread."""
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)


class Running(LoopThread):
    """Backend and server started in a background thread's event loop."""

    def __init__(self, **options: Any) -> None:
        super().__init__()
        self.options = options
        self.backend: Backend = self.call(self._backend())
        self.server = WebServer(
            self.backend, host=options.pop("host", "127.0.0.1"), port=0, **options
        )
        self.url = self.call(self.server.start())

    async def _backend(self) -> Backend:
        backend = Backend(demo=True)
        await backend.start()
        return backend

    def run(self, func: Any, *args: Any) -> Any:
        """Run a plain function in the server's loop (the simulated drives live there)."""

        async def call() -> Any:
            return func(*args)

        return self.call(call())


async def serve(backend: Backend, **options: Any) -> WebServer:
    """A server for ``backend`` on a free port of 127.0.0.1, started."""
    server = WebServer(backend, port=0, **options)
    await server.start()
    return server


def open_page(browser: Any, url: str, width: int = 1280, height: int = 860) -> Any:
    context = browser.new_context(
        viewport={"width": width, "height": height}, accept_downloads=True
    )
    # a wait for what the page shows ends as soon as it shows it; the limit only has to hold
    # on a loaded machine (`make test` runs four test processes on what may be two cores:
    # reading a V20's parameter values took 25 s of the 30 s there)
    context.set_default_timeout(90_000)
    page = context.new_page()
    page.goto(url)
    page.wait_for_function("window.pyuss && window.pyuss.socket && window.pyuss.bus")
    return page
