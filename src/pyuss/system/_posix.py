"""Linux, macOS and the BSDs (see `pyuss.system`)."""

from __future__ import annotations

import sys

# ruff: noqa: E402 - the imports follow the platform check, which the type checker reads
assert sys.platform != "win32"  # for the type checker too: this module is POSIX only

import contextlib
import errno
import fcntl
import logging
import os
import select
import selectors
import shlex
import signal
import stat
import struct
import termios
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, cast

if TYPE_CHECKING:
    import asyncio


log = logging.getLogger("pyuss.system")

LINUX = sys.platform.startswith("linux")
NAME = "linux" if LINUX else sys.platform
HAS_PTY = True
NOFOLLOW = os.O_NOFOLLOW
LINE_SETUP_ERRORS: tuple[type[BaseException], ...] = (termios.error,)
"""Errors of setting up a terminal that are no OSError."""
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
"""Ctrl+C and a service manager's stop."""

_FD_SETSIZE = 1024


# -- the event loop ---------------------------------------------------------------------------

if sys.platform == "linux":

    class _FineEpollSelector(selectors.EpollSelector):
        """``epoll`` for the events, ``select()`` on the epoll descriptor for the timeout."""

        def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
            if timeout is not None and timeout > 0:
                # Readable when any registered descriptor has an event (or after ``timeout``):
                # select() keeps microseconds where epoll rounds up to the millisecond.
                select.select([self.fileno()], [], [], timeout)
                timeout = 0
            return super().select(timeout)

    def fine_selector() -> selectors.BaseSelector | None:
        """epoll whose waits keep microseconds; None where select() cannot wait on it."""
        selector = _FineEpollSelector()
        if selector.fileno() >= _FD_SETSIZE:
            selector.close()
            return None
        return selector

else:

    def fine_selector() -> selectors.BaseSelector | None:
        """kqueue (macOS, the BSDs), whose timeouts keep nanoseconds already; None without."""
        kqueue = getattr(selectors, "KqueueSelector", None)
        return None if kqueue is None else cast(selectors.BaseSelector, kqueue())


def least_timer_slack() -> None:
    """Ask Linux for a 1 ns timer slack on this thread (default 50 us); no error if refused."""
    if not LINUX:
        return
    with contextlib.suppress(Exception):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(29, 1, 0, 0, 0)  # PR_SET_TIMERSLACK, 1 ns


@contextlib.contextmanager
def stop_on_signals(callback: Callable[[int], object] | None = None) -> Iterator[asyncio.Event]:
    """An event set (after ``callback(signal number)``) on Ctrl+C or SIGTERM while the block
    runs in the event loop's thread; the handlers before it are put back after."""
    import asyncio  # here: a command without an event loop (uss decode) loads no asyncio

    loop = asyncio.get_running_loop()
    stop = asyncio.Event()

    def on_signal(number: int) -> None:
        if callback is not None:
            callback(number)
        stop.set()

    added = []
    for number in STOP_SIGNALS:
        try:
            loop.add_signal_handler(number, on_signal, number)
        except (NotImplementedError, RuntimeError, ValueError):  # not the main thread
            continue
        added.append(number)
    try:
        yield stop
    finally:
        for number in added:
            with contextlib.suppress(Exception):
                loop.remove_signal_handler(number)


# -- files ------------------------------------------------------------------------------------


def replace(source: str | os.PathLike[str], target: str | os.PathLike[str]) -> None:
    """Rename ``source`` over ``target`` in one step."""
    os.replace(source, target)


def replace_closing(file: IO[Any], source: str, target: str | os.PathLike[str]) -> None:
    """Rename the flushed ``file`` (at ``source``) over ``target`` and close it. POSIX renames
    an open file, so it is renamed while its lock (`try_lock`) still keeps a sweep away."""
    try:
        os.replace(source, target)
    finally:
        file.close()


def try_lock(fd: int) -> None:
    """Lock the open file ``fd`` for this process until it is closed; `OSError` when another
    process holds its lock."""
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)


def set_mode(fd: int, mode: int) -> None:
    """Give the open file ``fd`` the permission bits ``mode``."""
    os.fchmod(fd, mode)


def quote(text: str, *, always: bool = False) -> str:
    """``text`` as one word of a POSIX shell (``always``: quoted even when it needs none)."""
    quoted = shlex.quote(text)
    return f"'{text}'" if always and quoted == text else quoted


# -- folders ----------------------------------------------------------------------------------


def _home() -> Path | None:
    try:
        return Path.home()
    except RuntimeError:  # no HOME and no user entry
        return None


def config_folder(app: str = "pyuss") -> Path | None:
    """The user's folder for ``app``'s configuration: ``~/Library/Application Support/APP`` on
    macOS, ``$XDG_CONFIG_HOME/APP`` (``~/.config/APP``) elsewhere; None without a home."""
    if sys.platform == "darwin":
        home = _home()
        return None if home is None else home / "Library" / "Application Support" / app
    config_home = os.environ.get("XDG_CONFIG_HOME") or ""
    if config_home.strip():
        return Path(config_home) / app
    home = _home()
    return None if home is None else home / ".config" / app


def wireshark_plugin_folder(home: Path | None = None) -> Path:
    """Wireshark's personal Lua plugins folder (Linux and macOS alike)."""
    return (home or Path.home()) / ".local" / "lib" / "wireshark" / "plugins"


# -- serial lines and ptys --------------------------------------------------------------------


def open_pty() -> tuple[int, int, str]:
    """A new pseudo-terminal pair in raw mode: (master, slave, the slave's path); the master
    does not block. `OSError` when the system refuses one."""
    import tty

    master, slave = os.openpty()
    try:
        tty.setraw(slave)
        os.set_blocking(master, False)
        path = os.ttyname(slave)
    except BaseException:
        os.close(master)
        os.close(slave)
        raise
    return master, slave, path


#: Major device numbers of Linux pty slaves when /proc/tty/drivers cannot be read: Unix98
#: ptys (136..143) and the old BSD ones (3).
_PTY_MAJORS = frozenset((3, *range(136, 144)))


def _pty_majors() -> frozenset[int]:
    """The major numbers the kernel lists for pty slaves (``/proc/tty/drivers``)."""
    try:
        with open("/proc/tty/drivers", encoding="ascii", errors="replace") as f:
            lines = f.read().splitlines()
    except OSError:
        return _PTY_MAJORS
    majors = set()
    for line in lines:
        fields = line.split()
        if len(fields) >= 5 and fields[-1] == "pty:slave" and fields[-3].isdigit():
            majors.add(int(fields[-3]))
    return frozenset(majors) or _PTY_MAJORS


def is_pty_device(path: str) -> bool:
    """True when ``path`` is the device side of a Linux pseudo-terminal (``/dev/pts/N``, or a
    link to one such as socat makes). False elsewhere, and on macOS."""
    if not LINUX or "://" in path:
        return False
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return False
    return stat.S_ISCHR(st.st_mode) and os.major(st.st_rdev) in _pty_majors()


def mark_line_errors(fd: int) -> bool:
    """Switch the terminal ``fd`` to mark characters with parity and framing errors (termios
    INPCK + PARMRK, see `pyuss.transport.serialport`); True: marking is on."""
    attrs = termios.tcgetattr(fd)
    attrs[0] |= termios.INPCK | termios.PARMRK
    attrs[0] &= ~(termios.IGNPAR | termios.ISTRIP | termios.IGNBRK | termios.BRKINT)
    termios.tcsetattr(fd, termios.TCSANOW, attrs)
    return True


#: ``struct serial_struct`` (TIOCGSERIAL): ``flags`` is its fifth int; room for any layout.
_SERIAL_FLAGS_AT = 16
_SERIAL_STRUCT_ROOM = 1024
#: ``ASYNC_LOW_LATENCY`` of ``flags`` (linux/tty_flags.h).
ASYNC_LOW_LATENCY = 1 << 13


def low_latency(fd: int, on: bool) -> bool | None:
    """Ask the driver of the open terminal ``fd`` for low-latency mode (``on``) or normal mode;
    returns whether it was in low-latency mode before, or None when the driver does not offer
    it (a pty, a USB CDC adapter, a driver that refuses, a system other than Linux)."""
    if not LINUX:
        return None
    get = getattr(termios, "TIOCGSERIAL", 0x541E)
    put = getattr(termios, "TIOCSSERIAL", 0x541F)
    try:
        info = bytearray(fcntl.ioctl(fd, get, bytes(_SERIAL_STRUCT_ROOM)))
        (flags,) = struct.unpack_from("i", info, _SERIAL_FLAGS_AT)
        was = bool(flags & ASYNC_LOW_LATENCY)
        if was != on:
            flags = flags | ASYNC_LOW_LATENCY if on else flags & ~ASYNC_LOW_LATENCY
            struct.pack_into("i", info, _SERIAL_FLAGS_AT, flags)
            fcntl.ioctl(fd, put, bytes(info))
    except OSError as exc:
        known = (errno.ENOTTY, errno.EINVAL, errno.EPERM, errno.EACCES, errno.EIO)
        if exc.errno not in (*known, errno.EOPNOTSUPP):
            log.debug("fd %d: low-latency mode: %s", fd, exc)
        return None
    return was
