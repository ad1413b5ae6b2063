"""`uss` commands in processes of their own: `uss simulate` serving a pty, and any command
started as a user runs it (`start_uss`), read line by line (`first_line`), stopped as by
SIGTERM (`stop_uss`)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator

USS = [sys.executable, "-m", "pyuss.cli.main"]


def start_uss(*args: str) -> subprocess.Popen[str]:
    """``uss ARGS`` in a process of its own: its output lines to read, its log lines (stderr)
    into a file (a pipe nobody reads would fill and stop the process)."""
    log = tempfile.TemporaryFile("w+")  # noqa: SIM115 - closed with the process
    return subprocess.Popen(
        [*USS, *args],
        stdout=subprocess.PIPE,
        stderr=log,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def first_line(process: subprocess.Popen[str], want: str, timeout: float = 30) -> str:
    """The first output line of ``process`` holding ``want`` (fails after ``timeout`` s)."""
    assert process.stdout is not None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        if want in line:
            return line.strip()
    raise AssertionError(
        f"no line with {want!r}; stderr: {process.stderr.read() if process.stderr else ''}"
    )


def stop_uss(process: subprocess.Popen[str], sig: int = signal.SIGTERM) -> int:
    """Stop ``process`` with ``sig`` (SIGTERM: as a service manager does); its exit code."""
    if process.poll() is None:
        process.send_signal(sig)
    return process.wait(30)


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
