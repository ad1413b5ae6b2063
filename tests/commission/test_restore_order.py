"""Restores in the drive's order, against simulated drives on the virtual bus: motor data that
only quick commissioning may change are written inside the drive's own P0010 rule; arrays
read element by element on a fixed layout with progress; the progress line itself."""

from __future__ import annotations

import io
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from pyuss.bus import VirtualBus
from pyuss.cli._params import Progress
from pyuss.commission.backup import Backup, read_parameters, take
from pyuss.commission.compare import plan, restore
from pyuss.master import ACYCLIC, Drive, Master
from pyuss.master.testing import simulated_drives
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import RequestId


@asynccontextmanager
async def drive_of(profile: str, layout: Layout | None = None) -> AsyncIterator[Drive]:
    bus = VirtualBus(38400)
    try:
        async with (
            simulated_drives(bus, [(1, profile, layout)]),
            Master(bus.attach("master"), profile=profile, mode=ACYCLIC, layout=layout) as master,
        ):
            yield master.drive(1)
    finally:
        await bus.close()


async def test_motor_data_are_restored_inside_quick_commissioning() -> None:
    async with drive_of("sinamics-v20") as drive:
        saved = await take(drive)
        assert await drive.write(10, 1) == 1  # quick commissioning
        await drive.write(304, 380, 0)  # rated motor voltage, changeable in commissioning only
        await drive.write(1120, 3.0, 0)
        assert await drive.write(10, 0) == 0
        now = await read_parameters(drive, [(e.pnu, e.index) for e in saved.entries])
        writes, skips = plan(saved, Backup(1, "sinamics-v20", now), drive.params, drive.profile)
        labels = [w.label for w in writes]
        assert (
            labels.index("P0010")
            < labels.index("P0304.0")
            < len(labels) - labels[::-1].index("P0010") - 1
        )
        assert [w.value for w in writes if w.pnu == 10] == [1, 0]
        outcomes = await restore(drive, writes)
        assert all(o.ok for o in outcomes), [o.text() for o in outcomes if not o.ok]
        assert await drive.read(304, 0) == saved.find(304).value[0]  # type: ignore[union-attr]
        assert await drive.read(1120, 0) == saved.find(1120).value[0]  # type: ignore[union-attr]
        assert await drive.read(10) == 0  # the drive is out of commissioning again
        assert all(s.entry.pnu not in (10, 3900, 970) for s in skips)


async def test_an_array_on_a_fixed_layout_is_read_element_by_element_with_progress() -> None:
    async with drive_of("micromaster4", Layout(4, 2)) as drive:
        seen: list[tuple[int, int]] = []
        reading = await drive.read_param(
            947, progress=lambda done, total: seen.append((done, total))
        )
        assert reading.value == [0] * 8 and reading.index is None
        assert seen == [(n, 8) for n in range(1, 9)]
        jobs = drive.diagnostics().jobs
        assert jobs.completed == 8  # no IND 255 on a fixed layout (C 4.2.2)


async def test_an_array_refused_whole_is_read_element_by_element() -> None:
    async with drive_of("micromaster4", Layout(127, 2)) as drive:
        real_job = drive.job

        async def no_whole_arrays(request, **kw):  # type: ignore[no-untyped-def]
            if request.id == RequestId.READ_ARRAY and request.index & 0xFF == 255:
                from pyuss.errors import DriveRefusal

                raise DriveRefusal(3, "wrong index", pnu=request.pnu, index=255)
            return await real_job(request, **kw)

        drive.job = no_whole_arrays  # type: ignore[method-assign]
        assert await drive.read(947) == [0] * 8


def test_the_progress_line_counts_and_estimates() -> None:
    out = io.StringIO()
    bar = Progress("backup", stream=out, enabled=True)
    bar(0, 4)
    bar(2, 4)
    bar(4, 4)
    bar.close()
    text = out.getvalue()
    assert "\rbackup [" in text and "2/4 ETA" in text and "4/4" in text and text.endswith("\n")
    quiet = io.StringIO()
    Progress("backup", stream=quiet)(1, 2)  # not a terminal: nothing
    assert quiet.getvalue() == ""
