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
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from pyuss.errors import ConfigError, TelegramError, TransportError
from pyuss.master.scheduler import ACYCLIC, Master
from pyuss.profiles import Profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.transport.base import Transport

__all__ = ["COMMON_LAYOUTS", "Found", "probe_layouts", "scan"]

COMMON_LAYOUTS: tuple[Layout, ...] = (
    Layout(3, 2),
    Layout(4, 2),
    Layout(0, 2),
    Layout(4, 0),
    Layout(3, 0),
    Layout(4, 6),
)
"""Fixed layouts tried by default (C 8 uses 3/2, 4/0 and 0/2)."""


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

    def to_dict(self) -> dict[str, Any]:
        return {
            "address": self.address,
            "baud": self.baud,
            "layout": str(self.layout),
            "variable": self.layout.variable,
            "status": self.status,
            "response_time": self.response_time,
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


async def _scan_line(
    bus: Master,
    baud: int,
    addresses: Sequence[int],
    layouts: Sequence[Layout],
    variable: bool,
    tick: Callable[[], None],
) -> list[Found]:
    found = []
    for address in addresses:
        hit = None
        for layout in layouts:
            reply = await bus.request(_probe(address, layout))
            tick()
            if reply is not None:
                hit = (layout, reply)
                break
        if hit is None:
            continue
        layout, reply = hit
        words = len(reply.telegram.data) // 2
        result = layout
        if words != layout.words and words >= 3:
            result = Layout(PKW_VARIABLE, words - 3)
        elif variable and layout.pkw == 3:
            longer = await bus.request(_probe(address, Layout(4, layout.pzd)))
            if longer is not None and len(longer.telegram.data) // 2 == words:
                result = Layout(PKW_VARIABLE, layout.pzd)
        try:
            pzd = result.unpack(reply.telegram.data).pzd
        except TelegramError:
            pzd = ()
        status = pzd[0] if pzd else None
        found.append(Found(address, baud, result, status, reply.response_time))
    return found


async def scan(
    transport: Callable[[int], Transport],
    bauds: Iterable[int],
    addresses: Iterable[int] = range(32),
    *,
    profile: Profile | str | None = None,
    layouts: Sequence[Layout] = (),
    progress: Callable[[int, int], None] | None = None,
    skipped: Callable[[int, TransportError], None] | None = None,
    **master_options: Any,
) -> list[Found]:
    """Probe ``addresses`` at each of ``bauds``; ``transport(baud)`` makes the transport for a
    baud rate (for example ``lambda b: open_transport(url, baud=b)``). ``progress(done,
    total)`` is called after each probe. Other options go to `Master`.

    A rate the transport cannot be opened at (a ``bus://`` line runs at one rate only) is
    left out and the scan goes on; once it is over, ``skipped(baud, error)`` is called for
    each such rate. When no rate could be opened at all, the first error is raised."""
    from pyuss.master.profile import resolve_profile

    prof = resolve_profile(profile)
    bauds = list(bauds)
    addresses = list(addresses)
    candidates = probe_layouts(prof, layouts)
    variable = not prof.fixed_length_only and not layouts
    total = len(bauds) * len(addresses) * len(candidates)
    done = 0

    def tick() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    found: list[Found] = []
    failed: list[tuple[int, TransportError]] = []
    for baud in bauds:
        before = done
        bus = Master(transport(baud), profile=prof, mode=ACYCLIC, **master_options)
        try:
            await bus.start()
        except TransportError as exc:
            failed.append((baud, exc))
        else:
            try:
                found += await _scan_line(bus, baud, addresses, candidates, variable, tick)
            finally:
                await bus.close()
        left = len(addresses) * len(candidates) - (done - before)
        done += left
        if progress is not None and left:
            progress(done, total)
    if failed and len(failed) == len(bauds):
        raise failed[0][1]
    for baud, error in failed:
        if skipped is not None:
            skipped(baud, error)
    return found
