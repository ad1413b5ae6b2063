"""The page's data access: the master's own traffic decoded for the monitor view, the scan,
values in units, parameters typed through `pyuss.params`, backup, compare and restore through
`pyuss.commission`."""

from __future__ import annotations

import asyncio
import contextlib
import re
from collections.abc import AsyncIterator

import pytest

from pyuss.bus import VirtualBus
from pyuss.commission.backup import loads as load_text
from pyuss.errors import ConfigError, UssError
from pyuss.master.testing import simulated_drives
from pyuss.params.words import WordKind, format_word
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.web.backend import Backend, DriveSpec
from support.limits import limit_writes
from support.waiting import eventually


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
        assert [(f["address"], f["layout"]) for f in found] == [
            (1, "v,2"),
            (4, "3,2"),
            (7, "v,2"),
            (9, "v,2"),
        ]
        assert progress[-1][0] == progress[-1][1] and len(progress) > 10
        assert backend.addresses() == [1, 4, 7, 9]
        assert [d["profile"] for d in backend.bus()["drives"]] == [
            "generic",
            "baumueller",
            "micromaster440",
            "sinamics-v20",
        ]
        # the master runs again after the scan
        status = await backend.command(1, "off1")
        assert status["state"]
    finally:
        await backend.close()


async def test_a_scan_is_refused_while_a_drive_is_switched_on() -> None:
    # the scan stops the telegrams to every drive, and with them the page's only way of
    # stopping one: while a drive is told to run, or runs, it is refused and changes nothing
    backend = Backend(demo=True)
    await backend.start()
    try:
        await backend.command(1, "on")
        with pytest.raises(ConfigError, match="drive 1 is switched on: switch it off"):
            await backend.scan(range(10))
        assert backend.scan_progress is None and backend.addresses() == [1, 4, 7, 9]
        assert backend.points(1).snapshot().control_word & 1  # still told to run, still heard
        await backend.command(1, "off1")
        await eventually(lambda: not backend.points(1).snapshot().running, what="drive 1 stopped")
        found = await backend.scan([1, 4])
        assert [f["address"] for f in found] == [1, 4]
    finally:
        await backend.close()


async def test_setpoints_in_the_reference_unit() -> None:
    backend = Backend(demo=True)
    await backend.start()
    try:
        assert backend.drive_info(1)["reference"] == {"value": 50.0, "unit": "Hz"}
        points = backend.points(1)
        assert points.check_setpoint("25", unit="Hz").percent == 50.0
        assert points.check_setpoint(30, unit="%").raw == round(0x4000 * 0.3)
        checked = backend.check(1, "setpoint", {"value": "10", "unit": "Hz"})
        assert checked["text"] == "set the setpoint to 10 Hz (20 % of the reference)"
        assert points.drive.setpoints == (0,)  # a check sends nothing
        await backend.command(1, "setpoint", {"value": "10", "unit": "Hz"})
        assert points.drive.setpoints == (round(0x4000 * 0.2),)
        assert abs((points.setpoint_value() or 0) - 10.0) < 0.01
    finally:
        await backend.close()


async def test_the_expert_list_and_edits_go_through_the_parameter_model() -> None:
    backend = Backend(demo=True)
    await backend.start()
    try:
        rows = {r["id"]: r for r in backend.parameters(7)}
        ramp = rows["1120.0"]  # MICROMASTER 440: one ramp-up time per data set
        assert (ramp["name"], ramp["unit"], ramp["type"]) == ("Ramp-up time", "s", "float")
        assert (ramp["min"], ramp["max"], ramp["writable"]) == ("0.00", "650.00", True)
        assert "2010.0" in rows and "2010.1" in rows  # MICROMASTER 4 counts from 0
        assert rows["2010.1"]["texts"]["7"] == "19200 baud"
        assert not rows["52"]["writable"]  # a bit field: raw words only
        # typed as the manual writes them: a time in another unit, a value text
        assert (await backend.write(7, 1120, 0, "1500 ms"))["value"] == "1.50 s"
        assert (await backend.write(7, 2010, 1, "19200 baud"))["value"] == "7 [19200 baud]"
        assert (await backend.read(7, [(2010, 1)]))[0]["input"] == "7"
        await backend.write(7, 2010, 1, "9600 baud")
        # refused before anything is sent: no job reaches the drive
        jobs = backend.points(7).drive.diagnostics().jobs
        before = jobs.completed + jobs.refused
        for pnu, index, text, words in [
            (1120, 0, "700", "outside 0.00..650.00 s"),
            (1120, 0, "fast", "not a number"),
            (1120, 0, "2 Hz", "unit 'Hz' does not fit"),
            (2010, 1, "0x2", "outside 3..12"),
            (21, None, "5", "read-only"),
            (52, None, "1", "read-only"),
        ]:
            try:
                await backend.write(7, pnu, index, text)
            except ConfigError as exc:
                assert words in str(exc), (text, str(exc))
            else:
                raise AssertionError(f"{text!r} for P{pnu} was not refused")
        jobs = backend.points(7).drive.diagnostics().jobs
        assert jobs.completed + jobs.refused == before
    finally:
        await backend.close()


async def test_backup_compare_and_restore_are_those_of_uss_backup() -> None:
    backend = Backend(demo=True)
    await backend.start()
    engine = backend.engines[1].drive
    try:
        name, text = await backend.backup(1)
        assert name.startswith("drive1-generic-") and name.endswith(".toml")
        saved = load_text(text)
        assert saved.find(462) is not None and saved.identity[0].label == "P91"
        await backend.write(1, 462, None, "4.5")
        compared = await backend.compare(1, text.encode(), name)
        assert compared["differences"] == [
            {
                "id": "462",
                "label": "P462",
                "name": "Ramp-up time",
                "drive": "4.5 s",
                "file": "10.0 s",
            }
        ]
        assert [w["change"] for w in compared["writes"]] == ["P462 (Ramp-up time): 4.5 s -> 10.0 s"]
        assert compared["stranger"] is None and compared["refused"] is None
        # a backup of another drive (its serial number differs) needs force
        other = text.replace('value = "00 00 30 39"', 'value = "00 00 30 40"')
        # a value the parameter cannot take refuses the whole file before anything is written
        broken = text.replace("value = 10.0\n", "value = 1000.0\n")
        for data, key, words in [
            (other, "stranger", "other.toml is from another drive: P91 (Serial number)"),
            (broken, "refused", "P462: 1000.0 s is outside 0.0..999.9 s"),
        ]:
            compared = await backend.compare(1, data.encode(), "other.toml")
            assert words in compared[key]
            with pytest.raises(ConfigError, match=re.escape(words)):
                await backend.restore(1, data.encode(), "other.toml")
            assert engine.value(462) == 45
        done = await backend.restore(1, other.encode(), "other.toml", force=True)
        assert done["message"] == "drive 1: 1 of 1 written"
        assert engine.value(462) == 100
        done = await backend.restore(1, text.encode(), name)
        assert done["message"] == f"drive 1 already holds {name}: nothing to write"
        # files that are no backups: one line naming what is wrong
        for data, words in [
            (b"\xff\xfe", "not a text file"),
            (b"x = 1\n", "not a pyuss backup"),
            (text.replace("count = 30", "count = 31").encode(), "cut short"),
        ]:
            with pytest.raises(ConfigError, match=re.escape(words)):
                await backend.compare(1, data, "f.toml")
    finally:
        await backend.close()


async def test_a_value_the_layout_cannot_carry_is_not_asked_for(backend: Backend) -> None:
    # Drive 4 has the fixed layout 3,2: one PWE word, no room for its 32-bit P70.
    rows = {r["id"]: r for r in backend.parameters(4)}
    needs = "needs PKW 4 or the variable layout: its int32 value takes 2 words, layout 3,2"
    assert rows["70"]["needs"].startswith(needs)
    assert not rows["70"]["writable"]
    assert "needs" not in rows["60"]  # a 16-bit value travels
    jobs = backend.points(4).drive.diagnostics().jobs
    before = jobs.completed + jobs.refused
    (item,) = await backend.read(4, [(70, None)])
    assert item["needs"].startswith(needs) and "value" not in item and "error" not in item
    try:
        await backend.write(4, 70, None, "5")
    except ConfigError as exc:
        assert str(exc).startswith("P70 cannot be written: needs PKW 4")
    else:
        raise AssertionError("a write the layout cannot carry was sent")
    jobs = backend.points(4).drive.diagnostics().jobs
    assert jobs.completed + jobs.refused == before  # nothing reached the drive
    # A backup records why, instead of the drive's refusal.
    _, text = await backend.backup(4)
    assert 'message = "P70: needs PKW 4 or the variable layout' in text
    assert "error 103" not in text


async def test_the_ramp_state_follows_the_actual_value(backend: Backend) -> None:
    # The generic drive sets status bit 8 at once; the page says "ramping up" until the actual
    # value reaches the setpoint, and after OFF1 "ramping down" while operation stays enabled.
    await backend.write(1, 462, None, "2.0")  # ramp-up time 2 s: at 80 % after 1.6 s
    await backend.command(1, "setpoint", 80)
    reply = await backend.command(1, "on")
    assert reply["taken"] and reply["motion"] == "ramping up", reply
    seen = set()
    async with asyncio.timeout(30):
        while backend.motion(1) != "at setpoint":
            seen.add(backend.motion(1))
            await asyncio.sleep(0.05)
    # (a loaded machine may miss an answer: the drive "does not send" until the next)
    assert seen - {"does not send"} == {"ramping up"}
    reply = await backend.command(1, "off1")
    assert reply["taken"] and reply["state"] == "operation enabled"
    assert reply["motion"] == "OFF1 active, ramping down"
    assert "off1: done" in reply["text"] and "ramping down" in reply["text"]


@contextlib.asynccontextmanager
async def drive_that_stops_answering() -> AsyncIterator[Backend]:
    """A backend whose drive 5 (generic, 4,2) answered, was switched on at 50 %, ran up, and
    then stopped answering (its simulated drive left the bus)."""
    bus = VirtualBus(38400)
    backend = Backend(transport=bus.attach("master"), baud=38400, job_timeout=0.3,
                      drives=[DriveSpec(5, "generic", Layout(4, 2))])  # fmt: skip
    try:
        async with simulated_drives(bus, [(5, "generic", Layout(4, 2))]):
            await backend.start()
            await backend.command(5, "setpoint", 50)
            await backend.command(5, "on")
            await eventually(lambda: backend.motion(5) == "at setpoint", 30, what="at setpoint")
        # offline: several answers missed in a row (one missed answer is no outage)
        await eventually(lambda: not backend.points(5).snapshot().online, what="offline")
        yield backend
    finally:
        await backend.close()
        await bus.close()


async def test_a_drive_that_stops_answering_has_no_fault_history_read() -> None:
    # a fault history that could not be read is no empty one: the page must not say "none
    # recorded" (nor "no fault") of a drive that does not answer
    async with drive_that_stops_answering() as backend:
        with pytest.raises(UssError, match="drive 5 does not send"):
            await backend.faults(5)


async def test_a_drive_that_stops_answering_shows_nothing_of_before_as_current() -> None:
    # it ran at setpoint when it fell silent: neither its last status word, state, ramp
    # state nor actual value is shown as what it is now (the bus row and the JSON alike)
    async with drive_that_stops_answering() as backend:
        summary = backend.summary(5)
        assert summary["status"] is None and summary["actual"] == []
        assert summary["state"] == "does not send" and summary["motion"] == "does not send"
        assert not summary["fault"] and not summary["warning"]
        assert backend.motion(5) == "does not send"
        # nor is the control word its last answer answered in force in a drive that hears
        # nothing (its telegram monitoring may have stopped it)
        assert summary["control_in_force"] is None
        assert summary["control"] == 0  # offline, it was given back: 0000h (docs/gateway.md)
        assert backend.bus()["drives"][0]["status"] is None


def test_a_drive_in_local_operation_is_not_judged_by_the_words_the_bus_sends() -> None:
    # status bit 9 = 0: local operation only (C Table 5.5), the control word and setpoint
    # sent are not in force; a drive running so is neither "OFF1 active, ramping down" (the
    # bus sends no ON) nor "ramping down" towards a setpoint it does not take
    from pyuss.points.view import motion_of

    running_locally = 0x0037  # ready, operation enabled, no OFF2/OFF3, bit 9 = 0
    assert motion_of(running_locally, 0x047E, 50.0, 0.0) == "running (local operation)"
    assert motion_of(running_locally, 0x047F, 50.0, 20.0) == "running (local operation)"
    assert motion_of(running_locally | 0x0200, 0x047E, 50.0, 0.0).startswith("OFF1 active")


async def test_a_key_actual_value_reads_as_the_parameter_list_and_uss_read_show_it(
    backend: Backend,
) -> None:
    # r0026 of the V20: one value, one text on the page: the drive view's key actual values
    # said 565.69 V where the parameter list (and uss read) said 565.6854 V
    (listed,) = await backend.read(9, [(26, None)])
    polled = await backend.key_actuals(9)
    (dc_link,) = [v for v in polled["values"] if v["pnu"] == 26]
    assert dc_link["text"] == listed["value"] == "565.6854 V"


def test_a_drive_turning_against_its_new_setpoint_is_ramping_down() -> None:
    # at +30 % told -50 %: it slows down through standstill before it runs up the other way;
    # "ramping up" (|30| < |-50|) was said of a motor that was slowing down
    from pyuss.points.view import motion_of

    running = 0x0237  # operation enabled, bit 9: under bus control
    assert motion_of(running, 0x047F, 30.0, -50.0) == "ramping down"
    assert motion_of(running, 0x047F, -30.0, 50.0) == "ramping down"
    assert motion_of(running, 0x047F, -30.0, -50.0) == "ramping up"
    assert motion_of(running, 0x047F, -49.5, -50.0) == "at setpoint"


async def test_a_line_whose_port_failed_shows_no_drive_as_answering() -> None:
    # the port fails (a TCP adapter gone, without reconnect=1): the master stops, and the
    # page must not go on showing the drives' last answers as now
    bus = VirtualBus(38400)
    station = bus.attach("master")
    backend = Backend(transport=station, baud=38400, job_timeout=0.3,
                      drives=[DriveSpec(5, "generic", Layout(4, 2))])  # fmt: skip
    try:
        async with simulated_drives(bus, [(5, "generic", Layout(4, 2))]):
            await backend.start()
            await eventually(lambda: backend.summary(5)["status"] is not None, what="answer")
            await station.close()
            await eventually(lambda: backend.summary(5)["status"] is None, what="no status")
            summary = backend.summary(5)
            assert summary["not_sending"] and summary["actual"] == []
            assert summary["state"] == summary["offline"]
            assert summary["offline"].startswith("the line failed: ")
    finally:
        await backend.close()
        await bus.close()


async def test_whether_a_drive_that_fell_silent_took_a_command_is_not_known() -> None:
    # its telegram was answered, then the drive fell silent: its last status word (operation
    # enabled) is no "on: done"
    from pyuss.points.view import command_outcome

    async with drive_that_stops_answering() as backend:
        points = backend.points(5)
        outcome = await command_outcome(points, "on", points.snapshot(), within=0.3)
        assert not outcome.taken and "done" not in outcome.text
        assert outcome.text.startswith("on: the drive does not send (A 5.2.1.1)")


async def test_a_write_the_drive_answers_with_another_value_says_what_it_holds() -> None:
    # the drive limits P18 to 1000: the page shows what it holds, and what was written
    bus = VirtualBus(19200)
    try:
        async with simulated_drives(bus, [(5, "generic", Layout(3, 2))]) as engines:
            limit_writes(engines[5].drive, 18, 1000)
            backend = Backend(transport=bus.attach("master"), baud=19200,
                              drives=[DriveSpec(5, "generic", Layout(3, 2))])  # fmt: skip
            await backend.start()
            try:
                shown = await backend.write(5, 18, None, "5000")
                assert (shown["value"], shown["written"]) == ("1000", "5000")
                assert "written" not in await backend.write(5, 18, None, "700")
            finally:
                await backend.close()
    finally:
        await bus.close()


async def test_the_summary_spells_the_control_and_status_words(backend: Backend) -> None:
    # the words as uss read and uss status show them (pyuss.params.words), bits 11..15 by
    # the drive's family: the SINAMICS V20 of the demo
    v20 = get_profile("sinamics-v20")
    await backend.command(9, "setpoint", 10)
    reply = await backend.command(9, "on")
    assert reply["taken"], reply
    summary = backend.summary(9)
    assert summary["control_text"] == format_word(0x047F, WordKind.CONTROL, v20)
    await eventually(lambda: backend.summary(9)["control_in_force_text"] is not None)
    await eventually(lambda: backend.summary(9)["status"] is not None)
    summary = backend.summary(9)
    assert summary["status_text"] == format_word(summary["status"], WordKind.STATUS, v20)
    assert summary["control_in_force_text"] == format_word(
        summary["control_in_force"], WordKind.CONTROL, v20
    )
    await backend.command(9, "off1")
