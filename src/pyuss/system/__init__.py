"""The one place where pyuss differs between Windows, macOS and Linux.

Everything else in pyuss is written once for every platform and asks this package where the
platforms differ, as pyserial picks ``serialposix`` or ``serialwin32`` in one module. A test
(tests/test_architecture.py) holds that no other module looks at ``sys.platform`` or
``os.name``, or uses calls that exist on some platforms only (``fcntl``, ``termios``,
``msvcrt``, ``add_signal_handler``, ``os.major``, ``os.openpty``, epoll, ``os.replace``).

What differs, and what pyuss does (docs/platforms.md says it for users):

- **The line's clock** (`clock`): the time every transport stamps bytes with and the virtual
  bus of another process shares. ``time.monotonic`` where it keeps microseconds (Linux, macOS,
  Windows from Python 3.13), else ``time.perf_counter`` (Windows before 3.13, whose
  ``monotonic`` ticks in 15.6 ms steps: 30 characters at 19200 baud). Both count system-wide,
  so processes on one machine share them. `clock_warning` says when even that clock is too
  coarse for a character time.
- **The event loop's selector** (`fine_selector`): epoll waited on with ``select()`` on Linux
  (microsecond timeouts), kqueue on macOS and the BSDs, the platform's default loop elsewhere
  (the proactor on Windows). `least_timer_slack` asks the system for its finest timers.
- **Stopping** (`stop_on_signals`): Ctrl+C everywhere, SIGTERM on Linux and macOS, Ctrl+Break on
  Windows, all ending a long-running command the same way.
- **Files** (`replace_closing`, `try_lock`, `set_mode`): a file is renamed into place while
  still open and locked where the system allows it (POSIX), closed first where it does not
  (Windows, which also retries a rename that an antivirus or an indexer holds for a moment).
- **Serial lines and ptys** (`open_pty`, `is_pty_device`, `mark_line_errors`, `low_latency`):
  ptys and the terminal settings exist on POSIX systems only; on Windows `open_pty` says what to
  use instead.
- **Folders** (`config_folder`, `wireshark_plugin_folder`): ``%APPDATA%`` on Windows,
  ``~/Library/Application Support`` on macOS, XDG on Linux.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable

from pyuss.system._common import PTY_ADVICE, NoPty

if sys.platform == "win32":
    from pyuss.system._windows import (
        HAS_PTY,
        LINE_SETUP_ERRORS,
        NAME,
        NOFOLLOW,
        STOP_SIGNALS,
        config_folder,
        fine_selector,
        is_pty_device,
        least_timer_slack,
        low_latency,
        mark_line_errors,
        open_pty,
        quote,
        replace,
        replace_closing,
        set_mode,
        stop_on_signals,
        try_lock,
        wireshark_plugin_folder,
    )
else:
    from pyuss.system._posix import (
        HAS_PTY,
        LINE_SETUP_ERRORS,
        NAME,
        NOFOLLOW,
        STOP_SIGNALS,
        config_folder,
        fine_selector,
        is_pty_device,
        least_timer_slack,
        low_latency,
        mark_line_errors,
        open_pty,
        quote,
        replace,
        replace_closing,
        set_mode,
        stop_on_signals,
        try_lock,
        wireshark_plugin_folder,
    )

__all__ = [
    "CLOCK_RESOLUTION",
    "HAS_PTY",
    "LINE_SETUP_ERRORS",
    "NAME",
    "NOFOLLOW",
    "PTY_ADVICE",
    "STOP_SIGNALS",
    "NoPty",
    "clock",
    "clock_warning",
    "config_folder",
    "fine_selector",
    "install_command",
    "is_pty_device",
    "least_timer_slack",
    "low_latency",
    "mark_line_errors",
    "open_pty",
    "quote",
    "replace",
    "replace_closing",
    "set_mode",
    "stop_on_signals",
    "try_lock",
    "wireshark_plugin_folder",
]

FINE_ENOUGH = 1e-4
"""A clock that ticks at most this coarsely keeps a character time (52 us at 187500 baud is
half of it; the start pause of two characters, A 5.1.2, 107 us)."""


def _line_clock() -> tuple[Callable[[], float], float]:
    monotonic = time.get_clock_info("monotonic").resolution
    if monotonic <= FINE_ENOUGH:
        return time.monotonic, monotonic
    return time.perf_counter, time.get_clock_info("perf_counter").resolution


clock, CLOCK_RESOLUTION = _line_clock()
"""The line's clock (seconds, one base for every process of the machine) and how finely it
ticks; see the module docstring."""


def clock_warning(baud: int) -> str | None:
    """A sentence for the user when the line's clock ticks more coarsely than a character at
    ``baud`` (11 bits, A 6.1), else None."""
    char = 11 / baud
    if char >= CLOCK_RESOLUTION:
        return None
    return (
        f"this system's clock ticks every {CLOCK_RESOLUTION * 1000:.3g} ms, more than a "
        f"character at {baud} baud ({char * 1000:.3g} ms): response times are measured only "
        "that finely (docs/platforms.md)"
    )


def install_command(requirement: str) -> str:
    """The command that installs ``requirement`` (``pyuss[web]``) into the Python running now:
    its own pip, quoted for the system's shell."""
    return f"{quote(sys.executable)} -m pip install {quote(requirement, always=True)}"
