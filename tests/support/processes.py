"""`uss simulate` in a process of its own, serving a pty."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
from collections.abc import Iterator


def start_simulator(*options: str) -> tuple[subprocess.Popen[str], str]:
    """``uss simulate OPTIONS --pty`` in a process of its own: the process and its pty's path."""
    process = subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", "simulate", *options, "--pty"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    path = process.stdout.readline().strip()
    assert path.startswith("/dev/"), process.stderr.read() if process.stderr else path
    return process, path


def stop_simulator(process: subprocess.Popen[str]) -> None:
    """Stop a simulator as Ctrl+C does; kill it if it does not end within 10 s."""
    process.send_signal(signal.SIGINT)
    try:
        process.wait(10)
    except subprocess.TimeoutExpired:  # pragma: no cover
        process.kill()


@contextlib.contextmanager
def simulator_pty(*options: str) -> Iterator[str]:
    """A `uss simulate` process serving a pty for the block: yields the pty's path."""
    process, path = start_simulator(*options)
    try:
        yield path
    finally:
        stop_simulator(process)
