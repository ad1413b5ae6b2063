"""ReconnectingTransport over real TCP on 127.0.0.1."""

from __future__ import annotations

import asyncio

import pytest

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.reconnect import LinkDown, ReconnectingTransport
from pyuss.transport.tcp import TcpServerTransport, TcpTransport
from transport.helpers import WAIT, joined, read_bytes


async def _wait_for(predicate: object, timeout: float = WAIT) -> bool:
    assert callable(predicate)
    for _ in range(int(timeout / 0.02)):
        if predicate():
            return True
        await asyncio.sleep(0.02)
    return bool(predicate())


async def test_link_loss_is_reported_and_the_link_comes_back() -> None:
    server = TcpServerTransport()
    await server.open()
    port = server.port
    losses: list[TransportError] = []
    link = ReconnectingTransport(
        lambda: TcpTransport("127.0.0.1", port),
        backoff_initial=0.02,
        backoff_max=0.1,
        on_loss=losses.append,
    )
    async with link:
        assert await server.wait_peer(WAIT)
        await server.write(b"before")
        assert joined(await read_bytes(link, 6)) == b"before"
        await server.close()
        assert await _wait_for(lambda: losses)
        assert link.losses == 1
        assert not link.connected
        with pytest.raises(LinkDown, match="not sent"):
            await link.write(b"lost")
        # Readers are not bothered while the link is down.
        assert await link.read(0.05) is None
        server = TcpServerTransport("127.0.0.1", port)
        await server.open()
        assert await _wait_for(lambda: link.connected)
        assert link.reconnects == 1
        assert await server.wait_peer(WAIT)
        await link.write(b"after")
        assert joined(await read_bytes(server, 5)) == b"after"
        await server.write(b"back")
        assert joined(await read_bytes(link, 4)) == b"back"
    await server.close()


async def test_readers_get_the_error_when_reconnecting_is_given_up() -> None:
    server = TcpServerTransport()
    await server.open()
    port = server.port
    link = ReconnectingTransport(
        lambda: TcpTransport("127.0.0.1", port),
        backoff_initial=0.01,
        backoff_max=0.02,
        max_attempts=3,
    )
    async with link:
        assert await server.wait_peer(WAIT)
        await server.close()
        with pytest.raises(TransportError, match="gave up after 3 tries"):
            await link.read(WAIT)


async def test_give_up_on_request() -> None:
    server = TcpServerTransport()
    await server.open()
    port = server.port
    link = ReconnectingTransport(lambda: TcpTransport("127.0.0.1", port), backoff_initial=0.05)
    async with link:
        assert await server.wait_peer(WAIT)
        await server.close()
        assert await _wait_for(lambda: link.losses == 1)
        link.give_up()
        with pytest.raises(TransportError, match="gave up"):
            await link.read(WAIT)


async def test_first_open_is_not_retried() -> None:
    server = TcpServerTransport()
    await server.open()
    port = server.port
    await server.close()
    link = ReconnectingTransport(lambda: TcpTransport("127.0.0.1", port))
    with pytest.raises(TransportError, match=str(port)):
        await link.open()


def test_bad_backoff() -> None:
    with pytest.raises(ConfigError, match="back-off"):
        ReconnectingTransport(lambda: TcpTransport("127.0.0.1", 1), backoff_initial=0)
