"""What only some systems have, and the tests that need it skipped where it is missing.

- ``@pytest.mark.pty``: the test needs a pseudo-terminal (``os.openpty``: Linux, macOS and the
  other POSIX systems; not Windows). A test that uses a pty only as a line to something else
  runs over TCP or the virtual bus instead; what is left tests the pty itself, or what only a
  terminal or a serial line has (its settings, its timing, ``--pty`` options, a controlling
  terminal).
- ``@pytest.mark.posix("what")``: the test needs something else only POSIX systems have: a
  signal sent to a child process (SIGTERM, SIGINT, SIGSTOP: Windows can only kill it),
  ``fcntl``, ``termios``, ``os.fork``, a FIFO, ``time.tzset``. ``what`` says which; it is the
  reason the skip gives.

`skip_reason` is what the hook in tests/conftest.py asks for every collected test.
"""

from __future__ import annotations

import os

import pytest

HAS_PTY = hasattr(os, "openpty")
"""Whether this system has pseudo-terminals."""

POSIX = os.name == "posix"
"""Whether this system is a POSIX one (signals, fcntl, termios, fork)."""

NO_PTY = "needs a pseudo-terminal (os.openpty), which this system does not have"


def skip_reason(item: pytest.Item) -> str | None:
    """Why ``item`` cannot run here (None: it can); a ``posix`` mark without its reason is a
    mistake of the test, named as such."""
    if item.get_closest_marker("pty") is not None and not HAS_PTY:
        return NO_PTY
    for mark in item.iter_markers("posix"):
        if len(mark.args) != 1 or not isinstance(mark.args[0], str) or not mark.args[0]:
            raise pytest.UsageError(
                f"{item.nodeid}: give the mark what it needs: @pytest.mark.posix('what')"
            )
        if not POSIX:
            return f"POSIX only: {mark.args[0]}"
    return None
