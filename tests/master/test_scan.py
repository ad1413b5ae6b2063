"""Scanning a line for slaves, their baud rate and layout; raw requests."""

from __future__ import annotations

import asyncio
import dataclasses

import pytest

from pyuss.bus import VirtualBus
from pyuss.errors import ConfigError, TransportError
from pyuss.master import Master
from pyuss.master.scan import Found, Progress, probe_layouts, scan
from pyuss.profiles import get_profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.transport.url import open_transport
from support.buses import simulated_bus


def test_probe_layouts_one_per_length_profile_first() -> None:
    layouts = probe_layouts(get_profile("baumueller"))
    assert layouts[0] == Layout(3, 2)
    assert len({layout.lge for layout in layouts}) == len(layouts)
    assert all(not layout.variable for layout in layouts)
    assert probe_layouts(get_profile("6se21")) == [Layout(3, 2)]
    assert probe_layouts(None, [Layout(3, 2), Layout(4, 1)]) == [Layout(3, 2)]  # same length
    with pytest.raises(ConfigError, match="fixed layout 3,2 only"):  # asked for, not possible
        probe_layouts(get_profile("6se21"), [Layout(4, 2)])


async def test_scan_finds_addresses_layouts_and_the_baud_rate() -> None:
    drives = [
        (1, "generic", Layout(3, 2)),
        (7, "generic", Layout(PKW_VARIABLE, 2)),
        (9, "6se21", Layout(3, 2)),
        (12, "generic", Layout(0, 2)),
        (20, "generic", Layout(4, 0)),
    ]
    async with simulated_bus(drives, baud=19200) as env:
        await env.master.close()  # the scan has the line to itself
        other = VirtualBus(9600)
        stations = {19200: env.bus, 9600: other}
        seen: list[Progress] = []
        counts: list[tuple[int, int]] = []
        found = await scan(
            lambda baud: stations[baud].attach(f"scan{baud}"),
            [9600, 19200],
            [1, 2, 7, 9, 12, 20],
            progress=lambda done, total: counts.append((done, total)),
            on_progress=seen.append,
            latency=0.05,  # simulated drives in this process, on a loaded machine: a margin
        )
        await other.close()
    by_address = {f.address: f for f in found}
    assert set(by_address) == {1, 7, 9, 12, 20}
    assert all(f.baud == 19200 for f in found)
    assert by_address[1].layout == Layout(3, 2)
    assert by_address[7].layout == Layout(PKW_VARIABLE, 2)
    assert by_address[9].layout == Layout(3, 2)
    assert by_address[12].layout == Layout(0, 2)
    assert by_address[20].layout == Layout(4, 0)
    assert by_address[1].status is not None
    assert seen[-1].done == seen[-1].total  # the progress ends complete
    assert counts[-1] == (seen[-1].done, seen[-1].total)
    assert seen[-1].left == 0 and seen[-1].wire > 0
    assert isinstance(found[0], Found) and found[0].to_dict()["baud"] == 19200


async def test_request_sends_any_telegram_and_returns_the_answer() -> None:
    async with simulated_bus([(5, "generic", Layout(3, 2))]) as env:
        bus = env.master
        mirror = Telegram(5, AddressMode.MIRROR, bytes(range(10)))
        reply = await bus.request(mirror)
        assert reply is not None and reply.telegram == mirror
        # A special telegram is dropped by a slave without special telegrams (A 5.4).
        assert await bus.request(Telegram(5, AddressMode.SPECIAL, bytes(10))) is None
        assert await bus.request(Telegram(6, AddressMode.NORMAL, bytes(10))) is None
        assert await bus.request(Telegram(0, AddressMode.BROADCAST, bytes(14))) is None
        await asyncio.sleep(0)


async def test_a_rate_the_line_cannot_be_opened_at_is_left_out() -> None:
    async with simulated_bus([(3, "generic", Layout(4, 2))], baud=19200) as env:
        await env.master.close()
        host, port = await env.bus.serve_tcp(framed=True)  # bus:// runs at 19200 only
        url = f"bus://{host}:{port}"
        notes: list[tuple[int, str]] = []
        found = await scan(
            lambda baud: open_transport(url, baud=baud),
            [9600, 19200, 38400],
            [2, 3],
            skipped=lambda baud, exc: notes.append((baud, str(exc))),
            latency=0.05,  # bus:// between tasks of a loaded machine: a margin for the answer
        )
        assert [(f.address, f.baud, f.layout) for f in found] == [(3, 19200, Layout(4, 2))]
        assert [baud for baud, _ in notes] == [9600, 38400]
        assert "19200" in notes[0][1]
        with pytest.raises(TransportError, match="19200"):  # no rate at all: the error
            await scan(lambda baud: open_transport(url, baud=baud), [9600], [3])


async def test_drives_are_reported_as_found_and_identify_asks_them_on_the_open_line() -> None:
    drives = [(4, "generic", Layout(3, 2)), (11, "generic", Layout(4, 2))]
    async with simulated_bus(drives, baud=38400) as env:
        await env.master.close()
        events: list[tuple[str, int]] = []
        asked: list[int] = []

        async def identify(bus: Master, found: Found) -> Found:
            value = await bus.drive(found.address, layout=found.layout, poll=False).read(52)
            asked.append(value)
            events.append(("identified", found.address))
            return dataclasses.replace(found, status=0xBEEF)

        def progress(p: Progress) -> None:
            if p.done == 27:  # 0..3: 24 probes, 4: 2 (its layout, the variable check), 5: 1
                events.append(("probe", p.done))

        found = await scan(
            lambda baud: env.bus.attach("scanner"),
            [38400],
            range(16),
            on_progress=progress,
            on_found=lambda f: events.append(("found", f.address)),
            identify=identify,
        )
    assert [f.address for f in found] == [4, 11]
    assert all(f.status == 0xBEEF for f in found)  # what identify returned is reported
    assert asked == [0x4000, 0x4000]  # P52 read through the scanning master
    # address 4 was reported before the probes of the addresses after it
    assert events.index(("found", 4)) < events.index(("probe", 27))
    assert events.index(("identified", 4)) < events.index(("found", 4))


async def test_first_stops_at_the_first_drive() -> None:
    drives = [(4, "generic", Layout(3, 2)), (11, "generic", Layout(3, 2))]
    async with simulated_bus(drives, baud=38400) as env:
        await env.master.close()
        seen: list[Progress] = []
        found = await scan(
            lambda baud: env.bus.attach("scanner"),
            [38400, 9600],
            range(32),
            on_progress=seen.append,
            first=True,
        )
    assert [(f.address, f.baud) for f in found] == [(4, 38400)]
    # addresses 0..3 with six layouts each, then 4: its layout and the variable-length check
    assert seen[-1].done == 4 * 6 + 2


async def test_progress_estimates_the_time_left_from_the_wire_time() -> None:
    async with simulated_bus([(1, "generic", Layout(3, 2))], baud=187500) as env:
        await env.master.close()
        seen: list[Progress] = []
        found = await scan(
            lambda baud: env.bus.attach("scanner"), [187500], range(4), on_progress=seen.append
        )
    first, last = seen[0], seen[-1]
    assert first.left is not None and first.left > 0
    assert last.left == 0 and last.done == last.total
    # a silent probe: its request, the start pause (2 characters) and the 20 ms window;
    # address 1 answers the first (14 + 14 characters, the start pause and its turnaround)
    # and stays silent to the variable-length check (PKW 4: 16 characters)
    ct = 11 / 187500
    lengths = [layout.lge + 2 for layout in probe_layouts(get_profile("generic"))]
    silent_address = sum((n + 2) * ct + 0.020 for n in lengths)
    address_1 = (14 + 2 + 14) * ct + found[0].response_time + (16 + 2) * ct + 0.020
    assert last.wire == pytest.approx(3 * silent_address + address_1, rel=0.01)
