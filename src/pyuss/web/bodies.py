"""What a request to the page's server carries, read within bounds: its body (at most
`MAX_BODY` bytes, a JSON body at most `MAX_JSON`, within the reader's time limit), a JSON
body parsed only to `MAX_DEPTH` levels without NaN or Infinity and with no key but those
asked for, the parameters (``52``, ``4.2``, at most `MAX_PNU`) and the addresses of a scan
(``0-31``, ``1,4,7``) it names. What is out of bounds is a `ConfigError` (one JSON error,
400), never a value that reaches a drive.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable
from typing import Any

from pyuss.errors import ConfigError, cut
from pyuss.userfile import parse_message
from pyuss.web import missing_extra

try:
    from aiohttp import web
except ImportError as exc:  # pragma: no cover - the extra is installed for the tests
    raise missing_extra(exc) from None

__all__ = [
    "MAX_BODY",
    "MAX_DEPTH",
    "MAX_JSON",
    "MAX_PNU",
    "Bodies",
    "param_ref",
    "parse_json",
    "scan_addresses",
]

MAX_BODY = 4 * 1024 * 1024
"""Largest request body (a backup file to compare or restore)."""
MAX_JSON = 64 * 1024
"""Largest JSON request body (a command, parameter ids, a value, a scan)."""
MAX_DEPTH = 8
"""Deepest nesting of arrays and objects in a JSON request body."""
MAX_PNU = 0xFFFF
"""The highest parameter number a request may name (a profile's paged numbers included)."""


class Bodies:
    """Request bodies read within ``timeout`` seconds each (the body timeout)."""

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout

    async def body(self, request: web.Request, read: Awaitable[bytes]) -> bytes:
        """The request's body as ``read`` reads it, within `timeout` seconds."""
        try:
            async with asyncio.timeout(self.timeout):
                return await read
        except TimeoutError:
            raise web.HTTPRequestTimeout(
                text=json.dumps(
                    {"error": f"the request body did not come within {self.timeout:g} s"}
                ),
                content_type="application/json",
                headers={"Connection": "close"},
            ) from None

    async def json(self, request: web.Request, keys: tuple[str, ...] = ()) -> dict[str, Any]:
        """The request's JSON object, read and parsed within bounds (`MAX_JSON` bytes, nesting
        `MAX_DEPTH`); with ``keys``, no other key may be in it."""
        if request.content_length is not None and request.content_length > MAX_JSON:
            raise ConfigError(f"the request body is larger than {MAX_JSON} bytes")
        body = await self.body(request, _read_up_to(request, MAX_JSON + 1))
        if len(body) > MAX_JSON:
            raise ConfigError(f"the request body is larger than {MAX_JSON} bytes")
        data = parse_json(bytes(body))
        if not isinstance(data, dict):
            raise ConfigError("the request body must be a JSON object")
        unknown = sorted(set(data) - set(keys)) if keys else []
        if unknown:
            raise ConfigError(f"unknown key {unknown[0][:40]!r}: the keys are {', '.join(keys)}")
        return data

    async def upload(self, request: web.Request) -> tuple[bytes, str]:
        """The backup file a page sends as the request body, and its name (``name=``)."""
        name = request.query.get("name", "").strip() or "the file"
        if len(name) > 200 or any(c in name for c in "\r\n\0"):
            raise ConfigError("the file name is too long or not a name")
        data = await self.body(request, request.read())
        if not data:
            raise ConfigError(f"{name} is empty: choose a backup file (TOML or JSON)")
        return data, name


def parse_json(body: bytes) -> Any:
    """A JSON request body, parsed only within `MAX_DEPTH` levels and without NaN or
    Infinity (`pyuss.userfile.parse_message`: the parser of the standard library recurses,
    deep nesting must never reach it)."""
    return parse_message(body, "the request body", max_depth=MAX_DEPTH)


def param_ref(text: object) -> tuple[int, int | None]:
    """``52`` or ``4.2`` (also ``P4.2``, or the number 52) as PNU and index."""
    if isinstance(text, int) and not isinstance(text, bool):
        if not 0 <= text <= MAX_PNU:
            raise ConfigError(f"{cut(text)} is not a parameter: a number is 0..{MAX_PNU}")
        text = str(text)
    if not isinstance(text, str) or len(text) > 16:
        raise ConfigError(f"{cut(text)} is not a parameter (52 or 4.2)")
    body = text.strip().lstrip("Pp").replace("[", ".").rstrip("]")
    pnu, dot, index = body.partition(".")
    if not pnu.isdigit() or (dot and not index.isdigit()):
        raise ConfigError(f"{cut(text)} is not a parameter (52 or 4.2)")
    if int(pnu) > MAX_PNU or (dot and int(index) > 255):
        raise ConfigError(f"{cut(text)}: a parameter number is 0..{MAX_PNU}, an index 0..255")
    return int(pnu), (int(index) if dot else None)


def scan_addresses(text: str) -> list[int]:
    """``0-31``, ``1,4,7`` or ``1-5,9`` as a list of addresses."""
    out: list[int] = []
    for part in text.replace(" ", "").split(","):
        if not part:
            continue
        low, dash, high = part.partition("-")
        try:
            first, last = int(low), int(high) if dash else int(low)
        except ValueError:
            raise ConfigError(f"addresses {text!r}: use 0-31, 1,4,7 or 1-5,9") from None
        if not 0 <= first <= last <= 31:
            raise ConfigError(f"addresses {text!r}: each must be 0..31, low to high")
        out.extend(range(first, last + 1))
    if not out:
        raise ConfigError("no address to scan")
    return sorted(set(out))


async def _read_up_to(request: web.Request, size: int) -> bytes:
    """The request's body, or its first ``size`` bytes when it is longer."""
    body = bytearray()
    while len(body) < size:
        part = await request.content.read(size - len(body))
        if not part:
            break
        body += part
    return bytes(body)
