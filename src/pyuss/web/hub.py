"""Live updates to the page's clients, each with a bounded send queue.

Every WebSocket client has a queue of at most ``queue_size`` messages and a task that sends
them one by one, each within ``send_timeout`` seconds. `Hub.send` never waits: a message that
does not fit a client's queue drops that client (its connection is cut at once), and so does a
send that does not finish in time. An idle, slow or hostile client therefore holds at most its
queue and the socket's buffers, and never holds up the others; the page reconnects by itself.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field

from pyuss._tasks import cancel_and_wait

__all__ = ["Client", "Hub"]

log = logging.getLogger("pyuss.web")

QUEUE_SIZE = 64
"""Messages waiting for one client at most (about 3 s of live updates)."""
SEND_TIMEOUT = 5.0
"""Seconds one message may take to go out to a client."""


@dataclass(eq=False)
class Client:
    """One connected page: how to send to it and how to cut it off."""

    send: Callable[[str], Awaitable[None]]
    abort: Callable[[], None]
    name: str = ""
    monitor: bool = False
    """The client shows the monitor view: it gets the decoded telegrams."""
    queue: asyncio.Queue[str] = field(default_factory=lambda: asyncio.Queue(QUEUE_SIZE))
    task: asyncio.Task[None] | None = None
    closed: bool = False
    longest: int = 0
    """The longest the queue has been (for tests and diagnostics)."""


class Hub:
    """The connected clients and what goes out to them."""

    def __init__(self, *, queue_size: int = QUEUE_SIZE, send_timeout: float = SEND_TIMEOUT):
        self.queue_size = queue_size
        self.send_timeout = send_timeout
        self.clients: list[Client] = []
        self.dropped = 0
        """Clients cut off for falling behind."""
        self.longest = 0
        """The longest any client's queue has been."""

    def add(
        self, send: Callable[[str], Awaitable[None]], abort: Callable[[], None], name: str = ""
    ) -> Client:
        client = Client(send, abort, name, queue=asyncio.Queue(self.queue_size))
        client.task = asyncio.create_task(self._sender(client))
        self.clients.append(client)
        return client

    async def remove(self, client: Client) -> None:
        self._forget(client)
        if client.task is not None and client.task is not asyncio.current_task():
            await cancel_and_wait(client.task)

    def send(self, message: str, *, monitor_only: bool = False) -> None:
        """Queue ``message`` for every client (those showing the monitor: ``monitor_only``)."""
        for client in list(self.clients):
            if monitor_only and not client.monitor:
                continue
            self.send_to(client, message)

    def send_to(self, client: Client, message: str) -> None:
        if client.closed:
            return
        try:
            client.queue.put_nowait(message)
        except asyncio.QueueFull:
            self._drop(client, f"{self.queue_size} messages behind")
            return
        size = client.queue.qsize()
        client.longest = max(client.longest, size)
        self.longest = max(self.longest, size)

    def _forget(self, client: Client) -> None:
        """Mark ``client`` closed and take it off the list: nothing more is queued for it."""
        client.closed = True
        if client in self.clients:
            self.clients.remove(client)

    def _drop(self, client: Client, why: str) -> None:
        if client.closed:
            return
        self._forget(client)
        self.dropped += 1
        log.warning("web client %s dropped: %s", client.name or "?", why)
        while not client.queue.empty():
            client.queue.get_nowait()
        client.abort()
        if client.task is not None and client.task is not asyncio.current_task():
            client.task.cancel()

    async def _sender(self, client: Client) -> None:
        while not client.closed:
            message = await client.queue.get()
            try:
                async with asyncio.timeout(self.send_timeout):
                    await client.send(message)
            except TimeoutError:
                self._drop(client, f"a message took longer than {self.send_timeout:g} s")
                return
            except (ConnectionError, RuntimeError) as exc:
                # The connection is gone (closed by the peer, or closing).
                log.debug("web client %s gone: %s", client.name, exc)
                self._forget(client)
                return

    async def close(self) -> None:
        for client in list(self.clients):
            await self.remove(client)
