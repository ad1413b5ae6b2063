"""The page's HTTP and WebSocket server (aiohttp).

Routes (all under the token when there is one):

- ``GET /``: the page; ``/static/...``: its scripts, styles and the plotting library.
- ``GET /api/config``, ``/api/bus``, ``/api/drive/N``, ``/api/drive/N/params``: what the page
  shows; ``POST /api/drive/N/params/read``: parameter values; ``GET /api/drive/N/faults``:
  the active fault and warning, the fault history and warning numbers with their texts;
  ``GET /api/drive/N/actuals``: the family's key actual values, read now;
  ``GET /api/drive/N/sources``: whether the drive follows the control word and setpoint of
  USS (P0700, P1000; `pyuss.commission.sources`).
- ``GET /api/drive/N/backup?format=toml|json|csv``: a backup file of the drive's parameters
  (`pyuss.commission`, the files of ``uss backup``); ``POST /api/drive/N/compare?name=FILE``
  with a backup file as the body: the differences, what a restore would write.
- ``POST /api/drive/N/command``, ``/api/drive/N/params/write``, ``/api/scan``,
  ``/api/drive/N/restore?name=FILE[&force=1][&eeprom=1]``: changes (refused with
  ``--read-only``). A command with ``"check": true`` is checked whole and not sent: the
  answer has the question for a person and a ``confirm``, which the yes carries; it acts
  once, within `CONFIRM_AGE` seconds, for exactly the command checked (`Confirmations`).
- ``GET /api/monitor.pcapng``: the telegrams of the monitor view as a capture.
- ``GET /ws``: live updates (`pyuss.web.hub`): ``tick`` messages with every drive's new
  process-data samples 20 times a second, ``bus`` messages with state and communication
  health twice a second, ``telegrams`` for clients showing the monitor, ``scan`` progress,
  ``progress`` of a backup, compare or restore.

Security (docs/web.md): who may use the server, and how a refusal or failure answers, is
`pyuss.web.guard`'s; what a request carries is read within bounds by `pyuss.web.bodies`; a
yes to a move is good once (`pyuss.web.confirm`). ``read_only`` refuses every change and the
page hides its controls.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import secrets
import time
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pyuss import __version__
from pyuss._tasks import cancel_and_wait
from pyuss.web import missing_extra

try:
    from aiohttp import WSCloseCode, WSMsgType, web
    from aiohttp.http_exceptions import HttpProcessingError
except ImportError as exc:  # pragma: no cover - the extra is installed for the tests
    raise missing_extra(exc) from None

from pyuss.errors import ConfigError, cut
from pyuss.points import state_name
from pyuss.profiles import UNKNOWN_KIND, profile_names
from pyuss.web.backend import Backend
from pyuss.web.bodies import MAX_BODY, Bodies, param_ref, parse_json, scan_addresses
from pyuss.web.confirm import CONFIRM_AGE, Confirmations
from pyuss.web.guard import Guard, error, is_loopback
from pyuss.web.hub import QUEUE_SIZE, SEND_TIMEOUT, Hub

if TYPE_CHECKING:
    from pyuss.web.plant import PlantBackend

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "WebServer"]

log = logging.getLogger("pyuss.web")

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8420
TICK = 0.05
"""Seconds between two live updates (20 a second)."""
BUS_EVERY = 10
"""Ticks between two bus messages (state and health, twice a second)."""
MAX_TELEGRAMS = 200
"""Telegrams sent in one tick at most; the rest are counted as left out."""
RECENT_TELEGRAMS = 500
"""Telegrams a page gets when it opens the monitor view."""
MAX_CLIENTS = 32
"""WebSocket clients at once; more are refused with 503."""
SHUTDOWN_GRACE = 2.0
"""Seconds a request still running when the page stops (Ctrl+C) has to finish; then it is
cut off (a scan, a parameter read over the broker waiting for its gateway)."""
IDLE_TIMEOUT = 10.0
"""Seconds a connection may go without a whole request head (the first one, or the next
one on a kept-alive connection) before it is closed: idle connections and heads sent a byte
at a time (slowloris) do not pile up."""
BODY_TIMEOUT = 60.0
"""Seconds a request body (a command, a backup file) may take to come in whole."""
DRIVE = r"/api/drive/{address:[A-Za-z0-9_.-]+}"
"""A drive's URLs: ``/api/drive/5`` on the page's line, ``/api/drive/line2.5`` in a plant."""
STATIC = Path(str(resources.files("pyuss.web").joinpath("static")))


class _ClientFaults(logging.Filter):
    """aiohttp logs a request it cannot parse (a header beyond 8 kB, no HTTP at all) with a
    traceback at ERROR: that is the client's fault, answered with 400, so it is one line at
    DEBUG instead. The server's own failures keep their traceback."""

    def filter(self, record: logging.LogRecord) -> bool:
        fault = record.exc_info[1] if record.exc_info else None
        if isinstance(fault, HttpProcessingError) and fault.code < 500:
            peer = record.args[0] if isinstance(record.args, tuple) and record.args else "?"
            log.debug("bad request from %s: %s %s", peer, fault.code, fault.message[:100])
            return False
        return True


SERVER_LOG = logging.getLogger("pyuss.web.http")
SERVER_LOG.addFilter(_ClientFaults())


class WebServer:
    """The page for ``backend`` on ``host``:``port`` (0: a free port)."""

    def __init__(
        self,
        backend: Backend | PlantBackend,
        *,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        token: str | None = None,
        read_only: bool = False,
        queue_size: int = QUEUE_SIZE,
        send_timeout: float = SEND_TIMEOUT,
        confirm_age: float = CONFIRM_AGE,
        shutdown_grace: float = SHUTDOWN_GRACE,
        idle_timeout: float = IDLE_TIMEOUT,
        body_timeout: float = BODY_TIMEOUT,
        scan_profile: str = "generic",
    ) -> None:
        if not is_loopback(host) and not token:
            raise ConfigError(
                f"listening on {host} makes the page reachable from the network: "
                "a token is required (uss web prints one)"
            )
        if not 0 <= port <= 65535:
            raise ConfigError(f"port {port} is not 0..65535")
        self.backend = backend
        self.host = host
        self.port = port
        self.token = token or None
        self.read_only = read_only
        self.scan_profile = scan_profile
        """The profile a scan of the page probes by unless it names another: the line's
        (``uss web --profile``, the configuration file), "generic" where none is named."""
        self.scan_profiles = [UNKNOWN_KIND, *profile_names()]
        """The profiles a scan may be asked for (the page's list)."""
        if scan_profile not in self.scan_profiles:  # NAME@EDITION
            self.scan_profiles.append(scan_profile)
        self.shutdown_grace = shutdown_grace
        self.idle_timeout = idle_timeout
        self.body_timeout = body_timeout
        self.hub = Hub(queue_size=queue_size, send_timeout=send_timeout)
        self._runner: web.AppRunner | None = None
        self._ticker: asyncio.Task[None] | None = None
        self._sweeper: asyncio.Task[None] | None = None
        self._sockets: set[web.WebSocketResponse] = set()
        """The pages connected live: told the server goes away when it closes."""
        self._sent_exchange = 0
        self._recent: tuple[int, str] | None = None
        """The last telegrams for a page opening the monitor, and the newest among them."""
        self._confirms = Confirmations(confirm_age)
        self.start_id = secrets.token_urlsafe(9)
        """This start of the server: a page sends it with every change (``X-Pyuss-Start``),
        so that a page loaded from an earlier start - which may show other drives - changes
        nothing."""
        self._guard = Guard(host, self.token, self.start_id, idle_timeout)
        self._bodies = Bodies(body_timeout)

    # -- life cycle ---------------------------------------------------------------------------
    @property
    def url(self) -> str:
        """The page's address (with the token when there is one)."""
        host = self.host
        if ":" in host:
            host = f"[{host}]"
        elif host in ("0.0.0.0", ""):
            host = "127.0.0.1"
        url = f"http://{host}:{self.port}/"
        return url + (f"?token={self.token}" if self.token else "")

    def app(self) -> web.Application:
        app = web.Application(middlewares=[self._guard.middleware], client_max_size=MAX_BODY)
        app.router.add_get("/", self._index)
        app.router.add_static("/static/", STATIC, show_index=False)
        app.router.add_get("/api/config", self._config)
        app.router.add_get("/api/bus", self._bus)
        app.router.add_get(DRIVE, self._drive)
        app.router.add_post(DRIVE + r"/command", self._command)
        app.router.add_get(DRIVE + r"/params", self._params)
        app.router.add_get(DRIVE + r"/faults", self._faults)
        app.router.add_get(DRIVE + r"/actuals", self._actuals)
        app.router.add_get(DRIVE + r"/sources", self._sources)
        app.router.add_post(DRIVE + r"/params/read", self._params_read)
        app.router.add_post(DRIVE + r"/params/write", self._params_write)
        app.router.add_get(DRIVE + r"/backup", self._backup)
        app.router.add_post(DRIVE + r"/compare", self._compare)
        app.router.add_post(DRIVE + r"/restore", self._restore)
        app.router.add_post("/api/scan", self._scan)
        app.router.add_get("/api/monitor.pcapng", self._pcapng)
        app.router.add_get("/ws", self._ws)
        return app

    async def start(self) -> str:
        """Listen and start the live updates; returns the URL (the real port for port 0)."""
        runner = web.AppRunner(
            self.app(),
            access_log=None,
            handle_signals=False,
            shutdown_timeout=self.shutdown_grace,
            keepalive_timeout=self.idle_timeout,
            logger=SERVER_LOG,
        )
        await runner.setup()
        site = web.TCPSite(runner, self.host, self.port, reuse_address=True)
        try:
            await site.start()
        except OSError as exc:
            await runner.cleanup()
            raise ConfigError(
                f"cannot listen on {self.host}:{self.port}: {exc.strerror or exc}"
            ) from None
        self._runner = runner
        if self.port == 0 and runner.addresses:
            self.port = int(runner.addresses[0][1])
        self._ticker = asyncio.create_task(self._tick())
        self._sweeper = asyncio.create_task(self._guard.sweep(runner.server))
        return self.url

    async def close(self) -> None:
        for task in (self._ticker, self._sweeper):
            if task is not None:
                await cancel_and_wait(task)
        await self.hub.close()
        # a page left open keeps its live connection: say goodbye (1001, going away) so
        # that stopping the server does not wait for the browser to leave
        for ws in list(self._sockets):
            with contextlib.suppress(Exception):
                await ws.close(code=WSCloseCode.GOING_AWAY, message=b"the page's server stops")
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None

    def _writable(self) -> None:
        if self.read_only:
            raise web.HTTPForbidden(
                text=json.dumps({"error": "the page is read-only (uss web --read-only)"}),
                content_type="application/json",
            )

    def _address(self, request: web.Request) -> Any:
        """The drive a URL names: an address (``5``) on the page's own line, ``BUS.ADDRESS``
        (``line2.5``) in the plant over the broker (`pyuss.web.plant`)."""
        text = request.match_info["address"]
        if text.isdigit() and len(text) <= 3 and isinstance(self.backend, Backend):
            return int(text)  # no drive has a longer address; a huge number is never parsed
        if not isinstance(self.backend, Backend) and len(text) <= 70:
            return text
        raise ConfigError(f"drive {cut(text)} is not on the page")

    # -- pages and data -----------------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.StreamResponse:
        return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-store"})

    async def _config(self, request: web.Request) -> web.Response:
        return web.json_response(
            {
                "version": __version__,
                "start": self.start_id,
                "read_only": self.read_only,
                "plant": not isinstance(self.backend, Backend),
                "moves": sorted(Backend.MOVES),
                "commands": list(Backend.COMMANDS),
                "tick": TICK,
                "profiles": self.scan_profiles,
                "scan_profile": self.scan_profile,
            }
        )

    async def _bus(self, request: web.Request) -> web.Response:
        return web.json_response(self.backend.bus())

    async def _drive(self, request: web.Request) -> web.Response:
        return web.json_response(self.backend.drive_info(self._address(request)))

    async def _command(self, request: web.Request) -> web.Response:
        self._writable()
        data = await self._bodies.json(request, keys=("name", "value", "check", "confirm"))
        address = self._address(request)
        name, value = data.get("name"), data.get("value")
        if not isinstance(name, str):
            raise ConfigError('"name" must be a command name: ' + ", ".join(Backend.COMMANDS))
        if "value" in data and name != "setpoint":
            # "on" with a speed beside it would start the drive at the setpoint in force,
            # not at the one the request names: only partly valid, so refused whole
            raise ConfigError(
                f"{cut(name)[1:-1]} takes no value: only setpoint does "
                '(send the setpoint first, {"name": "setpoint", "value": ...})'
            )
        check = data.get("check", False)
        if not isinstance(check, bool):
            raise ConfigError('"check" must be true or false')
        checked = self.backend.check(address, name, value)  # refused here: nothing is sent
        if check:
            return web.json_response({**checked, "confirm": self._confirms.issue(address, checked)})
        if "confirm" in data:
            self._confirms.redeem(data["confirm"], address, checked)
        return web.json_response(await self.backend.command(address, name, value))

    async def _actuals(self, request: web.Request) -> web.Response:
        return web.json_response(await self.backend.key_actuals(self._address(request)))

    async def _sources(self, request: web.Request) -> web.Response:
        return web.json_response(await self.backend.sources(self._address(request)))

    async def _faults(self, request: web.Request) -> web.Response:
        return web.json_response(await self.backend.faults(self._address(request)))

    async def _params(self, request: web.Request) -> web.Response:
        return web.json_response(self.backend.parameters(self._address(request)))

    async def _params_read(self, request: web.Request) -> web.Response:
        data = await self._bodies.json(request, keys=("ids",))
        ids = data.get("ids")
        if not isinstance(ids, list) or len(ids) > 256:
            raise ConfigError("ids must be a list of at most 256 parameters")
        refs = [param_ref(i) for i in ids]
        return web.json_response(await self.backend.read(self._address(request), refs))

    async def _params_write(self, request: web.Request) -> web.Response:
        self._writable()
        data = await self._bodies.json(request, keys=("id", "value", "eeprom"))
        pnu, index = param_ref(data.get("id", ""))
        value = data.get("value", "")
        if isinstance(value, bool) or not isinstance(value, str | int | float):
            raise ConfigError(f"value must be the value as text (or a number), not {cut(value)}")
        eeprom = data.get("eeprom", False)
        if not isinstance(eeprom, bool):
            raise ConfigError(f"eeprom must be true or false, not {cut(eeprom)}")
        result = await self.backend.write(
            self._address(request), pnu, index, str(value), eeprom=eeprom
        )
        return web.json_response(result)

    def _progress(self, address: int, job: str) -> Callable[[int, int, str], None]:
        """Progress of a backup, compare or restore, sent live to every page."""

        def progress(done: int, total: int, label: str) -> None:
            message = {"type": "progress", "address": address, "job": job}
            self.hub.send(json.dumps({**message, "done": done, "total": total, "label": label}))

        return progress

    async def _backup(self, request: web.Request) -> web.Response:
        address = self._address(request)
        fmt = request.query.get("format", "toml")
        name, text = await self.backend.backup(
            address, fmt, progress=self._progress(address, "backup")
        )
        types = {"toml": "application/toml", "json": "application/json", "csv": "text/csv"}
        return web.Response(
            text=text,
            content_type=types[fmt],
            headers={"Content-Disposition": f'attachment; filename="{name}"'},
        )

    async def _compare(self, request: web.Request) -> web.Response:
        address = self._address(request)
        data, name = await self._bodies.upload(request)
        reply = await self.backend.compare(
            address, data, name, progress=self._progress(address, "compare")
        )
        # the page asks with these writes; its yes carries this (`_restore`)
        reply["confirm"] = self._confirms.issue(address, {"restore": reply["writes"]})
        return web.json_response(reply)

    async def _restore(self, request: web.Request) -> web.Response:
        self._writable()
        address = self._address(request)
        data, name = await self._bodies.upload(request)
        approve = None
        if "confirm" in request.query:
            # the yes of a person to a comparison's writes: the same writes, or none

            def approve(writes: list[dict[str, Any]]) -> None:
                self._confirms.redeem(request.query["confirm"], address, {"restore": writes})

        reply = await self.backend.restore(
            address,
            data,
            name,
            force=request.query.get("force") == "1",
            eeprom=request.query.get("eeprom") == "1",
            progress=self._progress(address, "restore"),
            approve=approve,
        )
        return web.json_response(reply)

    async def _scan(self, request: web.Request) -> web.Response:
        self._writable()
        data = await self._bodies.json(request, keys=("addresses", "profile"))
        addresses = data.get("addresses", "0-31")
        profile = data.get("profile", self.scan_profile)
        if not isinstance(addresses, str) or len(addresses) > 200:
            raise ConfigError("addresses must be a short text: 0-31, 1,4,7 or 1-5,9")
        if profile not in self.scan_profiles:
            known = ", ".join(self.scan_profiles[1:])
            raise ConfigError(f"profile {cut(profile)} is not one of {known}")
        addresses = scan_addresses(addresses)

        def progress(done: int, total: int) -> None:
            self.hub.send(json.dumps({"type": "scan", "done": done, "total": total}))

        self._confirms.forget()  # each yes given was for a drive of before the scan
        try:
            found = await self.backend.scan(
                addresses, profile=None if profile == UNKNOWN_KIND else profile, progress=progress
            )
        finally:
            self._confirms.forget()
        self.hub.send(json.dumps({"type": "scan", "done": 1, "total": 1, "found": found}))
        return web.json_response({"found": found})

    async def _pcapng(self, request: web.Request) -> web.Response:
        data = await asyncio.to_thread(self.backend.pcapng)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        return web.Response(
            body=data,
            content_type="application/octet-stream",
            headers={"Content-Disposition": f'attachment; filename="uss-{stamp}.pcapng"'},
        )

    # -- live updates -------------------------------------------------------------------------
    async def _ws(self, request: web.Request) -> web.StreamResponse:
        if len(self.hub.clients) >= MAX_CLIENTS:
            return error(503, f"{MAX_CLIENTS} pages are connected already")
        ws = web.WebSocketResponse(heartbeat=20.0, max_msg_size=4096)
        await ws.prepare(request)
        self._sockets.add(ws)
        transport = request.transport

        def abort() -> None:
            if transport is not None:
                transport.abort()

        peer = request.remote or "?"
        client = self.hub.add(ws.send_str, abort, name=peer)
        self.hub.send_to(client, json.dumps({"type": "bus", "bus": self.backend.bus()}))
        try:
            async for message in ws:
                if client.closed:
                    break  # cut off (fallen behind): what it sent meanwhile is not read
                if message.type != WSMsgType.TEXT:
                    continue
                try:
                    data = parse_json(message.data.encode())
                except ConfigError:
                    continue
                if isinstance(data, dict) and "monitor" in data:
                    shown, client.monitor = client.monitor, bool(data["monitor"])
                    if client.monitor and not shown:
                        self.hub.send_to(client, self._recent_telegrams())
        finally:
            self._sockets.discard(ws)
            await self.hub.remove(client)
        return ws

    def _recent_telegrams(self) -> str:
        """The message with the last `RECENT_TELEGRAMS` telegrams for a page that opens the
        monitor view; decoded once for every page that opens it before the next telegram."""
        newest = self.backend.last_exchange
        if self._recent is None or self._recent[0] != newest:
            items, _ = self.backend.exchanges_since(newest - RECENT_TELEGRAMS, RECENT_TELEGRAMS)
            self._recent = (newest, json.dumps({"type": "telegrams", "items": items}))
        return self._recent[1]

    async def _tick(self) -> None:
        count = 0
        while True:
            await asyncio.sleep(TICK)
            count += 1
            try:
                self._send_tick(count)
            except Exception:  # one bad tick must not end the live updates
                log.exception("live update failed")

    def _send_tick(self, count: int) -> None:
        backend: Any = self.backend  # drives by address (a line) or BUS.ADDRESS (the plant)
        if backend.scan_progress is not None:
            return  # the drives of before are gone, the new ones not there yet
        samples = backend.take_samples()
        drives = {}
        for address, taken in samples.items():
            last = taken[-1]
            drives[str(address)] = {
                "samples": [[round(s.time, 4), s.status, list(s.values)] for s in taken],
                "status": last.status,
                "state": state_name(last.status),
                "setpoint": backend.setpoint_value(address),
                "motion": backend.motion(address),
            }
        if self.hub.clients:
            self.hub.send(json.dumps({"type": "tick", "drives": drives}))
            if count % BUS_EVERY == 0:
                self.hub.send(json.dumps({"type": "bus", "bus": backend.bus()}))
        newest = backend.last_exchange
        if newest > self._sent_exchange:
            if any(c.monitor for c in self.hub.clients):
                # decoded into lines only while a page shows the monitor
                items, left_out = backend.exchanges_since(self._sent_exchange, MAX_TELEGRAMS)
                message = {"type": "telegrams", "items": items, "left_out": left_out}
                self.hub.send(json.dumps(message), monitor_only=True)
            self._sent_exchange = newest
