"""TcpTransport and TcpServerTransport on 127.0.0.1."""

from __future__ import annotations

import asyncio
import socket

import pytest

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.tcp import TcpServerTransport, TcpTransport
from transport.helpers import WAIT, joined, read_bytes


async def test_client_and_server_carry_bytes_both_ways() -> None:
    async with TcpServerTransport("127.0.0.1", 0, baud=38400) as server:
        assert server.port > 0
        async with TcpTransport("127.0.0.1", server.port, baud=38400) as client:
            assert await server.wait_peer(WAIT)
            await client.write(b"\x02\x06\x03\x10\x20\x30\x40\x57")
            assert joined(await read_bytes(server, 8)) == b"\x02\x06\x03\x10\x20\x30\x40\x57"
            await server.write(bytes(range(200)))
            assert joined(await read_bytes(client, 200)) == bytes(range(200))


async def test_server_serves_one_peer_at_a_time_and_the_next_after() -> None:
    async with TcpServerTransport() as server:
        first = TcpTransport("127.0.0.1", server.port)
        await first.open()
        assert await server.wait_peer(WAIT)
        second = TcpTransport("127.0.0.1", server.port)
        await second.open()
        with pytest.raises(TransportError, match="closed by the peer"):
            await second.read(WAIT)
        await second.close()
        assert server.peers_refused == 1
        await first.write(b"one")
        assert joined(await read_bytes(server, 3)) == b"one"
        await first.close()
        for _ in range(250):
            if not server.connected:
                break
            await asyncio.sleep(0.02)
        assert not server.connected
        async with TcpTransport("127.0.0.1", server.port) as third:
            await third.write(b"three")
            assert joined(await read_bytes(server, 5)) == b"three"
        assert server.peers_served == 2


async def test_server_write_without_peer_is_counted_not_sent() -> None:
    async with TcpServerTransport() as server:
        await server.write(b"nobody")
        assert server.stats.dropped_out == 6
        async with TcpTransport("127.0.0.1", server.port) as client:
            assert await server.wait_peer(WAIT)
            await server.write(b"hi")
            assert joined(await read_bytes(client, 2)) == b"hi"


async def test_client_learns_when_the_server_goes() -> None:
    server = TcpServerTransport()
    await server.open()
    async with TcpTransport("127.0.0.1", server.port) as client:
        assert await server.wait_peer(WAIT)
        await server.write(b"bye")
        assert joined(await read_bytes(client, 3)) == b"bye"
        await server.close()
        with pytest.raises(TransportError, match=r"tcp://127\.0\.0\.1"):
            await client.read(WAIT)
        with pytest.raises(TransportError):
            await client.write(b"x")


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


async def test_connect_refused_names_the_address() -> None:
    port = _free_port()
    with pytest.raises(TransportError, match=f"127.0.0.1:{port}"):
        await TcpTransport("127.0.0.1", port).open()


async def test_listen_on_a_taken_port_fails() -> None:
    async with TcpServerTransport() as server:
        with pytest.raises(TransportError, match=str(server.port)):
            await TcpServerTransport("127.0.0.1", server.port).open()


@pytest.mark.parametrize(
    ("host", "port", "words"),
    [("", 502, "host"), ("127.0.0.1", 0, "TCP port"), ("127.0.0.1", 70000, "TCP port")],
)
def test_bad_endpoint(host: str, port: int, words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        TcpTransport(host, port)


async def test_echo_over_tcp_is_removed() -> None:
    async with (
        TcpServerTransport() as server,
        TcpTransport("127.0.0.1", server.port, echo=True) as client,
    ):
        assert await server.wait_peer(WAIT)
        await client.write(b"\x02\x02\x00\x00")
        # A converter that echoes: the server side returns the bytes, then answers.
        assert joined(await read_bytes(server, 4)) == b"\x02\x02\x00\x00"
        await server.write(b"\x02\x02\x00\x00" + b"\x02\x02\x01\x01")
        assert joined(await read_bytes(client, 4)) == b"\x02\x02\x01\x01"
        assert client.stats.echo_bytes == 4
