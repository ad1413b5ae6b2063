"""The web commissioning page: ``uss web`` (see docs/web.md).

- `pyuss.web.backend`: the one module that runs the line and talks to its drives, through
  the live-drive model `pyuss.points` (never the master); `pyuss.web.plant` the same surface
  over the broker.
- `pyuss.web.telegrams`: the monitor view (the line's telegrams, decoded; pcapng).
- `pyuss.web.files`: backups, comparisons and restores of both.
- `pyuss.web.shown`: how both show values, words and parameters.
- `pyuss.web.server`: the HTTP and WebSocket server (aiohttp): routes and live updates;
  `pyuss.web.guard` its security rules, `pyuss.web.bodies` requests read within bounds,
  `pyuss.web.confirm` the one-time yes to a move.
- `pyuss.web.hub`: live updates with a bounded queue per client.
- `pyuss.web.tap`: the master's own traffic for the monitor view.
- ``static/``: the page (plain JavaScript modules) and the uPlot plotting library.

The server needs the ``web`` extra: ``pip install 'pyuss[web]'``.
"""

from __future__ import annotations

from pyuss._lazy import not_installed
from pyuss.errors import UssError
from pyuss.system import install_command

__all__ = ["EXTRA_HINT", "MissingExtra", "require"]

EXTRA_HINT = install_command("pyuss[web]")


class MissingExtra(UssError, ImportError):
    """A package of the ``web`` extra is not installed."""


def require() -> None:
    """Raise `MissingExtra` naming the command to run when aiohttp is missing."""
    try:
        import aiohttp  # noqa: F401
    except ImportError as exc:
        raise missing_extra(exc) from None


def missing_extra(exc: ImportError) -> MissingExtra:
    """The error to raise for ``exc`` of importing aiohttp: the command to install it when it
    is not installed, else what failed inside it."""
    if not_installed(exc, "aiohttp"):
        return MissingExtra(f"the web page needs aiohttp, which is not installed: {EXTRA_HINT}")
    return MissingExtra(f"the web page needs aiohttp, which is installed but fails to load: {exc}")
