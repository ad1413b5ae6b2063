"""See the master at work: three simulated drives on a virtual bus, in a few seconds.

A virtual RS-485 line at 38400 baud carries three simulated drives of different profiles,
each a station of its own as real devices are: address 1 the drive profile of the USS
specification (``generic``, variable length), address 4 a Baumueller drive (fixed length PKW 3 +
PZD 2, pipelined answers, a 3-character start pause) and address 7 a MICROMASTER 4
(parameters from 2000 on through IND page bits). The master then

1. scans addresses 0..9 for drives and their telegram layout,
2. goes round the poll list cyclically and reads and writes parameters of all three, reads a
   parameter description and a text (USS specification C 8, examples 2, 4 and 7),
3. receives a spontaneous message when a value changes on the drive's own panel (C 4.2.1.2),
4. checks every drive with a mirror telegram (A 5.3),
5. runs drive 1 up to 50 % and down again, following its status live,
6. shows a request and its answer from the line decoded, and the diagnostics of the bus.

Nothing needs hardware; the demo finishes by itself.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
from typing import Any

from pyuss.bus import Recorder, VirtualBus
from pyuss.cli._help import subcommand
from pyuss.cli.decode import describe, render
from pyuss.master import Drive, Master, SpontaneousMessage
from pyuss.master.scan import scan
from pyuss.master.testing import simulated_drives
from pyuss.params.values import words_text
from pyuss.profiles import get_profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.receiver import Received, Receiver
from pyuss.slave import SlaveEngine

__all__ = ["DRIVES", "register", "run"]

BAUD = 38400
DRIVES: tuple[tuple[int, str, Layout], ...] = (
    (1, "generic", Layout(PKW_VARIABLE, 2)),
    (4, "baumueller", Layout(3, 2)),
    (7, "micromaster4", Layout(PKW_VARIABLE, 2)),
)
"""Address, profile and layout of the simulated drives."""


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers,
        "demo",
        "run the master against three simulated drives on a virtual bus",
        __doc__,
    )
    parser.set_defaults(func=run)


def say(text: str = "") -> None:
    print(text, flush=True)


async def _scan(bus: VirtualBus) -> None:
    say('1. Scan of addresses 0..9 ("no job" probes of the common fixed lengths):')
    found = await scan(lambda baud: bus.attach("scanner"), [BAUD], range(10), latency=0.02)
    for f in found:
        status = "-" if f.status is None else f"{f.status:04X}h"
        say(f"   address {f.address}: layout {f.layout}, status word {status}")
    say()


async def _parameters(master: Master, generic: Drive, baumueller: Drive, mm4: Drive) -> None:
    say("2. Parameters, while the master goes round the poll list [1, 4, 1, 7]:")
    value = await generic.read_param(52)
    say(f"   drive 1 (generic)      {value.text()}   (C 8 example 2: {words_text(value.words)})")
    low = (await generic.read_description(52, 7)).elements[7].words[0]
    say(f"   drive 1 (generic)      P52 lower limit = {low:04X}h    (C 8 example 4)")
    text = await generic.read_text(7, 3)
    say(f"   drive 1 (generic)      P7 text 3 = {text!r}     (C 8 example 7)")
    description = await generic.read_description(947)
    say(f"   drive 1 (generic)      P947 is {description.name!r}, {description.data_type}")
    written = await generic.write_raw(18, [0x7000])
    say(f"   drive 1 (generic)      P18 := 7000h -> {words_text(written)}")
    ramp = await baumueller.read_param(60)
    say(f"   drive 4 (baumueller)   {ramp.text()}")
    written_value = await baumueller.write_param(60, 1500)
    say(f"   drive 4 (baumueller)   P60 := 1500 ms -> {written_value.text()}")
    baud = await mm4.read_param(2010, 0)
    say(f"   drive 7 (micromaster4) {baud.text()} (IND page bit 15)")
    seconds = await mm4.write_param(1120, 2.5)
    say(f"   drive 7 (micromaster4) P1120 := 2.5 s -> {seconds.text()}")
    say()


async def _spontaneous(generic: Drive, engine: SlaveEngine) -> None:
    say("3. A value changes on the drive's own panel: a spontaneous message (C 4.2.1.2):")
    got: asyncio.Queue[SpontaneousMessage] = asyncio.Queue()
    remove = generic.on_spontaneous(got.put_nowait)
    engine.drive.update(52, 0x1234)
    async with asyncio.timeout(5):
        message = await got.get()
    remove()
    say(f"   drive {message.address}: P{message.pnu} is now {message.value:04X}h (acknowledged)")
    say()


async def _mirror(master: Master) -> None:
    say("4. Mirror telegrams (A 5.3):")
    for address, _, _ in DRIVES:
        result = await master.mirror(address)
        say(
            f"   drive {address}: {len(result.sent)} bytes back unchanged, answer after "
            f"{result.response_time * 1000:.2f} ms"
        )
    say()


async def _run(generic: Drive) -> None:
    say("5. Drive 1 runs up to 50 % and down again (ramp 1 s), status live:")
    await generic.write(462, 1.0)  # ramp-up time 1.0 s (P462 counts in 0.1 s)
    await generic.write(464, 1.0)
    await generic.setpoint(50.0)
    await generic.on()
    # The ramp ends exactly on the setpoint (8192 = 2000h = 50 %); wait for that, not for the
    # tolerance band, so the last line shows the setpoint reached whatever the cycle timing.
    await _follow(generic, lambda s: s.in_tolerance and (s.actual_percent or 0) >= 50.0)
    await generic.off1()
    await _follow(generic, lambda s: not s.running)
    say()


async def _follow(drive: Drive, done: Any) -> None:
    loop = asyncio.get_running_loop()
    end = loop.time() + 10
    shown = -1.0
    while loop.time() < end:
        status = await drive.next_update()
        now = loop.time()
        finished = done(status)
        if finished or now - shown >= 0.2:
            shown = now
            actual = status.actual_percent or 0.0
            bar = "#" * round(actual / 2.5)
            say(f"   {status.state:<20} {status.word:04X}h  {actual:6.2f} %  {bar}")
        if finished:
            return


def _decoded(recorder: Recorder) -> None:
    say("6. Reading P52 of drive 1 as it went over the line (uss decode, bit lists left out):")
    receiver = Receiver(BAUD)
    seen: dict[str, Received] = {}
    for record in recorder.records:
        for event in receiver.feed(bytes((record.byte,)), record.t):
            if not isinstance(event, Received) or event.telegram.address != 1:
                continue
            pke = event.telegram.data[:2]
            if record.sender == "master" and pke == b"\x10\x34" and "request" not in seen:
                seen["request"] = event
            elif record.sender == "drive1" and "request" in seen and pke[0] & 0xF7 == 0x10:
                seen.setdefault("response", event)
    layout = DRIVES[0][2]
    for direction in ("request", "response"):
        if direction in seen:
            text = render(describe(seen[direction].raw, layout, direction))
            lines = [ln for ln in text.splitlines() if not ln.lstrip().startswith("bit ")]
            say("   " + "\n   ".join(lines))
    say()


def _diagnostics(master: Master) -> None:
    diag = master.diagnostics()
    cycles = diag.cycles.achieved
    say(
        f"Diagnostics: {diag.cycles.cycles} cycles, cycle time {cycles.mean * 1000:.1f} ms "
        f"(jitter {cycles.stdev * 1000:.2f} ms), {diag.line.good} good telegrams, "
        f"{diag.line.discarded} discarded on the line"
    )
    for slave in diag.slaves:
        say(
            f"   drive {slave.address}: {slave.exchanges} exchanges, {slave.timeouts} timeouts, "
            f"response {slave.response_time.median * 1000:.2f} ms median, "
            f"{slave.jobs.completed} jobs ({slave.jobs.guard_telegrams} 'no job' guards)"
        )


async def demo() -> int:
    # The simulated drives share this process's event loop with the master and the bus; a
    # busy moment makes them complain about their own answer times, which is not the point.
    logging.getLogger("pyuss.slave").setLevel(logging.ERROR)
    bus = VirtualBus(BAUD)
    recorder = Recorder().attach(bus)
    say(f"A virtual RS-485 bus at {BAUD} baud with three simulated drives:")
    for address, profile, layout in DRIVES:
        say(f"   address {address}: {get_profile(profile).title} (layout {layout})")
    say()
    try:
        async with simulated_drives(bus, DRIVES) as engines:
            await _scan(bus)
            async with Master(bus.attach("master")) as master:
                generic = master.drive(1, layout=DRIVES[0][2], profile="generic")
                baumueller = master.drive(4, layout=DRIVES[1][2], profile="baumueller")
                mm4 = master.drive(7, layout=DRIVES[2][2], profile="micromaster4")
                master.set_poll_list([1, 4, 1, 7])
                await _parameters(master, generic, baumueller, mm4)
                await _spontaneous(generic, engines[1])
                await _mirror(master)
                await _run(generic)
                _decoded(recorder)
                _diagnostics(master)
    finally:
        await bus.close()
    return 0


def run(args: argparse.Namespace) -> int:
    del args
    return asyncio.run(demo())
