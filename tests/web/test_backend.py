"""The page's data access: the master's own traffic decoded for the monitor view, the scan,
values in units."""

from __future__ import annotations

import asyncio

from pyuss.bus import VirtualBus
from pyuss.master.testing import simulated_drives
from pyuss.protocol.layout import Layout
from pyuss.web.backend import Backend, DriveSpec


async def test_the_monitor_sees_the_masters_own_traffic() -> None:
    bus = VirtualBus(19200)
    try:
        async with simulated_drives(bus, [(5, "generic", Layout(3, 2))]):
            backend = Backend(transport=bus.attach("master"), baud=19200,
                              drives=[DriveSpec(5, "generic", Layout(3, 2))])  # fmt: skip
            await backend.start()
            try:
                assert await backend.read(5, [(52, None)]) == [
                    {"id": "52", "value": "16384", "input": "16384"}
                ]
                async with asyncio.timeout(20):
                    while backend.last_exchange < 20:
                        await asyncio.sleep(0.05)
                items, _ = backend.exchanges_since(0, 1000)
                assert {i["address"] for i in items} == {5}
                assert any("read P52 -> P52 = 16384" in i["line"] for i in items)
                good = [i for i in items if i["kind"] == "exchange" and not i["problems"]]
                assert len(good) >= len(items) - 2
                capture = backend.pcapng()
                assert capture[:4] == b"\x0a\x0d\x0d\x0a"
            finally:
                await backend.close()
    finally:
        await bus.close()


async def test_a_scan_finds_the_drives_and_reports_progress() -> None:
    backend = Backend(demo=True)
    await backend.start()
    progress: list[tuple[int, int]] = []
    try:
        found = await backend.scan(range(10), progress=lambda d, t: progress.append((d, t)))
        assert [(f["address"], f["layout"]) for f in found] == [(1, "v,2"), (4, "3,2"), (7, "v,2")]
        assert progress[-1][0] == progress[-1][1] and len(progress) > 10
        assert backend.addresses() == [1, 4, 7]
        assert [d["profile"] for d in backend.bus()["drives"]] == [
            "generic",
            "baumueller",
            "micromaster4",
        ]
        # the master runs again after the scan
        status = await backend.command(1, "off1")
        assert status["state"]
    finally:
        await backend.close()


async def test_setpoints_in_the_reference_unit() -> None:
    backend = Backend(demo=True)
    await backend.start()
    try:
        assert backend.drive_info(1)["reference"] == {"value": 50.0, "unit": "Hz"}
        assert backend.setpoint_percent(1, {"value": "25", "unit": "Hz"}) == 50.0
        assert backend.setpoint_percent(1, 30) == 30.0
        await backend.command(1, "setpoint", {"value": "10", "unit": "Hz"})
        assert backend.master.drive(1).setpoints == (round(0x4000 * 0.2),)
        assert abs((backend.setpoint_value(1) or 0) - 10.0) < 0.01
    finally:
        await backend.close()
