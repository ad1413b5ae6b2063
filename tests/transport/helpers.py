"""Helpers for transport tests: collect what a transport delivers until a condition holds;
what other programs do to a serial device before pyuss opens it; an RFC 2217 server."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading
from typing import Any, cast

import serial
from serial import rfc2217

from pyuss.transport.base import Chunk, LineError, Transport

#: Generous: real ptys and sockets on a loaded machine.
WAIT = 5.0


async def read_bytes(transport: Transport, n: int, timeout: float = WAIT) -> list[Chunk]:
    """Read chunks until ``n`` bytes came (or ``timeout`` per read passes)."""
    chunks: list[Chunk] = []
    got = 0
    while got < n:
        chunk = await transport.read(timeout)
        if chunk is None:
            break
        chunks.append(chunk)
        got += len(chunk.data)
    return chunks


def joined(chunks: list[Chunk]) -> bytes:
    return b"".join(c.data for c in chunks)


def flat_errors(chunks: list[Chunk]) -> list[tuple[int, LineError]]:
    """Line errors of ``chunks`` with positions in the joined data."""
    out: list[tuple[int, LineError]] = []
    offset = 0
    for chunk in chunks:
        out += [(offset + pos, flag) for pos, flag in chunk.errors]
        offset += len(chunk.data)
    return out


def byte_ends(chunks: list[Chunk], baud: int) -> list[float]:
    """The end time of every byte, from the chunk stamps (bytes in a chunk are contiguous)."""
    tc = 11 / baud
    out: list[float] = []
    for chunk in chunks:
        n = len(chunk.data)
        out += [chunk.timestamp - (n - 1 - i) * tc for i in range(n)]
    return out


_HOLDER = """
import sys, time, serial
port = serial.Serial(sys.argv[1], 9600, xonxoff=True)
print("holding", flush=True)
time.sleep(60)
"""


def plain_8n1(path: str) -> None:
    """Another program opens the device at 9600 8N1 and closes it."""
    serial.Serial(path, 9600).close()


def even_8e1(path: str) -> None:
    """Another program opens the device at 9600 8E1 and closes it. Its C library may refuse
    that open (that is its business); what it leaves on the device must not keep pyuss out."""
    import termios  # a pty's settings: POSIX only

    with contextlib.suppress(serial.SerialException, termios.error):
        serial.Serial(path, 9600, parity="E").close()


def killed_holder(path: str) -> None:
    """A program that opened the device (9600 8N1, XON/XOFF) and is killed while it holds it."""
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, path], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None
        assert holder.stdout.readline() == "holding\n"
    finally:
        os.kill(holder.pid, signal.SIGKILL)  # POSIX only, as a pty is
        holder.wait(WAIT)
        if holder.stdout is not None:
            holder.stdout.close()


class Rfc2217Server:
    """A small RFC 2217 server (pyserial's `PortManager`) in front of a pyserial port, on
    127.0.0.1, serving one client in two threads, as ``examples/rfc2217_server.py`` does."""

    def __init__(self, port: Any) -> None:
        self.port = port
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.address: tuple[str, int] = self._listener.getsockname()[:2]
        self._alive = threading.Event()
        self._alive.set()
        self._threads = [threading.Thread(target=self._serve, daemon=True)]
        self._threads[0].start()

    def _serve(self) -> None:
        try:
            conn, _ = self._listener.accept()
        except OSError:
            return
        conn.settimeout(0.1)
        manager = rfc2217.PortManager(self.port, cast(Any, _Connection(conn)))
        to_client = threading.Thread(target=self._to_client, args=(conn, manager), daemon=True)
        self._threads.append(to_client)
        to_client.start()
        with conn:
            while self._alive.is_set():
                try:
                    data = conn.recv(1024)
                except TimeoutError:
                    continue
                except OSError:
                    break
                if not data:
                    break
                self.port.write(b"".join(manager.filter(data)))
            self._alive.clear()

    def _to_client(self, conn: socket.socket, manager: rfc2217.PortManager) -> None:
        while self._alive.is_set():
            try:
                data = self.port.read(self.port.in_waiting or 1)
                if data:
                    conn.sendall(b"".join(manager.escape(data)))
                manager.check_modem_lines()
            except OSError:
                break

    def close(self) -> None:
        self._alive.clear()
        self._listener.close()
        for thread in self._threads:
            thread.join(5)


class _Connection:
    def __init__(self, conn: socket.socket) -> None:
        self._conn = conn

    def write(self, data: bytes) -> None:
        self._conn.sendall(data)
