"""`uss` commands in processes of their own: `uss simulate` serving TCP (`simulator`), a
virtual bus of its own (`simulator_bus`) or a pty (`simulator_pty`), and any command started
as a user runs it (`first_line`, `line_within`), stopped as by SIGTERM (`stop_uss`)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from typing import IO

from support.posix import POSIX

USS = [sys.executable, "-m", "pyuss.cli.main"]

TCP = ("--tcp", "127.0.0.1:0")
"""The line of `uss simulate` that every system has: a TCP server on a free loopback port."""


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


def line_within(stream: IO[str] | None, timeout: float, silent: str = "nothing printed") -> str:
    """The next line of ``stream`` (a process's output), stripped ("" at the end of the
    output); fails with the message ``silent`` when none comes within ``timeout`` seconds.
    Read in a thread: ``select`` waits for pipes on POSIX systems only."""
    assert stream is not None
    got: list[str] = []
    reader = threading.Thread(target=lambda: got.append(stream.readline()), daemon=True)
    reader.start()
    reader.join(timeout)
    assert got, silent
    return got[0].strip()


def stop_uss(process: subprocess.Popen[str], sig: int = signal.SIGTERM) -> int:
    """Stop ``process`` with ``sig`` (SIGTERM: as a service manager does); its exit code."""
    if process.poll() is None:
        process.send_signal(sig)
    return process.wait(30)


def end_process(process: subprocess.Popen[str]) -> None:
    """End a process whose way of ending the test does not look at: as Ctrl+C does on POSIX
    systems, killed elsewhere (Windows sends no signal to another process) or when it does not
    end within 10 s."""
    if process.poll() is None:
        if POSIX:
            process.send_signal(signal.SIGINT)
        else:  # pragma: no cover - Windows
            process.kill()
    try:
        process.wait(10)
    except subprocess.TimeoutExpired:  # pragma: no cover
        process.kill()
        process.wait(10)


BUS = ("--bus-tcp", "127.0.0.1:0")
"""A virtual bus of the simulator's own on a free loopback port: one rate, its own timeline."""


def start_simulator(
    *options: str, pty: bool = False, bus: bool = False
) -> tuple[subprocess.Popen[str], str]:
    """``uss simulate OPTIONS`` on a TCP server of a free loopback port (``pty``: on a pty;
    ``bus``: a virtual bus of its own, `BUS`) in a process of its own: the process and the
    first line it prints (``tcp://127.0.0.1:PORT``, ``bus://127.0.0.1:PORT`` or the pty's
    path), the port to open."""
    line = ("--pty",) if pty else BUS if bus else TCP
    process = subprocess.Popen(
        [*USS, "simulate", *options, *line],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    port = process.stdout.readline().strip()
    start = "/dev/" if pty else "bus://127.0.0.1:" if bus else "tcp://127.0.0.1:"
    assert port.startswith(start), process.stderr.read() if process.stderr else port
    return process, port


def stop_simulator(process: subprocess.Popen[str]) -> None:
    """Stop a simulator (`end_process`)."""
    end_process(process)


@contextlib.contextmanager
def simulator(*options: str) -> Iterator[str]:
    """A `uss simulate` process serving TCP for the block: yields its ``tcp://`` URL."""
    process, port = start_simulator(*options)
    try:
        yield port
    finally:
        stop_simulator(process)


@contextlib.contextmanager
def simulator_bus(*options: str) -> Iterator[str]:
    """A `uss simulate` process with its drives on a virtual bus of its own for the block
    (one rate: a station at another is refused): yields its ``bus://`` URL."""
    process, port = start_simulator(*options, bus=True)
    try:
        yield port
    finally:
        stop_simulator(process)


@contextlib.contextmanager
def simulator_pty(*options: str) -> Iterator[str]:
    """A `uss simulate` process serving a pty for the block: yields the pty's path."""
    process, path = start_simulator(*options, pty=True)
    try:
        yield path
    finally:
        stop_simulator(process)
