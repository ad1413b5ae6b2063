"""Logging names. Raw frames go to the ``pyuss.wire`` logger at DEBUG level, one line per frame:
direction, the time stamp and the bytes in hex, so a user can switch them on alone with
``logging.getLogger("pyuss.wire").setLevel(logging.DEBUG)``.
"""

from __future__ import annotations

import logging

wire = logging.getLogger("pyuss.wire")


def log_frame(direction: str, data: bytes, timestamp: float | None = None, note: str = "") -> None:
    """Log one raw frame on ``pyuss.wire`` (cheap when DEBUG is off)."""
    if wire.isEnabledFor(logging.DEBUG):
        when = "" if timestamp is None else f" t={timestamp:.6f}"
        extra = f" {note}" if note else ""
        wire.debug("%s%s %s%s", direction, when, data.hex(" ").upper(), extra)
