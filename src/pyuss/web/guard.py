"""Who may use the page's server, and how a refusal or failure answers (docs/web.md).

The page's server is bound to 127.0.0.1 unless told otherwise. Bound elsewhere, a token is
required (`WebServer` refuses to start without one) and every request must carry it: in the
``token`` query parameter of the first request (the page then keeps it in a cookie), the
``X-Pyuss-Token`` header or that cookie. On a loopback address the ``Host`` header must name
a loopback host (a web site cannot reach the page through a DNS name of its own). Requests
that change something must carry the ``X-Pyuss`` header (a web site's form cannot add it)
and, from the page, ``X-Pyuss-Start``: the start of the server the page was loaded from
(`WebServer.start_id`; a page of an earlier start changes nothing), and
no ``Origin`` of another site; a WebSocket from another origin is refused. What a browser
says comes from another site (``Sec-Fetch-Site``: an image or script tag, which sends no
``Origin``) is refused too, but a link to the page itself. ``read_only``
refuses every change and the page hides its controls. Every body is read within bounds
(`pyuss.web.bodies`), every key and type checked; a bad request gets one JSON error with a
4xx status and never reaches a drive.

The middleware (`Guard.middleware`) checks every request before its handler and turns what
a handler raises into one JSON error: bad input 400, a drive's refusal 409 (with its number
and meaning), no write authority 409, a timeout 504, another failure on the line 502.
Connections that send no whole request head within the idle time are closed (`Guard.sweep`).
"""

from __future__ import annotations

import asyncio
import hmac
import ipaddress
import logging
import time
from collections.abc import Awaitable, Callable
from typing import Any
from urllib.parse import urlsplit

from pyuss.web import missing_extra

try:
    from aiohttp import web
except ImportError as exc:  # pragma: no cover - the extra is installed for the tests
    raise missing_extra(exc) from None

from pyuss.errors import ConfigError, DriveRefusal, UssError, UssTimeout, cut
from pyuss.points import NoWriteAuthority
from pyuss.web.bodies import MAX_BODY

__all__ = ["COOKIE", "Guard", "error", "is_loopback"]

log = logging.getLogger("pyuss.web")

COOKIE = "pyuss_token"
"""The cookie the page keeps its token in."""

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``) is on this machine only."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _netloc(url: str, part: str) -> str:
    """The ``netloc`` or ``hostname`` of ``url``; empty for what is no URL (``http://[``,
    a ``Host`` header of a broken IPv6 address), which is then no host of this machine."""
    try:
        split = urlsplit(url)
    except ValueError:
        return ""
    return str(getattr(split, part) or "")


def error(status: int, message: str, **extra: Any) -> web.Response:
    return web.json_response({"error": message, **extra}, status=status)


class Guard:
    """The rules of the module text for a server on ``host`` with ``token`` (None: none, on a
    loopback address only) at its start ``start_id``; connections idle ``idle_timeout``
    seconds without a whole request head are closed."""

    def __init__(self, host: str, token: str | None, start_id: str, idle_timeout: float) -> None:
        self.host = host
        self.token = token
        self.start_id = start_id
        self.idle_timeout = idle_timeout
        self._opened: dict[web.RequestHandler, float] = {}
        """Connections by their handler, with when they were first seen."""
        self.begun: set[object] = set()
        """The transports of connections that sent at least one whole request head."""

    def token_ok(self, request: web.Request) -> bool:
        if self.token is None:
            return True
        given = (
            request.query.get("token")
            or request.headers.get("X-Pyuss-Token")
            or request.cookies.get(COOKIE)
            or ""
        )
        # a header or cookie of bytes that are no UTF-8 comes as lone surrogates: kept as
        # the bytes they were, and so a wrong token, never an error
        return hmac.compare_digest(given.encode("utf-8", "surrogateescape"), self.token.encode())

    @web.middleware
    async def middleware(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        self.begun.add(request.transport)
        if is_loopback(self.host) and not is_loopback(_netloc(f"//{request.host}", "hostname")):
            return error(403, f"host {cut(request.host)} is not this machine")
        if not self.token_ok(request):
            return error(401, "the page needs its token: open the URL uss web printed")
        origin = request.headers.get("Origin")
        if origin is not None and _netloc(origin, "netloc") != request.host:
            return error(403, f"requests from {cut(origin)} are not accepted")
        fetched_from = request.headers.get("Sec-Fetch-Site", "same-origin")
        if fetched_from not in ("same-origin", "none") and not (
            request.path == "/" and request.headers.get("Sec-Fetch-Mode") == "navigate"
        ):
            # an image, script or frame of another site (which sends no Origin): a link to
            # the page opens it, nothing else of it is for another site
            return error(403, f"requests from another site ({cut(fetched_from)}) are not accepted")
        changing = request.method not in ("GET", "HEAD", "OPTIONS")
        if changing and request.headers.get("X-Pyuss") != "1":
            return error(403, "a change needs the X-Pyuss header (sent by the page)")
        if changing and request.headers.get("X-Pyuss-Start", self.start_id) != self.start_id:
            return error(
                409,
                "the page was loaded from an earlier start of uss web and may show other "
                "drives than there are now: nothing sent, reload the page",
            )
        try:
            response = await handler(request)
        except web.HTTPException as exc:
            if exc.status < 400 or exc.content_type == "application/json":
                raise
            # aiohttp's own refusals (too large a body, no such route) as JSON too
            if exc.status == 413:
                return error(413, f"the request body is larger than {MAX_BODY} bytes")
            return error(exc.status, exc.reason)
        except ConfigError as exc:
            return error(400, str(exc))
        except DriveRefusal as exc:
            return error(409, str(exc), number=exc.number, meaning=exc.meaning)
        except NoWriteAuthority as exc:
            return error(409, str(exc), response_id=8)
        except UssTimeout as exc:
            return error(504, str(exc))
        except UssError as exc:
            return error(502, str(exc))
        if self.token is not None and request.query.get("token"):
            response.set_cookie(COOKIE, self.token, httponly=True, samesite="Strict")
        return response

    async def sweep(self, server: web.Server | None) -> None:
        """Close every connection that has not sent a whole request head within
        `idle_timeout` seconds of opening (between two requests aiohttp's keep-alive
        timeout, the same, does it)."""
        while server is not None:
            await asyncio.sleep(min(1.0, self.idle_timeout / 2))
            now = time.monotonic()
            handlers = server.connections
            transports = {h.transport for h in handlers}
            self.begun &= transports
            self._opened = {h: self._opened.get(h, now) for h in handlers}
            for handler, since in self._opened.items():
                transport = handler.transport
                if (
                    transport is not None
                    and transport not in self.begun
                    and now - since > self.idle_timeout
                ):
                    log.info(
                        "web connection closed: no whole request within %g s", self.idle_timeout
                    )
                    transport.close()
