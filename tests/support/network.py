"""Loopback ports for servers the tests start."""

from __future__ import annotations

import contextlib
import socket
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path


def free_port() -> int:
    """A TCP port of 127.0.0.1 free at the time of asking."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


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
