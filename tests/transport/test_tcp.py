"""TcpTransport and TcpServerTransport on 127.0.0.1."""

from __future__ import annotations

import asyncio
import socket

import pytest

from pyuss.errors import ConfigError, TransportError
from pyuss.transport import tcp
from pyuss.transport.tcp import TcpServerTransport, TcpTransport
from support.waiting import eventually
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


async def test_server_carries_the_line_to_several_peers() -> None:
    """What any peer sends reaches the line; what the line sends reaches every peer; a peer
    that leaves frees its place, and the next is served."""
    async with TcpServerTransport() as server:
        first = TcpTransport("127.0.0.1", server.port)
        await first.open()
        assert await server.wait_peer(WAIT)
        async with TcpTransport("127.0.0.1", server.port) as second:
            await second.write(b"two")
            assert joined(await read_bytes(server, 3)) == b"two"
            await first.write(b"one")
            assert joined(await read_bytes(server, 3)) == b"one"
            await server.write(b"all")
            assert joined(await read_bytes(first, 3)) == b"all"
            assert joined(await read_bytes(second, 3)) == b"all"
        await first.close()
        for _ in range(250):
            if not server.connected:
                break
            await asyncio.sleep(0.02)
        assert not server.connected
        async with TcpTransport("127.0.0.1", server.port) as third:
            await third.write(b"three")
            assert joined(await read_bytes(server, 5)) == b"three"
        assert server.peers_served == 3
        assert server.peers_replaced == 0


async def test_idle_peers_never_lock_a_new_one_out() -> None:
    """All places taken by idle peers: a new peer replaces the one silent longest."""
    async with TcpServerTransport(max_peers=2) as server:
        idle = [socket.create_connection(("127.0.0.1", server.port)) for _ in range(2)]
        try:
            for _ in range(250):
                if server.peers == 2:
                    break
                await asyncio.sleep(0.02)
            idle[1].sendall(b"x")  # the second one spoke last
            assert joined(await read_bytes(server, 1)) == b"x"
            async with TcpTransport("127.0.0.1", server.port) as master:
                await master.write(b"job")
                assert joined(await read_bytes(server, 3)) == b"job"
                await server.write(b"answer")
                assert joined(await read_bytes(master, 6)) == b"answer"
            assert server.peers_replaced == 1
            idle[0].setblocking(False)
            async with asyncio.timeout(WAIT):
                gone = await asyncio.get_running_loop().sock_recv(idle[0], 16)
            assert gone == b""  # the longest silent one was closed
        finally:
            for sock in idle:
                sock.close()


async def test_a_peer_that_does_not_read_is_disconnected_not_waited_for() -> None:
    async with TcpServerTransport() as server:
        stuck = socket.create_connection(("127.0.0.1", server.port))
        stuck.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        try:
            async with TcpTransport("127.0.0.1", server.port) as master:
                for _ in range(250):
                    if server.peers == 2:
                        break
                    await asyncio.sleep(0.02)
                for _ in range(4000):
                    await server.write(bytes(1024))  # never blocks on the stuck peer
                    if server.peers_dropped:
                        break
                    await read_bytes(master, 1024)
                assert server.peers_dropped == 1
                await master.write(b"still")
                assert joined(await read_bytes(server, 5)) == b"still"
        finally:
            stuck.close()


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


async def test_new_connections_do_not_push_out_a_peer_that_talks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A peer that connects again and again does not push a master that talks off the line: a
    newcomer takes the place of a peer that has said nothing since it connected (or nothing
    for `IDLE_PEER` seconds, made long here); when every peer has spoken within that time it
    is turned away."""
    monkeypatch.setattr(tcp, "IDLE_PEER", 3600.0)
    async with (
        TcpServerTransport(max_peers=2) as server,
        TcpTransport("127.0.0.1", server.port) as master,
    ):
        await master.write(b"job")
        assert joined(await read_bytes(server, 3)) == b"job"
        crowd = [socket.create_connection(("127.0.0.1", server.port)) for _ in range(5)]
        try:
            await eventually(
                lambda: server.peers_served == 6, WAIT, what="every silent newcomer served"
            )
            assert server.peers_replaced == 4  # each took the place of the one before
            await master.write(b"job")  # the master is still on the line
            assert joined(await read_bytes(server, 3)) == b"job"
            talker = socket.create_connection(("127.0.0.1", server.port))
            crowd.append(talker)
            talker.sendall(b"x")  # it takes the silent one's place, and speaks
            assert joined(await read_bytes(server, 1)) == b"x"
            assert server.peers_replaced == 5
            crowd += [socket.create_connection(("127.0.0.1", server.port)) for _ in range(2)]
            await eventually(
                lambda: server.peers_refused == 2, WAIT, what="two newcomers turned away"
            )
            assert server.peers == 2 and server.peers_replaced == 5
            await master.write(b"job")  # still on the line
            assert joined(await read_bytes(server, 3)) == b"job"
            await server.write(b"answer")
            assert joined(await read_bytes(master, 6)) == b"answer"
        finally:
            for sock in crowd:
                sock.close()


async def test_a_reader_cancelled_as_its_data_arrive_is_cancelled() -> None:
    # The data and the cancellation of the task reading them come in the same step: the
    # cancellation must win (the chunk stays for the next reader), or the task reads on.
    async with TcpServerTransport("127.0.0.1", 0) as line:
        reader = asyncio.create_task(line.read(timeout=5))
        await asyncio.sleep(0)  # the reader waits
        line._deliver(b"\x02", 1.0)  # as the event loop hands the line its bytes
        reader.cancel()
        with pytest.raises(asyncio.CancelledError):
            await reader
        chunk = await line.read(timeout=1)
        assert chunk is not None and chunk.data == b"\x02"
