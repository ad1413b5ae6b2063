"""Fixtures of the web tests: the demo's backend in the test's loop, the page's server on a
thread of its own, and a headless Chromium (helpers in support/web.py)."""

from __future__ import annotations

import shutil
from collections.abc import AsyncIterator, Iterator
from typing import Any

import pytest

from pyuss.web.backend import Backend
from support.web import CHROMIUM, Running


@pytest.fixture
async def backend() -> AsyncIterator[Backend]:
    """The demo's backend in the test's own event loop."""
    backend = Backend(demo=True)
    await backend.start()
    try:
        yield backend
    finally:
        await backend.close()


@pytest.fixture(scope="module")
def demo() -> Iterator[Running]:
    running = Running()
    try:
        yield running
    finally:
        running.stop()


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    if not shutil.which(CHROMIUM):
        pytest.skip("Debian's chromium is not installed (.ci/system-deps chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True)
        try:
            yield browser
        finally:
            browser.close()
