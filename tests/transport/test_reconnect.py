"""ReconnectingTransport over real TCP on 127.0.0.1."""

from __future__ import annotations

import asyncio
import itertools
import logging

import pytest

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.reconnect import LinkDown, ReconnectingTransport, backoff
from pyuss.transport.tcp import TcpServerTransport, TcpTransport
from pyuss.transport.url import open_transport
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


async def test_readers_get_the_error_when_reconnecting_is_given_up(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger="pyuss.transport.reconnect")
    server = TcpServerTransport()
    await server.open()
    port = server.port
    link = ReconnectingTransport(
        lambda: TcpTransport("127.0.0.1", port),
        backoff_initial=0.01,
        backoff_max=0.03,
        max_attempts=5,
    )
    async with link:
        assert await server.wait_peer(WAIT)
        await server.close()
        with pytest.raises(TransportError, match="gave up after 5 tries"):
            await link.read(WAIT)
    messages = [r.getMessage() for r in caplog.records if r.name == "pyuss.transport.reconnect"]
    assert "link lost" in messages[0]
    tries = [m for m in messages if "reconnect try" in m]
    assert [m.rsplit("next try in ", 1)[-1] for m in tries[:-1]] == [
        "0.02 s",
        "0.03 s",
        "0.03 s",
        "0.03 s",
    ]
    assert "reconnect try 5 failed" in tries[-1]
    assert all(str(port) in m for m in tries)  # each says what failed


def test_backoff_sequence() -> None:
    assert list(itertools.islice(backoff(0.1, 5.0), 8)) == [
        0.1,
        0.2,
        0.4,
        0.8,
        1.6,
        3.2,
        5.0,
        5.0,
    ]


async def test_serial_port_over_socket_url_comes_back_after_a_drop() -> None:
    server = TcpServerTransport()
    await server.open()
    port = server.port
    built = open_transport(
        f"socket://127.0.0.1:{port}", reconnect=True, backoff_initial=0.02, backoff_max=0.1
    )
    assert isinstance(built, ReconnectingTransport)
    link: ReconnectingTransport = built
    async with link:
        assert await server.wait_peer(WAIT)
        await server.write(b"one")
        assert joined(await read_bytes(link, 3)) == b"one"
        await server.close()  # as an unplugged adapter: pyserial reports the port gone
        assert await _wait_for(lambda: link.losses == 1)
        with pytest.raises(LinkDown):
            await link.write(b"lost")
        server = TcpServerTransport("127.0.0.1", port)
        await server.open()
        assert await _wait_for(lambda: link.connected)
        assert await server.wait_peer(WAIT)
        await link.write(b"two")
        assert joined(await read_bytes(server, 3)) == b"two"
    await server.close()


async def test_a_failing_loss_callback_reaches_the_reader() -> None:
    server = TcpServerTransport()
    await server.open()
    port = server.port

    def broken(_: TransportError) -> None:
        raise RuntimeError("callback broke")

    link = ReconnectingTransport(lambda: TcpTransport("127.0.0.1", port), on_loss=broken)
    async with link:
        assert await server.wait_peer(WAIT)
        await server.close()
        with pytest.raises(TransportError, match="callback broke"):
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
