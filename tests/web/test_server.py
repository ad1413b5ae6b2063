"""The server's rules, over real sockets on 127.0.0.1: the token off loopback, the host and
origin checks, read-only, and a bounded queue per WebSocket client."""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import logging
import os
import socket
from typing import Any

import aiohttp
import pytest

from pyuss.errors import ConfigError
from pyuss.web.backend import Backend
from pyuss.web.server import WebServer
from support.processes import simulator
from support.web import serve

WRITE = {"X-Pyuss": "1"}


def base(server: WebServer) -> str:
    return f"http://127.0.0.1:{server.port}"


async def test_listening_beyond_this_computer_needs_a_token(backend: Backend) -> None:
    with pytest.raises(ConfigError, match="token is required"):
        WebServer(backend, host="0.0.0.0", port=0)
    with pytest.raises(ConfigError, match="token is required"):
        WebServer(backend, host="192.0.2.1", port=0, token="")


async def test_off_loopback_every_request_needs_the_token(backend: Backend) -> None:
    server = await serve(backend, host="0.0.0.0", token="s3cret-token")
    try:
        assert server.url.endswith("?token=s3cret-token")
        # a browser keeps cookies of an IP address; aiohttp's client only when told
        async with aiohttp.ClientSession(cookie_jar=aiohttp.CookieJar(unsafe=True)) as http:
            for path in ("/", "/api/bus", "/static/app.js", "/api/monitor.pcapng"):
                async with http.get(base(server) + path) as reply:
                    assert reply.status == 401, path
            async with http.get(base(server) + "/api/bus?token=wrong") as reply:
                assert reply.status == 401
            with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
                await http.ws_connect(base(server) + "/ws")
            assert refused.value.status == 401
            async with http.get(
                base(server) + "/api/bus", headers={"X-Pyuss-Token": "s3cret-token"}
            ) as reply:
                assert reply.status == 200
            # the printed URL works, and the page's later requests carry the cookie it set
            async with http.get(base(server) + "/?token=s3cret-token") as reply:
                assert reply.status == 200
            async with http.get(base(server) + "/api/bus") as reply:
                assert reply.status == 200
            async with http.ws_connect(base(server) + "/ws") as ws:
                first = await ws.receive_json(timeout=10)
                assert first["type"] == "bus"
    finally:
        await server.close()


def _raw_get(port: int, headers: bytes) -> bytes:
    """The status line of a GET of /api/bus with ``headers`` as raw bytes."""
    with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:
        sock.sendall(b"GET /api/bus HTTP/1.1\r\nHost: 127.0.0.1\r\n" + headers + b"\r\n")
        answer = b""
        while b"\r\n" not in answer:
            answer += sock.recv(4096) or b"\r\n"
        return answer.split(b"\r\n")[0]


async def test_a_token_that_is_no_text_is_a_wrong_token(backend: Backend) -> None:
    server = await serve(backend, host="0.0.0.0", token="s3cret-token")
    try:
        for headers in (
            b"X-Pyuss-Token: \xff\xfe\r\n",
            b"Cookie: pyuss_token=\xff\r\n",
            b"Cookie: pyuss_token=s3cret-token\xff\r\n",
        ):
            status = await asyncio.to_thread(_raw_get, server.port, headers)
            assert status == b"HTTP/1.1 401 Unauthorized", headers
        status = await asyncio.to_thread(_raw_get, server.port, b"X-Pyuss-Token: s3cret-token\r\n")
        assert status == b"HTTP/1.1 200 OK"
    finally:
        await server.close()


async def test_a_malformed_request_is_one_line_in_the_log_not_a_traceback(
    backend: Backend, caplog: pytest.LogCaptureFixture
) -> None:
    # a client's bad HTTP (a header beyond 8 kB, no HTTP at all) is the client's fault: a
    # flood of it must not fill the engineer's terminal with tracebacks
    caplog.set_level(logging.DEBUG, logger="pyuss.web")
    server = await serve(backend)
    try:
        for raw in (b"X-Big: " + b"a" * 20_000 + b"\r\n", b"X-Bad\x01: 1\r\n"):
            status = await asyncio.to_thread(_raw_get, server.port, raw)
            assert status.split()[1] == b"400", status
        async with aiohttp.ClientSession() as http, http.get(base(server) + "/api/bus") as r:
            assert r.status == 200
    finally:
        await server.close()
    # (the web server's records: the simulated drives may have their say on a loaded machine)
    web_records = [r for r in caplog.records if r.name.startswith(("pyuss.web", "aiohttp"))]
    loud = [r for r in web_records if r.levelno >= logging.INFO or r.exc_info]
    assert not loud, [r.getMessage() for r in loud]
    assert any("bad request from 127.0.0.1: 400" in r.getMessage() for r in caplog.records)


async def test_a_web_site_cannot_reach_the_page_on_loopback(backend: Backend) -> None:
    server = await serve(backend)
    try:
        async with aiohttp.ClientSession() as http:
            # DNS rebinding: a foreign name that resolves to 127.0.0.1
            async with http.get(base(server) + "/api/bus", headers={"Host": "evil.example"}) as r:
                assert r.status == 403
            # a form of another site cannot add the header, a script of it sends its Origin
            command = base(server) + "/api/drive/1/command"
            async with http.post(command, json={"name": "on"}) as reply:
                assert reply.status == 403
            headers = {**WRITE, "Origin": "http://evil.example"}
            async with http.post(command, json={"name": "on"}, headers=headers) as reply:
                assert reply.status == 403
            with pytest.raises(aiohttp.WSServerHandshakeError):
                await http.ws_connect(base(server) + "/ws", origin="http://evil.example")
            # an image or script tag of another site sends no Origin, but the browser says
            # where the request comes from: no backup or fault read for it; a link to the
            # page itself opens it
            foreign = {"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "no-cors"}
            for path in ("/api/drive/1/backup", "/api/drive/1/faults", "/static/app.js"):
                async with http.get(base(server) + path, headers=foreign) as reply:
                    assert reply.status == 403, path
                    assert "another site" in (await reply.json())["error"]
            link = {"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "navigate"}
            async with http.get(base(server) + "/", headers=link) as reply:
                assert reply.status == 200
            async with http.get(base(server) + "/api/bus", headers=link) as reply:
                assert reply.status == 403
            for site in ("same-origin", "none"):
                async with http.get(
                    base(server) + "/api/bus", headers={"Sec-Fetch-Site": site}
                ) as reply:
                    assert reply.status == 200, site
            assert backend.points(1).drive.control == 0  # nothing reached the drive
            own = {**WRITE, "Origin": base(server)}
            async with http.post(command, json={"name": "off1"}, headers=own) as reply:
                assert reply.status == 200
    finally:
        await server.close()


async def test_read_only_refuses_every_change(backend: Backend) -> None:
    server = await serve(backend, read_only=True)
    try:
        async with aiohttp.ClientSession(headers=WRITE) as http:
            url = base(server)
            for path, body in (
                ("/api/drive/1/command", {"name": "on"}),
                ("/api/drive/1/params/write", {"id": "462", "value": "2"}),
                ("/api/scan", {"addresses": "0-3"}),
                ("/api/drive/1/restore?name=d1.toml", {}),
            ):
                async with http.post(url + path, json=body) as reply:
                    assert reply.status == 403, path
                    assert "read-only" in (await reply.json())["error"]
            async with http.post(url + "/api/drive/1/params/read", json={"ids": ["462"]}) as r:
                assert r.status == 200
                assert (await r.json())[0]["value"] == "10.0 s"
            async with http.get(url + "/api/config") as reply:
                assert (await reply.json())["read_only"] is True
        assert backend.points(1).drive.control == 0
    finally:
        await server.close()


async def test_a_page_of_an_earlier_start_changes_nothing(backend: Backend) -> None:
    # a browser tab left open while uss web was started again (perhaps on another line,
    # where drive 1 is another machine): its buttons act on what it shows, so they act not
    earlier = await serve(backend)
    async with (
        aiohttp.ClientSession(headers=WRITE) as http,
        http.get(base(earlier) + "/api/config") as reply,
    ):
        start = (await reply.json())["start"]
    await earlier.close()
    server = await serve(backend)
    try:
        async with aiohttp.ClientSession(headers=WRITE) as http:
            url = base(server)
            async with http.get(url + "/api/config") as reply:
                now = (await reply.json())["start"]
            assert now != start
            for path, body in (
                ("/api/drive/1/command", {"name": "on"}),
                ("/api/drive/1/command", {"name": "on", "check": True}),
                ("/api/drive/1/params/write", {"id": "462", "value": "2"}),
            ):
                headers = {"X-Pyuss-Start": start}
                async with http.post(url + path, json=body, headers=headers) as reply:
                    assert reply.status == 409, path
                    assert "reload the page" in (await reply.json())["error"]
            assert backend.points(1).drive.control == 0
            async with http.post(
                url + "/api/drive/1/command", json={"name": "off1"}, headers={"X-Pyuss-Start": now}
            ) as reply:
                assert reply.status == 200
    finally:
        await server.close()


async def test_bad_requests_get_one_clear_line(backend: Backend) -> None:
    server = await serve(backend)
    try:
        async with aiohttp.ClientSession(headers=WRITE) as http:
            url = base(server)
            cases = [
                ("/api/drive/1/command", {"name": "fly"}, 400, "unknown command"),
                ("/api/drive/12/command", {"name": "on"}, 400, "not on the page"),
                ("/api/drive/1/command", {"name": "setpoint", "value": "fast"}, 400, "number"),
                ("/api/drive/1/params/write", {"id": "x", "value": "1"}, 400, "parameter"),
                ("/api/drive/1/params/write", {"id": "2", "value": "1"}, 400, "read-only"),
                ("/api/drive/1/params/write", {"id": "352", "value": "40"}, 409, "error 12"),
                ("/api/scan", {"addresses": "40-50"}, 400, "0..31"),
            ]
            for path, body, status, words in cases:
                async with http.post(url + path, json=body) as reply:
                    assert reply.status == status, (path, body)
                    assert words in (await reply.json())["error"], (path, body)
            async with http.post(url + "/api/drive/1/command", data=b"\xff\x00") as reply:
                assert reply.status == 400
    finally:
        await server.close()


def _raw_websocket(port: int) -> socket.socket:
    """A WebSocket client that completes the handshake and then never reads."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            "Sec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    assert head.startswith(b"HTTP/1.1 101")
    return sock


async def test_a_client_that_does_not_read_is_dropped_and_holds_up_nobody(
    backend: Backend,
) -> None:
    server = await serve(backend, queue_size=4, send_timeout=1.0)
    hostile = await asyncio.to_thread(_raw_websocket, server.port)
    received = 0
    try:
        async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:

            async def read() -> None:
                nonlocal received
                async for message in ws:
                    if message.type == aiohttp.WSMsgType.TEXT and '"big"' in message.data[:20]:
                        received += 1

            reader = asyncio.create_task(read())
            while len(server.hub.clients) < 2:
                await asyncio.sleep(0.01)
            big = json.dumps({"type": "big", "data": "x" * 200_000})
            for _ in range(60):
                server.hub.send(big)
                await asyncio.sleep(0.02)
            async with asyncio.timeout(30):
                while server.hub.dropped == 0:
                    await asyncio.sleep(0.05)
                while received < 60:
                    await asyncio.sleep(0.05)
            reader.cancel()
        # the one that never read was cut off; its queue never held more than 4 messages
        assert server.hub.dropped == 1
        assert server.hub.longest <= 4
        assert received == 60  # the page that reads got everything
        hostile.settimeout(5)
        with pytest.raises(OSError):  # the server closed the connection: reads end or fail
            while hostile.recv(65536):
                pass
            raise ConnectionResetError
    finally:
        hostile.close()
        await server.close()


def _closed_by_server(sock: socket.socket) -> bytes:
    """What the server sent before it closed ``sock`` (waits for the close, at most 60 s)."""
    sock.settimeout(60)
    got = b""
    try:
        while part := sock.recv(65536):
            got += part
    except ConnectionResetError:
        pass
    return got


async def test_a_connection_that_sends_no_whole_request_is_closed(backend: Backend) -> None:
    # idle connections and heads or bodies sent a byte at a time (slowloris) hold a
    # connection each: they are closed, and a page is served meanwhile and afterwards
    server = await serve(backend, idle_timeout=1.0, body_timeout=1.0)
    head = f"POST /api/drive/1/command HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\n"
    idle = socket.create_connection(("127.0.0.1", server.port))
    slow = socket.create_connection(("127.0.0.1", server.port))
    body = socket.create_connection(("127.0.0.1", server.port))
    stop = asyncio.Event()

    async def drip() -> None:  # a byte of the head every 0.2 s, never its end
        with contextlib.suppress(OSError):
            for byte in (head + "X-Pyuss: 1\r\n" + "X" * 10_000).encode():
                if stop.is_set():
                    return
                slow.send(bytes([byte]))
                await asyncio.sleep(0.2)

    dripping = asyncio.create_task(drip())
    try:
        body.sendall((head + 'X-Pyuss: 1\r\nContent-Length: 100\r\n\r\n{"name": "o').encode())
        async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:
            async with http.get(base(server) + "/api/bus") as reply:
                assert reply.status == 200
            for sock in (idle, slow):
                assert await asyncio.to_thread(_closed_by_server, sock) == b""
            answer = await asyncio.to_thread(_closed_by_server, body)
            assert answer.startswith(b"HTTP/1.1 408"), answer[:200]
            assert b"the request body did not come within 1 s" in answer
            # a live connection is no idle one: it stays, and the page is served
            assert not ws.closed
            assert (await ws.receive_json(timeout=10))["type"] in ("tick", "bus")
            async with http.get(base(server) + "/api/bus") as reply:
                assert reply.status == 200
        assert backend.points(1).drive.control == 0  # nothing half-received acted
    finally:
        stop.set()
        await dripping
        for sock in (idle, slow, body):
            sock.close()
        await server.close()


async def test_a_client_sending_oversized_messages_is_closed(backend: Backend) -> None:
    server = await serve(backend)
    try:
        async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:
            await ws.send_str(json.dumps({"monitor": "x" * 100_000}))
            async with asyncio.timeout(10):
                while not ws.closed:
                    await ws.receive()
            assert ws.close_code == aiohttp.WSCloseCode.MESSAGE_TOO_BIG
        async with asyncio.timeout(10):
            while server.hub.clients:
                await asyncio.sleep(0.05)
    finally:
        await server.close()


async def test_a_flood_of_monitor_messages_does_not_hold_up_the_server(
    backend: Backend,
) -> None:
    # each "show me the monitor" used to decode the last 500 telegrams anew: 2000 of them
    # from one page held the event loop - the page, the others and the drives' cyclic
    # traffic - for seconds
    decoded = 0
    exchanges_since = backend.exchanges_since

    def counted(seq: int, limit: int) -> tuple[list[dict[str, Any]], int]:
        nonlocal decoded
        decoded += 1
        return exchanges_since(seq, limit)

    backend.exchanges_since = counted  # type: ignore[method-assign]
    server = await serve(backend)
    try:
        async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:
            recent: list[dict[str, Any]] = []
            listener = asyncio.create_task(collect(ws, "telegrams", recent))
            for _ in range(2000):
                await ws.send_str('{"monitor": true}')
            await ws.send_str('{"ping": 1}')  # the last one: once it is read, all were
            async with asyncio.timeout(30):
                while not recent or server.hub.clients[0].monitor is not True:
                    await asyncio.sleep(0.05)
            # the monitor was asked for once and is shown: its telegrams came once
            assert len([r for r in recent if "left_out" not in r]) == 1
            for n in range(2000):  # on, off, on, ...: each "on" is served from one decoding
                await ws.send_str(json.dumps({"monitor": n % 2 == 0}))
            async with http.get(base(server) + "/api/bus") as reply:
                assert reply.status == 200
            listener.cancel()
        assert decoded < 500, decoded
    finally:
        backend.exchanges_since = exchanges_since  # type: ignore[method-assign]
        await server.close()


async def test_a_page_left_open_does_not_hold_up_stopping_the_server(backend: Backend) -> None:
    # Ctrl+C on `uss web` while a browser shows the page: the page is told the server goes
    # away (1001) and the server stops, instead of waiting for the browser to leave.
    server = await serve(backend)
    async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:
        first = await ws.receive()
        assert json.loads(first.data)["type"] == "bus"
        async with asyncio.timeout(10):  # far less than a browser stays on a page
            await server.close()
            while not ws.closed:
                await ws.receive()
        assert ws.close_code == aiohttp.WSCloseCode.GOING_AWAY


async def test_a_request_still_running_when_the_server_stops_is_cut_off(backend: Backend) -> None:
    # A scan runs for a second or more: stopping the page gives it the grace and
    # then cuts it off instead of waiting for it (and for the browser that asked).
    server = await serve(backend, shutdown_grace=0.2)
    async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:
        progress: list[dict[str, Any]] = []
        listener = asyncio.create_task(collect(ws, "scan", progress))
        scan = asyncio.create_task(
            http.post(base(server) + "/api/scan", json={"addresses": "0-7"}, headers=WRITE)
        )
        async with asyncio.timeout(10):
            while not progress:
                await asyncio.sleep(0.02)
        await server.close()
        with pytest.raises(aiohttp.ClientError):
            reply = await scan
            await reply.read()
        assert not any("found" in p for p in progress)  # the scan never got to its end
        listener.cancel()


async def collect(ws: Any, kind: str, into: list[dict[str, Any]]) -> None:
    """Keep the live messages of type ``kind`` a page receives."""
    async for message in ws:
        data = json.loads(message.data)
        if data["type"] == kind:
            into.append(data)


async def test_a_scan_from_the_page_reports_progress_live(backend: Backend) -> None:
    server = await serve(backend)
    try:
        async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:
            progress: list[dict[str, Any]] = []
            listener = asyncio.create_task(collect(ws, "scan", progress))
            async with http.post(
                base(server) + "/api/scan", json={"addresses": "0-7"}, headers=WRITE
            ) as reply:
                assert reply.status == 200
                found = (await reply.json())["found"]
            async with asyncio.timeout(10):
                while not progress or "found" not in progress[-1]:
                    await asyncio.sleep(0.05)
            listener.cancel()
        assert [f["address"] for f in found] == [1, 4, 7]
        steps = [p["done"] for p in progress[:-1]]
        assert len(steps) > 8 and steps == sorted(steps)
        assert progress[-1]["found"] == found
    finally:
        await server.close()


async def test_backup_compare_and_restore_over_http(backend: Backend) -> None:
    server = await serve(backend)
    try:
        async with aiohttp.ClientSession() as http, http.ws_connect(base(server) + "/ws") as ws:
            progress: list[dict[str, Any]] = []
            listener = asyncio.create_task(collect(ws, "progress", progress))
            url = base(server) + "/api/drive/1"
            async with http.get(url + "/backup?format=json") as reply:
                assert reply.status == 200
                disposition = reply.headers["Content-Disposition"]
                assert disposition.startswith('attachment; filename="drive1-generic-')
                assert disposition.endswith('.json"')
                body = await reply.read()
            assert json.loads(body)["pyuss_backup"] == 1
            async with asyncio.timeout(10):
                while not progress or progress[-1]["done"] < progress[-1]["total"]:
                    await asyncio.sleep(0.05)
            assert {p["job"] for p in progress} == {"backup"}
            assert progress[-1]["total"] == 30 and len(progress) > 30
            listener.cancel()
            async with http.post(url + "/compare?name=d1.json", data=body, headers=WRITE) as r:
                assert r.status == 200
                assert (await r.json())["differences"] == []
            # a restore is a change: the page's header is needed, as for every change
            async with http.post(url + "/restore?name=d1.json", data=body) as reply:
                assert reply.status == 403
            await backend.write(1, 464, None, "3")
            async with http.post(url + "/restore?name=d1.json", data=body, headers=WRITE) as r:
                assert r.status == 200
                done = await r.json()
            assert done["message"] == "drive 1: 1 of 1 written"
            assert done["results"][0]["change"] == "P464 (Ramp-down time): 3.0 s -> 10.0 s"
            for path, data, words in [
                ("/backup?format=xml", None, "backup format 'xml'"),
                ("/compare?name=e.toml", b"", "e.toml is empty"),
                ("/compare?name=n.toml", b"[x]\n", "n.toml: not a pyuss backup"),
                ("/restore?name=b.toml", b"\x00\xff", "b.toml: not a text file"),
            ]:
                if data is None:
                    request = http.get(url + path)
                else:
                    request = http.post(url + path, data=data, headers=WRITE)
                async with request as reply:
                    assert reply.status == 400, path
                    assert words in (await reply.json())["error"], path
    finally:
        await server.close()


async def test_a_scan_probes_by_the_lines_profile_unless_asked_for_another(
    backend: Backend,
) -> None:
    # `uss web` gives the server the line's profile (--profile, uss.toml); without one the
    # page's scan probes by the USS specification's drive profile
    server = await serve(backend)
    try:
        async with (
            aiohttp.ClientSession(headers=WRITE) as http,
            http.get(base(server) + "/api/config") as reply,
        ):
            assert (await reply.json())["scan_profile"] == "generic"
    finally:
        await server.close()
    with simulator("--profile", "sinamics-v20", "--address", "3", "--baud", "9600") as url:
        line = Backend(port=url, baud=9600, drives=[])
        await line.start()
        server = await serve(line, scan_profile="sinamics-v20@2014")
        try:
            async with aiohttp.ClientSession(headers=WRITE) as http:
                async with http.get(base(server) + "/api/config") as reply:
                    config = await reply.json()
                assert config["scan_profile"] == "sinamics-v20@2014"
                assert "sinamics-v20@2014" in config["profiles"]  # an edition is offered too
                body = {"addresses": "2-3"}  # no profile named: the line's
                async with http.post(base(server) + "/api/scan", json=body) as reply:
                    assert reply.status == 200, await reply.text()
                    assert [f["address"] for f in (await reply.json())["found"]] == [3]
            drives = line.bus()["drives"]
            assert [(d["address"], d["profile"]) for d in drives] == [(3, "sinamics-v20@2014")]
        finally:
            await server.close()
            await line.close()
