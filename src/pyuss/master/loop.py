"""The asyncio master's task: `Loop` asks the core what comes next
(`pyuss.master.core.MasterCore.next_action`) and carries it out over the line
(`pyuss.master.wire.Wire`): a turn of a slave, a special telegram, or a wait until the core's
time or until something is asked (`Loop.poke`). While the link is down it sends nothing and
looks every `LINK_POLL` whether it is back; a transport that fails for good, or an error of
its own, stops it (`Loop.lost`) and fails all that waits.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging

from pyuss.errors import TransportError, UssError
from pyuss.master.core import _NORMAL, Idle, MasterCore, Slave, Special
from pyuss.master.errors import MasterClosed
from pyuss.master.wire import LineDown, Wire

__all__ = ["LINK_POLL", "Loop"]

log = logging.getLogger("pyuss.master")

LINK_POLL = 0.05
"""How often the master looks whether a lost link is back (seconds); it sends nothing
meanwhile."""


class Loop:
    """The task of one master (see the module docstring)."""

    def __init__(self, core: MasterCore, wire: Wire) -> None:
        self.core = core
        self.wire = wire
        core.poke = self.poke
        self.transport = wire.transport
        self._wake: asyncio.Event | None = None
        self.lost: TransportError | None = None
        """What stopped it on its own (the port failed for good, or an error of its own)."""

    def start(self) -> None:
        """Before `run` is started as a task (in the event loop)."""
        self._wake = asyncio.Event()
        self.wire.start()

    def poke(self) -> None:
        """Something was asked: a wait ends now."""
        if self._wake is not None:
            self._wake.set()

    async def run(self) -> None:
        clock = self.transport.clock
        try:
            now = clock()  # after a turn: the time it ended
            while not self.core.closing:
                if self.core.down is not None:
                    await self._ride_out()  # then the next telegram tries the line
                    if self.core.closing:
                        break
                    now = clock()
                try:
                    action = self.core.next_action(now)
                    if isinstance(action, Slave):
                        now = await self._turn(action)
                        continue
                    if isinstance(action, Special):
                        await self._do_special(action)
                    else:
                        await self._idle(action)
                except LineDown:
                    pass
                now = clock()
        except TransportError as exc:
            if not self.core.line_followed:
                log.error("master stopped: %s", exc)
            self.lost = exc
            self.core.stopped(exc)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a bug must not leave waiters hanging
            log.exception("master stopped by an internal error")
            self.lost = error = MasterClosed(f"the master stopped: {exc!r}")
            self.core.stopped(error)

    async def _ride_out(self) -> None:
        """Wait, sending nothing, until the link is back (the transport's ``connected``) or
        the master closes. A transport that does not say is tried by the next telegram: the
        first that goes out ends the outage (`Wire.send`)."""
        while not self.core.closing:
            await self._sleep(LINK_POLL)
            connected = getattr(self.transport, "connected", None)
            if connected is None:
                return
            if connected:
                self.core.line_back()
                return

    async def _idle(self, idle: Idle) -> None:
        now = self.transport.clock()
        await self._sleep(None if idle.until is None else idle.until - now)
        self.core.expire_jobs(self.transport.clock())

    async def _sleep(self, timeout: float | None) -> None:
        assert self._wake is not None
        self._wake.clear()
        if self.core.closing or self.core.specials:
            return
        if timeout is None:
            await self._wake.wait()
        elif timeout > 0:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(timeout):
                    await self._wake.wait()

    async def _do_special(self, special: Special) -> None:
        pending = special.pending
        try:
            result = await self._run_special(special)
        except LineDown:
            if not pending.done() and self.core.down is not None:
                pending.set_exception(self.core.down)
            raise
        except TransportError:
            raise
        except UssError as exc:
            if not pending.done():
                pending.set_exception(exc)
        else:
            if not pending.done():
                pending.set_result(result)
        self.core.expire_jobs(self.transport.clock())

    async def _run_special(self, special: Special) -> object:
        if special.kind == "broadcast":
            await self.wire.send(special.frame, self.core.broadcast_pause())
            until, before = self.core.broadcast_sent()
            await self.wire.listen(until)
            return self.core.answered_broadcasts - before
        slave, pause, limit, modes = self.core.special_setup(special)
        result = await self.wire.transact(
            special.frame, special.address, modes, limit, pause, slave
        )
        return self.core.special_result(special, slave, result)

    async def _turn(self, slave: Slave) -> float:
        """One telegram to ``slave`` and its answer; returns the time it ended. The telegram is
        built at the last moment, once the start pause is over, so that it carries the newest
        process data (C 5.1) and a job submitted meanwhile."""
        sent = [slave.version, slave.control]

        def build() -> bytes:
            sent[:] = [slave.version, slave.control]
            return slave.request(self.transport.clock())

        pause = slave.profile.start_pause_chars
        early = slave is not self.core.woken
        result = await self.wire.transact(
            build, slave.address, _NORMAL, slave.response_delay, pause, slave, early=early
        )
        now = self.transport.clock()
        self.core.end_turn(slave, result, sent[0], sent[1], now)
        return now
