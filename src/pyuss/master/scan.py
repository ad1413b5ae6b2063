"""Finding the slaves on a line: their addresses, baud rate and telegram layout.

For each baud rate a master is opened (acyclic: only probes go out) and every address is probed
with normal telegrams carrying "no job" and all process data zero. Control word 0000h has bit
10 clear, "no control by the interface: process data not valid, the old ones stay" (C Table
5.4), so a drive takes nothing from a probe.

A slave with a fixed telegram length stays silent when LGE is not its own (A 5.2, A 4.2.2), so
the probes try the common fixed layouts one after the other - different lengths only, since a
layout of the same length is the same probe - beginning with the profile's default layout:
PKW 3 / PZD 2, PKW 4 / PZD 2, PKW 0 / PZD 2, PKW 4 / PZD 0, PKW 3 / PZD 0, PKW 4 / PZD 6
(``layouts`` replaces the list). The first answer gives the length; two layouts of one length
(PKW 3 + PZD 3 and PKW 4 + PZD 2, say) cannot be told apart this way, and the first in the list
is reported. A variable-length slave (PKW 127) answers "no job" with a 3-word PKW area and its
PZD words whatever the probe's length: an answer of another length than the probe, or an
answer to a second probe one PKW word longer, shows it, and gives its PZD count.

Time: a probe nobody answers costs its request, the start pause and the response window
(`response_limit`), plus the master's ``silence`` (4 ms on the virtual bus); `Progress` reports
after each probe with the wire time so far and an estimate of the time left. Drives are
reported as they are found (``on_found``), ``first`` stops at the first one, and ``identify``
lets a caller ask each drive who it is while its rate is open, before it is reported.
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from pyuss.bus.timed import timed_writer
from pyuss.errors import ConfigError, TelegramError, TransportError
from pyuss.master.core import EXACT_LATENCY
from pyuss.master.profile import response_limit
from pyuss.master.scheduler import ACYCLIC, Master, Reply
from pyuss.profiles import Profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.protocol.timing import char_time
from pyuss.transport.base import Transport

__all__ = [
    "COMMON_LAYOUTS",
    "USUAL_BAUDS",
    "Found",
    "Identify",
    "Progress",
    "probe_layouts",
    "scan",
]

COMMON_LAYOUTS: tuple[Layout, ...] = (
    Layout(3, 2),
    Layout(4, 2),
    Layout(0, 2),
    Layout(4, 0),
    Layout(3, 0),
    Layout(4, 6),
)
"""Fixed layouts tried by default (C 8 uses 3/2, 4/0 and 0/2)."""

USUAL_BAUDS = (9600, 19200, 38400, 57600, 115200, 187500)
"""The rates drives are set to in practice, tried by ``uss scan --baud auto`` (the 13 of B 2.4
take some 6 to 7 minutes, most of it at the slow rates no drive of today is set to)."""


@dataclass(frozen=True, slots=True)
class Found:
    """A slave that answered."""

    address: int
    baud: int
    layout: Layout
    """Its layout (PKW 127 with its PZD count for a variable-length slave)."""
    status: int | None
    """PZD1 of its answer (the status word), None without PZD."""
    response_time: float
    """From the end of the probe to the start of the answer; 0 where none was measured (an
    answer read sooner than a line brings it: a pty or a socket whose peer writes it at once,
    `measured`)."""

    @property
    def measured(self) -> float | None:
        """The response time, or None where it was not measured: a slave keeps the start pause
        before it answers (A 5.2.1.1), so an estimate of 0 or less is no time of the drive's."""
        return self.response_time if self.response_time > 0 else None

    def to_dict(self) -> dict[str, Any]:
        return {
            "address": self.address,
            "baud": self.baud,
            "layout": str(self.layout),
            "variable": self.layout.variable,
            "status": self.status,
            "response_time": self.measured,
        }


def probe_layouts(profile: Profile | None = None, layouts: Sequence[Layout] = ()) -> list[Layout]:
    """The fixed layouts to probe with, one per telegram length, in order. ``layouts`` given
    replace the common ones and must suit ``profile`` (`ConfigError`); of the common ones,
    those the profile does not allow are left out."""
    candidates: list[Layout] = []
    if layouts:
        candidates += layouts
    else:
        if profile is not None:
            candidates.append(profile.fixed_layout or profile.default_layout)
        candidates += COMMON_LAYOUTS
    out: list[Layout] = []
    lengths: set[int] = set()
    for layout in candidates:
        if layout.variable:
            layout = Layout(3, layout.pzd)
        if profile is not None:
            try:
                profile.check_layout(layout)
            except ConfigError:
                if layouts:
                    raise
                continue
        assert layout.lge is not None
        if layout.lge not in lengths:
            lengths.add(layout.lge)
            out.append(layout)
    return out


def _probe(address: int, layout: Layout) -> Telegram:
    pkw = Pkw(0) if layout.pkw else None
    return Telegram(address, AddressMode.NORMAL, layout.pack(pkw, [0] * layout.pzd))


@dataclass(frozen=True, slots=True)
class Progress:
    """How far a scan is, after each probe."""

    done: int
    """Probes sent (or skipped with a rate that could not be opened)."""
    total: int
    """Probes at most: every address at every rate with every layout."""
    elapsed: float
    """Seconds since the scan began."""
    left: float | None
    """Seconds still to go, estimated from the wire time of the probes left and how the
    scan kept to the wire time so far (None before the first probe)."""
    wire: float
    """The wire time of the probes so far: each request with the start pause before it, and
    its answer or, for an address that stayed silent, the response window."""


Identify = Callable[[Master, Found], Awaitable[Found]]
"""Asks a drive just found who it is, on the scanning master (its layout is known, its rate
is open): returns the `Found` to report (the same, or one that says more)."""


@dataclass(slots=True)
class _Clock:
    """The bookkeeping behind `Progress`."""

    total: int
    model_total: float
    report: Callable[[Progress], None] | None
    began: float = field(default_factory=time.monotonic)
    done: int = 0
    model_done: float = 0.0
    wire: float = 0.0

    def tick(self, probes: int, model: float, wire: float) -> None:
        self.done += probes
        self.model_done += model
        self.wire += wire
        if self.report is None:
            return
        elapsed = time.monotonic() - self.began
        left = None
        if self.done >= self.total:
            left = 0.0  # every probe made (the sum of the model's floats may miss its total)
        elif self.model_done > 0:
            left = max(0.0, (self.model_total - self.model_done) * elapsed / self.model_done)
        self.report(Progress(self.done, self.total, elapsed, left, self.wire))


class _Line:
    """One rate of a scan: its master and the time model of its probes."""

    def __init__(self, bus: Master, baud: int, clock: _Clock) -> None:
        self.bus = bus
        self.baud = baud
        self.clock = clock
        self.ct = char_time(baud)
        self.pause = bus.profile.start_pause(baud)
        self.window = response_limit(bus.profile, baud, bus.response_delay)

    async def probe(self, telegram: Telegram) -> Reply | None:
        reply = await self.bus.request(telegram)
        sent = (len(telegram.data) + 4) * self.ct + self.pause
        if reply is None:
            wire = sent + self.window
        else:
            wire = sent + reply.response_time + len(reply.raw) * self.ct
        self.clock.tick(1, sent + self.window, wire)
        return reply


def _reporter(
    progress: Callable[[int, int], None] | None, on_progress: Callable[[Progress], None] | None
) -> Callable[[Progress], None] | None:
    if progress is None:
        return on_progress
    if on_progress is None:
        return lambda p: progress(p.done, p.total)

    def both(p: Progress) -> None:
        progress(p.done, p.total)
        on_progress(p)

    return both


def _probe_seconds(
    baud: int, layout: Layout, profile: Profile, response_delay: float | None
) -> float:
    """The wire time of a probe nobody answers: request, start pause, response window."""
    assert layout.lge is not None
    chars = layout.lge + 2
    return (
        chars * char_time(baud)
        + profile.start_pause(baud)
        + response_limit(profile, baud, response_delay)
    )


async def _probe_address(
    line: _Line, address: int, layouts: Sequence[Layout], variable: bool
) -> Found | None:
    """Probe one address with each layout until it answers; what it is, or None."""
    hit = None
    for layout in layouts:
        reply = await line.probe(_probe(address, layout))
        if reply is not None:
            hit = (layout, reply)
            break
    if hit is None:
        return None
    layout, reply = hit
    words = len(reply.telegram.data) // 2
    result = layout
    if words != layout.words and words >= 3:
        result = Layout(PKW_VARIABLE, words - 3)
    elif variable and layout.pkw == 3:
        longer = await line.probe(_probe(address, Layout(4, layout.pzd)))
        if longer is not None and len(longer.telegram.data) // 2 == words:
            result = Layout(PKW_VARIABLE, layout.pzd)
    try:
        pzd = result.unpack(reply.telegram.data).pzd
    except TelegramError:
        pzd = ()
    status = pzd[0] if pzd else None
    return Found(address, line.baud, result, status, reply.response_time)


async def scan(
    transport: Callable[[int], Transport],
    bauds: Iterable[int],
    addresses: Iterable[int] = range(32),
    *,
    profile: Profile | str | None = None,
    layouts: Sequence[Layout] = (),
    progress: Callable[[int, int], None] | None = None,
    on_progress: Callable[[Progress], None] | None = None,
    skipped: Callable[[int, TransportError], None] | None = None,
    on_found: Callable[[Found], None] | None = None,
    identify: Identify | None = None,
    first: bool = False,
    **master_options: Any,
) -> list[Found]:
    """Probe ``addresses`` at each of ``bauds``; ``transport(baud)`` makes the transport for a
    baud rate (for example ``lambda b: open_transport(url, baud=b)``). Other options go to
    `Master`.

    ``progress(done, total)`` and ``on_progress`` (with a `Progress`: the time left too) are
    called after each probe; ``on_found`` with each drive as
    soon as it is found (after ``identify``, if given, has asked it who it is); ``first``:
    stop at the first drive found. A rate the transport cannot be opened at (a ``bus://``
    line runs at one rate only) is left out and the scan goes on; once it is over,
    ``skipped(baud, error)`` is called for each such rate. When no rate could be opened at
    all, the first error is raised. The drives found are returned in the order found."""
    from pyuss.master.profile import resolve_profile

    prof = resolve_profile(profile)
    bauds = list(bauds)
    addresses = list(addresses)
    candidates = probe_layouts(prof, layouts)
    variable = not prof.fixed_length_only and not layouts
    delay = master_options.get("response_delay")
    per_address = {
        baud: sum(_probe_seconds(baud, layout, prof, delay) for layout in candidates)
        for baud in bauds
    }
    clock = _Clock(
        total=len(bauds) * len(addresses) * len(candidates),
        model_total=sum(per_address[baud] * len(addresses) for baud in bauds),
        report=_reporter(progress, on_progress),
    )
    found: list[Found] = []
    failed: list[tuple[int, TransportError]] = []
    for baud in bauds:
        before, model_before = clock.done, clock.model_done
        link = transport(baud)
        options = dict(master_options)
        if "latency" not in options and "silence" not in options and timed_writer(link):
            options["silence"] = EXACT_LATENCY  # the virtual bus hands characters over at once
        bus = Master(link, profile=prof, mode=ACYCLIC, **options)
        try:
            await bus.start()
        except TransportError as exc:
            failed.append((baud, exc))
        else:
            try:
                line = _Line(bus, baud, clock)
                for address in addresses:
                    drive = await _probe_address(line, address, candidates, variable)
                    if drive is None:
                        continue
                    if identify is not None:
                        drive = await identify(bus, drive)
                    found.append(drive)
                    if on_found is not None:
                        on_found(drive)
                    if first:
                        return found
            finally:
                await bus.close()
        # what was not probed at this rate (a rate that could not be opened) counts as done
        left = len(addresses) * len(candidates) - (clock.done - before)
        model_left = per_address[baud] * len(addresses) - (clock.model_done - model_before)
        if left > 0:
            clock.tick(left, max(0.0, model_left), 0.0)
    if failed and len(failed) == len(bauds):
        raise failed[0][1]
    for baud, error in failed:
        if skipped is not None:
            skipped(baud, error)
    return found
