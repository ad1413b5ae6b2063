"""Loopback ports for servers the tests start."""

from __future__ import annotations

import contextlib
import itertools
import os
import socket
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

PORTS_FROM = 20000
"""The first of the ports `free_port` hands out: below the ephemeral range (Linux 32768 and
up), so no port the system gives another test (``bind`` to 0, a client's socket) is one of
them."""
PORTS_EACH = 1500
"""How many of them each test process (pytest-xdist worker) has, apart from the others'."""
_turn = itertools.count()


def free_port() -> int:
    """A TCP port of 127.0.0.1 free at the time of asking, from this test process's own range:
    a port asked of the system (``bind`` to 0) and set free again could be handed to another
    worker's server before this one's binds it."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw")
    first = PORTS_FROM + (int(worker) % 8 if worker.isdigit() else 0) * PORTS_EACH
    for _ in range(PORTS_EACH):
        port = first + next(_turn) % PORTS_EACH
        with socket.socket() as sock:
            try:
                sock.bind(("127.0.0.1", port))
            except OSError:
                continue  # taken (or still held by a connection of before): the next one
        return port
    raise RuntimeError(f"no free port in {first}..{first + PORTS_EACH - 1}")


@contextlib.contextmanager
def holding(port: int, timeout: float = 300.0) -> Iterator[None]:
    """Hold the fixed loopback ``port`` (8420, the page's default) against the other test
    processes while the block runs: the tests that run documented commands with a fixed port
    take turns (a directory made atomically is the lock, on every system)."""
    lock = Path(tempfile.gettempdir()) / f"pyuss-tests-port-{port}.lock"
    deadline = time.monotonic() + timeout
    while True:
        try:
            lock.mkdir()
            break
        except FileExistsError:
            with contextlib.suppress(OSError):
                if time.time() - lock.stat().st_mtime > timeout:  # left by a killed run
                    lock.rmdir()
                    continue
            if time.monotonic() > deadline:
                raise TimeoutError(
                    f"port {port} held by another test for {timeout:.0f} s"
                ) from None
            time.sleep(0.2)
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            lock.rmdir()
