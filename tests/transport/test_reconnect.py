"""ReconnectingTransport over real TCP on 127.0.0.1: a loss is noticed by the next read or
write, the link reopened (the first try at once, then waits doubling up to a ceiling), and an
outage logged once when it begins, once a minute while it lasts and once when it ends."""

from __future__ import annotations

import asyncio
import itertools
import logging

import pytest

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.reconnect import (
    BACKOFF_INITIAL,
    BACKOFF_MAX,
    LinkDown,
    ReconnectingTransport,
    backoff,
    duration_text,
)
from pyuss.transport.tcp import TcpServerTransport, TcpTransport
from pyuss.transport.url import open_transport
from transport.helpers import WAIT, joined, read_bytes

LOGGER = "pyuss.transport.reconnect"


async def _wait_for(
    predicate: object, timeout: float = WAIT, reader: ReconnectingTransport | None = None
) -> bool:
    """Whether ``predicate()`` holds within ``timeout``; with ``reader``, reading it meanwhile
    (a loss is noticed by a read, as the master reads all the time)."""
    assert callable(predicate)
    for _ in range(int(timeout / 0.02)):
        if predicate():
            return True
        if reader is not None:
            await reader.read(0.02)
        else:
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
        assert await _wait_for(lambda: losses, reader=link)
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
    assert "link lost" in messages[0] and "at once, then after 0.01 s" in messages[0]
    assert not [m for m in messages if "reconnect try" in m]  # each try at DEBUG only
    assert "gave up after 5 tries" in messages[-1] and str(port) in messages[-1]


def test_backoff_sequence() -> None:
    # the waits after the first try (made at once), as documented: 0.5 s doubling up to 10 s
    assert list(itertools.islice(backoff(BACKOFF_INITIAL, BACKOFF_MAX), 8)) == [
        0.5,
        1.0,
        2.0,
        4.0,
        8.0,
        10.0,
        10.0,
        10.0,
    ]


def test_an_outage_lasts_as_people_read_it() -> None:
    assert duration_text(4.25) == "4.2 s"
    assert duration_text(185) == "3 min 5 s"
    assert duration_text(7620) == "2 h 7 min"


async def test_an_outage_is_one_line_when_it_begins_and_one_when_it_ends(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    # many failed tries, and a link that comes back and drops again at once (a converter
    # that takes the connection and closes it): one outage, two lines
    monkeypatch.setattr("pyuss.transport.reconnect.SETTLE", 3.0)  # what "at once" is here
    caplog.set_level(logging.WARNING, logger=LOGGER)
    server = TcpServerTransport()
    await server.open()
    port = server.port
    link = ReconnectingTransport(
        lambda: TcpTransport("127.0.0.1", port), backoff_initial=0.01, backoff_max=0.02
    )

    def messages() -> list[str]:
        return [r.getMessage() for r in caplog.records if r.name == LOGGER]

    async with link:
        assert await server.wait_peer(WAIT)
        await server.close()
        assert await _wait_for(lambda: link.losses == 1, reader=link)
        await asyncio.sleep(0.3)  # tries every 0.02 s: refused
        server = TcpServerTransport("127.0.0.1", port)
        await server.open()
        assert await _wait_for(lambda: link.connected)
        await server.close()  # lost again at once: the same outage
        assert await _wait_for(lambda: link.losses == 2, reader=link)
        server = TcpServerTransport("127.0.0.1", port)
        await server.open()
        assert await _wait_for(lambda: link.connected, reader=link)
        assert await _wait_for(lambda: any("link back" in m for m in messages()), 15)
    assert len(messages()) == 2, messages()
    assert "link lost" in messages()[0]
    assert "link back after" in messages()[1] and "tries)" in messages()[1]
    await server.close()


async def test_a_long_outage_is_told_of_once_a_minute(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("pyuss.transport.reconnect.REPORT_EVERY", 0.2)
    caplog.set_level(logging.WARNING, logger=LOGGER)
    server = TcpServerTransport()
    await server.open()
    port = server.port
    link = ReconnectingTransport(
        lambda: TcpTransport("127.0.0.1", port), backoff_initial=0.05, backoff_max=0.05
    )
    async with link:
        assert await server.wait_peer(WAIT)
        await server.close()
        assert await _wait_for(lambda: link.losses == 1, reader=link)
        still = lambda: [r for r in caplog.records if "still lost" in r.getMessage()]  # noqa: E731
        assert await _wait_for(lambda: len(still()) >= 2)
    first = still()[0].getMessage()
    assert "still lost after" in first and "tries so far" in first and str(port) in first


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
        assert await _wait_for(lambda: link.losses == 1, reader=link)
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
        assert await _wait_for(lambda: link.losses == 1, reader=link)
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
