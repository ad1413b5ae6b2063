"""Event loops whose timers keep sub-millisecond times, and precise waits on any loop.

asyncio's default loop on Linux waits with ``epoll``, whose timeout counts whole milliseconds,
rounded up: a timer, a ``sleep`` or a read with a timeout ends up to 1 ms late, 0.5 ms on
average. At 9600 baud a character takes 1.15 ms and that hardly matters; at 187500 baud a
character takes 59 us and the start pause (2 characters, USS specification A 5.1.2) 117 us, so
a millisecond of lateness is 17 characters lost on every wait.

`new_event_loop` makes a selector loop whose waits keep microseconds: it first waits in
``select()`` (a timeout in microseconds) on the ``epoll`` descriptor itself, which is readable
as soon as any of the loop's sockets, pipes or ptys is, then collects the events with a
non-blocking ``epoll``; the loop still watches any number of descriptors. On Linux it also asks
the kernel for the smallest timer slack of the loop's thread (``PR_SET_TIMERSLACK``), so a
timer is not held back by the default 50 us either. Where the platform's selector is precise
already (``kqueue`` on macOS and BSD) it is the default selector loop; on Windows it is the
proactor loop, with the system's timers set to 1 ms. The choice is made in `pyuss.system`.
`run` runs a coroutine on such a loop; the ``uss`` command uses one for every sub-command.

`sleep_until` and `fine_timers` let the code that keeps the line's timing (the master's start
pause, the simulator's response delay) be precise on any loop: on a loop with coarse timers
(the default one, uvloop) it sleeps until about a millisecond before the moment and passes
the rest by yielding to the loop (``asyncio.sleep(0)``) until the clock says so, which keeps
other tasks and I/O running while it costs some CPU for at most that millisecond.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import importlib
import weakref
from collections.abc import Callable, Coroutine, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

from pyuss import system

__all__ = [
    "COARSE_MARGIN",
    "FINE_MARGIN",
    "LoopChoice",
    "fine_timers",
    "install",
    "installed",
    "margin",
    "new_event_loop",
    "run",
    "sleep_until",
    "uvloop_choice",
]

T = TypeVar("T")

COARSE_MARGIN = 0.0012
"""On a loop with millisecond timers, waits end this much before their moment by sleeping;
the rest is passed by yielding to the loop."""
FINE_MARGIN = 0.0001
"""The same on a loop of `new_event_loop`: a timer of a loaded machine still wakes some tens
of microseconds late."""

_FINE: weakref.WeakSet[asyncio.AbstractEventLoop] = weakref.WeakSet()


def _default_loop() -> asyncio.AbstractEventLoop:
    """The platform's own loop (the proactor on Windows), made without the policy that
    `install` sets, whose ``new_event_loop`` calls back here."""
    return asyncio.DefaultEventLoopPolicy().new_event_loop()


def new_event_loop(*, least_slack: bool = True) -> asyncio.AbstractEventLoop:
    """A new event loop with microsecond timers where the platform has them (see the module
    docstring), else the platform's default loop. ``least_slack``: also ask the system for
    its finest timers (a program that keeps a line's timing for long; a quick command spares
    itself loading ctypes)."""
    selector = system.fine_selector()
    if least_slack:
        system.least_timer_slack()
    if selector is None:
        return _default_loop()
    loop: asyncio.AbstractEventLoop = asyncio.SelectorEventLoop(selector)
    _FINE.add(loop)
    return loop


def fine_timers(loop: asyncio.AbstractEventLoop | None = None) -> bool:
    """Whether ``loop`` (default: the running one) keeps sub-millisecond timers."""
    return (loop or asyncio.get_running_loop()) in _FINE


def run(main: Coroutine[Any, Any, T], *, debug: bool | None = None) -> T:
    """`asyncio.run` on a loop of `new_event_loop`."""
    with asyncio.Runner(debug=debug, loop_factory=new_event_loop) as runner:
        return runner.run(main)


class _Policy(asyncio.DefaultEventLoopPolicy):
    def __init__(self, least_slack: bool) -> None:
        super().__init__()
        self.least_slack = least_slack

    def new_event_loop(self) -> asyncio.AbstractEventLoop:
        return new_event_loop(least_slack=self.least_slack)


def install(*, least_slack: bool = True) -> None:
    """Make `asyncio.run` (and every loop made through the policy) use `new_event_loop`: for
    programs, such as the ``uss`` command, whose every loop keeps a line's timing."""
    asyncio.set_event_loop_policy(_Policy(least_slack))


@contextlib.contextmanager
def installed(*, least_slack: bool = True) -> Iterator[None]:
    """`install` for the time of a ``with`` block; the policy before it is put back after."""
    before = asyncio.get_event_loop_policy()
    install(least_slack=least_slack)
    try:
        yield
    finally:
        asyncio.set_event_loop_policy(before)


def margin(loop: asyncio.AbstractEventLoop | None = None) -> float:
    """How long before a moment a precise wait on ``loop`` stops sleeping and yields instead."""
    return FINE_MARGIN if fine_timers(loop) else COARSE_MARGIN


@dataclass(frozen=True)
class LoopChoice:
    """The event loop a program runs on, and why (printed by ``uss gateway``)."""

    name: str
    why: str
    factory: Callable[[], asyncio.AbstractEventLoop] | None = None
    """Makes the loop; None: the loop `install` set up (`new_event_loop`)."""

    def run(self, main: Coroutine[Any, Any, T]) -> T:
        """`asyncio.run` on this loop."""
        if self.factory is None:
            return asyncio.run(main)
        with asyncio.Runner(loop_factory=self.factory) as runner:
            return runner.run(main)

    def __str__(self) -> str:
        return f"{self.name} ({self.why})"


def uvloop_choice(timed_by_bus: bool) -> LoopChoice:
    """uvloop where it is installed and the program keeps no line's timing by its own
    timers, else the loop of `new_event_loop`. ``timed_by_bus``: every line the program
    talks to is a virtual bus of another process (``bus://``), which puts each telegram on
    the line at the moment handed over with it: the master needs no timer finer than
    uvloop's milliseconds there. On a serial port, a pty or TCP it keeps the start pause
    itself, and on a loop with millisecond timers would pass the last 1.2 ms of every wait
    yielding to the loop (`COARSE_MARGIN`), which costs more CPU than uvloop saves. uvloop
    takes fewer microseconds per turn of the loop, and a program that serves many drives
    turns it several times per answer (docs/bench.md)."""
    fine = LoopChoice("pyuss.loop", "microsecond timers")
    if not timed_by_bus:
        return dataclasses.replace(fine, why="microsecond timers: a line whose timing it keeps")
    try:
        uvloop = importlib.import_module("uvloop")  # an optional extra (pyuss[gateway])
    except ImportError:
        return dataclasses.replace(fine, why="microsecond timers; uvloop is not installed")
    version = getattr(uvloop, "__version__", "")
    return LoopChoice(
        f"uvloop {version}".strip(), "every bus is bus://, timed by the bus", uvloop.new_event_loop
    )


async def sleep_until(target: float, clock: Callable[[], float]) -> None:
    """Return once ``clock()`` has reached ``target``, as soon after as the machine allows,
    on any loop (see the module docstring)."""
    left = target - clock()
    if left <= 0:
        return
    early = margin()
    if left > early:
        await asyncio.sleep(left - early)
    while clock() < target:
        await asyncio.sleep(0)
