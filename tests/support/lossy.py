"""A lossy TCP proxy for a USS line carried over TCP (`uss simulate --tcp`): a master connects to
the proxy, the proxy to the simulator, and the bytes pass both ways, except where the test says
otherwise. Towards the master it cuts the byte stream into telegrams (STX, LGE, ..., BCC: LGE +
2 bytes, USS specification C 3.1) and can leave out the next answers of one address (`drop`:
one answer, a burst, or all until `clear`); `cut` closes every connection and refuses new ones
until `restore`, as an unplugged converter would. A simulator that is gone (killed) closes the
proxy's connection to the master as well, and a new connection finds none until the simulator
listens again. Threads and blocking sockets, so it runs beside any event loop of the test."""

from __future__ import annotations

import contextlib
import socket
import threading
from collections.abc import Iterator

STX = 0x02


class LossyProxy:
    """The proxy on a free loopback port (`port`) towards ``upstream`` (a port of 127.0.0.1)."""

    def __init__(self, upstream: int) -> None:
        self.upstream = upstream
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port: int = self.listener.getsockname()[1]
        self.lock = threading.Lock()
        self.sockets: list[socket.socket] = []
        self.down = False
        self.closed = False
        self.to_drop: dict[int, int] = {}
        """Per address, how many of its next answers are left out."""
        self.dropped: dict[int, int] = {}
        """Per address, how many answers were left out so far."""
        self.passed: dict[int, int] = {}
        """Per address, how many answers went through."""
        self.connections = 0
        self.refused = 0
        self.thread = threading.Thread(target=self._accept, daemon=True)

    def start(self) -> LossyProxy:
        self.thread.start()
        return self

    def close(self) -> None:
        self.closed = True
        self.listener.close()
        self._close_all()
        self.thread.join(5)

    def drop(self, address: int, count: int = 1) -> None:
        """Leave out the next ``count`` answers of drive ``address``."""
        with self.lock:
            self.to_drop[address] = self.to_drop.get(address, 0) + count

    def clear(self, address: int) -> None:
        """Let the answers of ``address`` through again from now on."""
        with self.lock:
            self.to_drop[address] = 0

    def pending(self, address: int) -> int:
        """How many answers of ``address`` are still to be left out."""
        with self.lock:
            return self.to_drop.get(address, 0)

    def cut(self) -> None:
        """Close every connection and refuse new ones until `restore`."""
        self.down = True
        self._close_all()

    def restore(self) -> None:
        self.down = False

    def _close_all(self) -> None:
        with self.lock:
            sockets, self.sockets = self.sockets, []
        for sock in sockets:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
            sock.close()

    def _accept(self) -> None:
        while not self.closed:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return
            if self.down:
                self.refused += 1
                client.close()
                continue
            try:
                server = socket.create_connection(("127.0.0.1", self.upstream), timeout=2)
            except OSError:  # the simulator is not there
                self.refused += 1
                client.close()
                continue
            server.settimeout(None)
            for sock in (client, server):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self.lock:
                self.sockets += [client, server]
            self.connections += 1
            pair = (client, server)
            threading.Thread(target=self._requests, args=pair, daemon=True).start()
            threading.Thread(target=self._answers, args=pair, daemon=True).start()

    def _end(self, *sockets: socket.socket) -> None:
        with self.lock:
            self.sockets = [s for s in self.sockets if s not in sockets]
        for sock in sockets:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
            sock.close()

    def _requests(self, client: socket.socket, server: socket.socket) -> None:
        """The master's bytes, to the simulator as they come."""
        try:
            while data := client.recv(4096):
                server.sendall(data)
        except OSError:
            pass
        self._end(client, server)

    def _answers(self, client: socket.socket, server: socket.socket) -> None:
        """The simulator's bytes, to the master telegram by telegram, but the dropped ones."""
        buffer = bytearray()
        try:
            while data := server.recv(4096):
                buffer += data
                for chunk in _telegrams(buffer):
                    if self._keep(chunk):
                        client.sendall(chunk)
        except OSError:
            pass
        self._end(client, server)

    def _keep(self, chunk: bytes) -> bool:
        if len(chunk) < 3 or chunk[0] != STX:
            return True  # what is no telegram goes on as it came
        address = chunk[2] & 0x1F
        with self.lock:
            if self.to_drop.get(address, 0) > 0:
                self.to_drop[address] -= 1
                self.dropped[address] = self.dropped.get(address, 0) + 1
                return False
            self.passed[address] = self.passed.get(address, 0) + 1
        return True


def _telegrams(buffer: bytearray) -> Iterator[bytes]:
    """Whole telegrams (and bytes before an STX) taken from the front of ``buffer``; an
    incomplete telegram stays in it."""
    while buffer:
        if buffer[0] != STX:
            start = buffer.find(STX)
            end = len(buffer) if start < 0 else start
            yield bytes(buffer[:end])
            del buffer[:end]
            continue
        if len(buffer) < 2:
            return
        size = buffer[1] + 2
        if len(buffer) < size:
            return
        yield bytes(buffer[:size])
        del buffer[:size]
