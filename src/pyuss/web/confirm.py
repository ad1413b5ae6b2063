"""The one-time confirmation of a command a person said yes to.

A command that can set a motor turning is first checked whole and not sent (``"check":
true``); the page asks a person with the check's words, and the yes carries the check's
``confirm``. It acts once, within `CONFIRM_AGE` seconds, for exactly the command checked (the
same drive, name and words); a replayed, stale or changed request is refused (409) before
anything is sent. A restore's yes is the same, for the very writes a comparison listed.
"""

from __future__ import annotations

import json
import secrets
import time
from typing import Any

from pyuss.web import missing_extra

try:
    from aiohttp import web
except ImportError as exc:  # pragma: no cover - the extra is installed for the tests
    raise missing_extra(exc) from None

__all__ = ["CONFIRM_AGE", "MAX_CONFIRMS", "Confirmations"]

CONFIRM_AGE = 60.0
"""Seconds a checked command may wait for the person's yes before it is stale."""
MAX_CONFIRMS = 64
"""Checked commands waiting for a yes at most (the oldest are forgotten)."""


class Confirmations:
    """Commands a page checked and asks a person about: each yes carries the ``confirm``
    of its check, which is good once, for `CONFIRM_AGE` seconds, and for exactly the command
    checked (the same drive, name and words): a replayed, stale or changed request is refused
    before anything is sent. A scan forgets them all (`forget`): the drives they were given
    for are gone, another may stand at the same address."""

    def __init__(self, age: float = CONFIRM_AGE) -> None:
        self.age = age
        self._open: dict[str, tuple[float, str]] = {}

    @staticmethod
    def _what(drive: object, checked: dict[str, Any]) -> str:
        return json.dumps({"drive": str(drive), "checked": checked}, sort_keys=True)

    def issue(self, drive: object, checked: dict[str, Any]) -> str:
        token = secrets.token_urlsafe(18)
        self._open[token] = (time.monotonic(), self._what(drive, checked))
        while len(self._open) > MAX_CONFIRMS:
            del self._open[next(iter(self._open))]
        return token

    def forget(self) -> None:
        self._open.clear()

    def redeem(self, token: object, drive: object, checked: dict[str, Any]) -> None:
        entry = self._open.pop(token, None) if isinstance(token, str) else None
        if entry is None:
            raise _conflict("this command was confirmed before or never checked: check it again")
        when, what = entry
        if time.monotonic() - when > self.age:
            raise _conflict(f"the confirmation is older than {self.age:g} s: check it again")
        if what != self._what(drive, checked):
            raise _conflict(
                "the command is not the one confirmed (another drive, command or value, "
                "or it means another setpoint now)"
            )


def _conflict(message: str) -> web.HTTPConflict:
    return web.HTTPConflict(text=json.dumps({"error": message}), content_type="application/json")
