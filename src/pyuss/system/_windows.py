"""Windows (see `pyuss.system`)."""

from __future__ import annotations

import sys

# ruff: noqa: E402 - the imports follow the platform check, which the type checker reads
assert sys.platform == "win32"  # for the type checker too: this module is Windows only

import contextlib
import msvcrt
import os
import selectors
import signal
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType
from typing import IO, TYPE_CHECKING, Any

if TYPE_CHECKING:
    import asyncio

from pyuss.system._common import PTY_ADVICE, NoPty

NAME = "win32"
HAS_PTY = False
NOFOLLOW = 0
"""Windows follows no symbolic links on open that a sweep must guard against."""
LINE_SETUP_ERRORS: tuple[type[BaseException], ...] = ()
STOP_SIGNALS = (signal.SIGINT, signal.SIGBREAK)
"""Ctrl+C and Ctrl+Break (what a console, a service wrapper or ``CTRL_BREAK_EVENT`` sends)."""

_REPLACE_TRIES = 20
"""How often a rename refused with "access denied" is tried again (an antivirus or an indexer
holds the new file for a moment after it was closed); 1 s in all."""
_REPLACE_PAUSE = 0.05


# -- the event loop ---------------------------------------------------------------------------


def fine_selector() -> selectors.BaseSelector | None:
    """None: the proactor loop, Windows' default, serves sockets, pipes and subprocesses;
    its timers follow the system's timer resolution (`least_timer_slack`)."""
    return None


def least_timer_slack() -> None:
    """Ask Windows for 1 ms timer resolution (``timeBeginPeriod``) for this process (the
    default is 15.6 ms); no error if refused."""
    with contextlib.suppress(Exception):
        import ctypes

        ctypes.windll.winmm.timeBeginPeriod(1)


@contextlib.contextmanager
def stop_on_signals(callback: Callable[[int], object] | None = None) -> Iterator[asyncio.Event]:
    """An event set (after ``callback(signal number)``) on Ctrl+C or Ctrl+Break while the block
    runs in the event loop's thread; the handlers before it are put back after.

    Windows' loops have no ``add_signal_handler``: the handler is Python's own, which hands
    the stop to the loop (the proactor loop wakes on a signal through its wake-up socket)."""
    import asyncio  # here: a command without an event loop (uss decode) loads no asyncio

    loop = asyncio.get_running_loop()
    stop = asyncio.Event()

    def in_loop(number: int) -> None:
        if callback is not None:
            callback(number)
        stop.set()

    def on_signal(number: int, frame: FrameType | None) -> None:
        with contextlib.suppress(RuntimeError):  # the loop is closed: nobody waits any more
            loop.call_soon_threadsafe(in_loop, number)

    before: list[tuple[signal.Signals, Any]] = []
    for number in STOP_SIGNALS:
        try:
            before.append((number, signal.signal(number, on_signal)))
        except (ValueError, OSError):  # not the main thread
            continue
    try:
        yield stop
    finally:
        for done, handler in before:
            with contextlib.suppress(ValueError, OSError, TypeError):
                signal.signal(done, handler)


# -- files ------------------------------------------------------------------------------------


def replace(source: str | os.PathLike[str], target: str | os.PathLike[str]) -> None:
    """Rename ``source`` over ``target``, trying again for a second while Windows refuses
    with "access denied" (an antivirus or an indexer looking at the new file)."""
    for _ in range(_REPLACE_TRIES - 1):
        try:
            os.replace(source, target)
            return
        except PermissionError:
            time.sleep(_REPLACE_PAUSE)
    os.replace(source, target)


def replace_closing(file: IO[Any], source: str, target: str | os.PathLike[str]) -> None:
    """Close the flushed ``file`` (at ``source``), then rename it over ``target``: Windows
    renames no file that is still open."""
    file.close()
    replace(source, target)


def try_lock(fd: int) -> None:
    """Lock the first byte of the open file ``fd`` (at its start) for this process until it
    is closed; `OSError` when another process holds it."""
    msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)


def set_mode(fd: int, mode: int) -> None:
    """Nothing: a new file on Windows takes its folder's permissions."""


def quote(text: str, *, always: bool = False) -> str:
    """``text`` as one word of cmd.exe and PowerShell (``always``: quoted even when it needs
    none)."""
    if always or not text or any(ch in text for ch in " \t&|<>^()[]{};,=%!\"'"):
        return '"' + text.replace('"', '""') + '"'
    return text


# -- folders ----------------------------------------------------------------------------------


def config_folder(app: str = "pyuss") -> Path | None:
    """``%APPDATA%\\APP`` (the user's roaming application data); None without it."""
    appdata = os.environ.get("APPDATA") or ""
    if appdata.strip():
        return Path(appdata) / app
    try:
        return Path.home() / "AppData" / "Roaming" / app
    except RuntimeError:
        return None


def wireshark_plugin_folder(home: Path | None = None) -> Path:
    """Wireshark's personal Lua plugins folder: ``%APPDATA%\\Wireshark\\plugins``."""
    appdata = os.environ.get("APPDATA")
    if home is None and appdata:
        return Path(appdata) / "Wireshark" / "plugins"
    return (home or Path.home()) / "AppData" / "Roaming" / "Wireshark" / "plugins"


# -- serial lines and ptys --------------------------------------------------------------------


def open_pty() -> tuple[int, int, str]:
    """Windows has no pseudo-terminals: `NoPty` saying what to use instead."""
    raise NoPty(PTY_ADVICE)


def is_pty_device(path: str) -> bool:
    return False


def mark_line_errors(fd: int) -> bool:
    """False: Windows' serial driver marks no bad characters in the data."""
    return False


def low_latency(fd: int, on: bool) -> bool | None:
    """None: set the latency timer in the adapter's driver settings instead."""
    return None
