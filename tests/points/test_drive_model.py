"""The live-drive model on a virtual bus with simulated drives: a setpoint is checked once,
whole, before anything is sent (a refused one changes nothing), the commands come from one
table, process data become values in one place, and the reference is read anew when a face
writes it."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import math
import statistics
import time
from collections.abc import AsyncIterator

import pytest

from pyuss.bus import VirtualBus
from pyuss.errors import ConfigError, UssError
from pyuss.points import (
    COMMAND_TABLE,
    MOVES,
    DrivePoints,
    NotInControl,
    Plant,
    PlantModel,
    checked_setpoint,
    error_dict,
    line_model,
    simulated_drives,
)
from pyuss.points.drive import JOG_GRACE
from pyuss.points.plant import HEALTH_PERIOD
from pyuss.points.state import DriveState
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import Telegram
from pyuss.protocol.timing import start_pause
from pyuss.slave import SlaveEngine
from support.buses import scripted_bus
from support.line import LineRecord
from support.waiting import eventually

BAUD = 38400
DRIVES = [(1, "generic", Layout(4, 2)), (4, "baumueller", Layout(3, 2))]


@pytest.fixture
async def plant() -> AsyncIterator[Plant]:
    bus = VirtualBus(BAUD)
    try:
        async with simulated_drives(bus, DRIVES):
            model = line_model("line", DRIVES, baud=BAUD)
            plant = Plant(model, transports={"line": bus.attach("master")})
            async with plant:
                await eventually(lambda: all(d.state.answered for d in plant.drives))
                await eventually(lambda: plant.drive("line", 1).reference is not None)
                yield plant
    finally:
        await bus.close()


def sent(points: DrivePoints) -> tuple[int, tuple[int, ...]]:
    return points.drive.control, points.drive.setpoints


async def test_a_setpoint_is_checked_whole_and_a_refused_one_changes_nothing(
    plant: Plant,
) -> None:
    drive = plant.drive("line", 1)
    assert (drive.reference, drive.model.unit) == (50.0, "Hz")
    assert drive.setpoint_units() == ("%", "Hz")
    # the same setpoint three ways: in the reference's unit, in percent, raw
    for value, unit in ((25, "Hz"), ("25", "value"), (50.0, "%"), ("0x2000", "raw")):
        checked = drive.check_setpoint(value, unit=unit)
        assert (checked.raw, checked.percent, checked.value) == (0x2000, 50.0, 25.0)
    before = sent(drive)
    for value, unit, words in [
        (500, "%", "500 % is outside -200 % .. 199.99 % of the reference (16 bits, C 5.2.2)"),
        (100, "Hz", "100 Hz is outside"),  # 200 % of 50 Hz: one step beyond the word
        (10**400, "Hz", "is outside"),
        (10**400, "raw", "does not fit 16 bits"),
        (1.5, "raw", "whole number"),
        (math.nan, "%", "finite number"),
        (math.inf, "Hz", "finite number"),
        ("-inf", "%", "finite number"),
        ("fast", "%", "'fast' is not a number"),
        ("1" * 65, "%", "is not a number"),
        (True, "%", "finite number"),
        (None, "%", "finite number"),
        ([25], "%", "finite number"),
        (25, "rpm", "setpoint unit 'rpm': line/drive1 takes '%' or 'Hz' or 'raw'"),
    ]:
        with pytest.raises(ConfigError, match=words.replace("(", r"\(").replace(")", r"\)")):
            await drive.set_setpoint(value, unit=unit)
    assert sent(drive) == before  # nothing reached the line
    await drive.set_setpoint("20", unit="Hz")
    assert drive.drive.setpoints == (round(0x4000 * 0.4),)
    assert drive.setpoint_value() == pytest.approx(20.0, abs=0.01)


async def test_the_commands_come_from_one_table(plant: Plant) -> None:
    drive = plant.drive("line", 1)
    assert set(COMMAND_TABLE) == {"on", "off1", "off2", "off3", "acknowledge", "jog1", "jog2",
                                  "jog_off"}  # fmt: skip
    assert {"on", "jog1", "jog2"} == MOVES
    before = sent(drive)
    for name in ("reverse", "", 5, None):
        with pytest.raises(ConfigError, match="unknown command"):
            await drive.command(name)  # type: ignore[arg-type]
    assert sent(drive) == before
    await drive.command("jog1")
    assert drive.drive.control & 0x0100
    await drive.command("jog_off")
    assert not drive.drive.control & 0x0300
    state = await drive.command("off1")
    assert state.state in ("ready to switch on", "switch-on inhibited")


async def switched_on_and_left(bus: VirtualBus, model: PlantModel) -> None:
    """A master switches drive 1 on at 50 % and goes away (a gateway stopped), the drive
    running on."""
    async with Plant(model, transports={"line": bus.attach("first")}) as first:
        drive = first.drive("line", 1)
        await eventually(lambda: drive.state.answered)
        await drive.set_setpoint(50, unit="%")
        await drive.command("on")
        await eventually(lambda: drive.state.state == "operation enabled")


async def test_a_master_started_again_changes_no_running_drive_nobody_asked_to_change() -> None:
    """A gateway or page started again sends 0000h (no control by the interface) until a
    command, so the drive runs on with what it had. An acknowledge or a jog then would
    start from 047Eh, OFF1, and stop it; an ON would set it to setpoint 0, which nobody set
    here: refused, nothing sent. ON once the setpoint was set, and OFF1, are taken."""
    bus = VirtualBus(BAUD)
    try:
        async with simulated_drives(bus, DRIVES[:1]) as engines:
            machine = engines[1].drive.machine
            model = line_model("line", DRIVES[:1], baud=BAUD)
            await switched_on_and_left(bus, model)
            async with Plant(model, transports={"line": bus.attach("again")}) as again:
                drive = again.drive("line", 1)
                await eventually(lambda: drive.state.answered)
                assert drive.state.state == "operation enabled"  # 0000h stopped nothing
                for name, words in [
                    ("acknowledge", "acknowledge refused: the drive is switched on"),
                    ("jog1", "would take control with OFF1"),
                    ("jog2", "would take control with OFF1"),
                    ("jog_off", "would take control with OFF1"),
                    ("on", "on refused: .* with setpoint main 0, which nobody set here"),
                ]:
                    with pytest.raises(NotInControl, match=words):
                        await drive.command(name)
                assert error_dict(NotInControl("x"))["class"] == "refused"
                for request in (  # ON in a control word of the face's own: the same
                    drive.set_control_word(0x047F),
                    drive.set_process(control=0x057E),
                ):
                    with pytest.raises(NotInControl, match=r"control word 0[0-9A-F]{3}h refused"):
                        await request
                record = LineRecord(engines[1])
                await record.telegrams()
                record.close()
                assert {words[0] for words in record.pzd} == {0}  # nothing of them went out
                assert (machine.control, machine.setpoint) == (0x047F, 0.5)
                assert drive.state.state == "operation enabled"
                await drive.set_process(control=0x047F, words={2: 0x1000})  # with its setpoint
                assert (machine.control, machine.setpoint) == (0x047F, 0.25)
                await drive.set_setpoint(75, unit="%")
                await drive.command("on")  # the setpoint set here: taken, it runs on
                assert (machine.control, machine.setpoint) == (0x047F, 0.75)
                await drive.command("off1")
                await eventually(lambda: drive.state.state == "ready to switch on")
                await drive.command("acknowledge")  # in control now: only the edge of bit 7
                assert drive.drive.control == 0x047E
            # a drive that is not switched on cannot be stopped: what a new master sends acts
            machine.raise_fault(65, machine.time)
            async with Plant(model, transports={"line": bus.attach("third")}) as third:
                drive = third.drive("line", 1)
                await eventually(lambda: drive.state.state == "fault")
                await drive.command("acknowledge")
                await eventually(lambda: drive.state.state != "fault")
            async with Plant(model, transports={"line": bus.attach("fourth")}) as fourth:
                drive = fourth.drive("line", 1)
                await eventually(lambda: drive.state.answered)
                await drive.command("on")  # ready to switch on: ON at setpoint 0 moves nothing
                assert machine.control == 0x047F
    finally:
        await bus.close()


async def test_process_words_are_checked_whole_and_a_refused_request_changes_nothing(
    plant: Plant,
) -> None:
    drive = plant.drive("line", 1)  # layout 4,2: PZD2 is its one setpoint word
    before = sent(drive)
    for control, words, message in [
        (0x047F, {2: 0x1000, 3: 1}, "PZD3 is not in layout 4,2"),
        (None, {2: 0x1000, 3: 1}, "PZD3 is not in layout 4,2"),
        (0x047F, {2: 0x10000}, "PZD2 must be a 16-bit value"),
        (None, {2: 0x1000, "3": 1}, "PZD number must be a whole number"),
        (None, {2: True}, "PZD2 must be a 16-bit value"),
        (0x10000, {2: 0x1000}, "control word must be 0..65535"),
    ]:
        with pytest.raises(ConfigError, match=message):
            await drive.set_process(control=control, words=words)  # type: ignore[dict-item]
        assert sent(drive) == before  # no part of it reaches the line
    await drive.set_process(words={2: 0x1000})
    assert sent(drive) == (before[0], (0x1000,))


@contextlib.asynccontextmanager
async def jogging() -> AsyncIterator[tuple[DrivePoints, SlaveEngine]]:
    """A simulated MICROMASTER 4 at address 3 jogging (JOG1) by a plant's command, and its
    slave engine."""
    drives = [(3, "micromaster4", None)]
    bus = VirtualBus(BAUD)
    try:
        async with simulated_drives(bus, drives) as engines:
            model = line_model("line", drives, baud=BAUD)
            async with Plant(model, transports={"line": bus.attach("master")}) as plant:
                drive = plant.drive("line", 3)
                await eventually(lambda: drive.state.answered)
                await drive.command("off1")
                await drive.command("jog1")
                await eventually(lambda: engines[3].drive.machine.state.name == "JOG")
                yield drive, engines[3]
    finally:
        await bus.close()


@pytest.mark.parametrize("lost", ["fault", "power"])
async def test_a_jog_a_fault_or_a_lost_drive_ended_does_not_start_again_by_itself(
    lost: str,
) -> None:
    """A MICROMASTER 4 jogs from "ready to switch on" while its jog bit is set. A fault, or
    the drive lost (a power cut), ends the jog: the master drops the jog bit, so the
    acknowledge of the fault, or the drive back from its power cut, does not set the motor
    turning again - which the standing bit did, nobody asking."""
    async with jogging() as (drive, engine):
        if lost == "fault":
            machine = engine.drive.machine
            machine.raise_fault(7, machine.time)
            await eventually(lambda: drive.state.state == "fault")
            await eventually(lambda: not drive.drive.control & 0x0300)
            await drive.command("acknowledge")
        else:
            handle = engine.handle
            engine.handle = lambda telegram, now: None  # type: ignore[method-assign]
            await eventually(lambda: drive.drive.not_sending)
            await eventually(lambda: not drive.drive.control & 0x0300)
            engine.drive.machine = type(engine.drive.machine)(
                engine.drive.machine.time, engine.drive.machine.motion
            )  # powered up again
            engine.handle = handle  # type: ignore[method-assign]
            await eventually(lambda: not drive.drive.not_sending)
        record = LineRecord(engine)
        await record.telegrams()
        record.close()
        machine = engine.drive.machine
        assert machine.state.name in ("SWITCH_ON_INHIBIT", "READY_TO_SWITCH_ON")
        assert not drive.snapshot().told_to_run


async def test_one_answer_lost_on_a_noisy_line_does_not_stop_a_jog() -> None:
    """A jog ends when the drive is silent long enough to have lost its power (0.2 s), not at
    the first answer lost: on a noisy line (or a busy laptop) a jog would stop every few
    seconds otherwise."""
    async with jogging() as (drive, engine):
        handle = engine.handle
        dropped: list[bool] = []

        def drop_one(telegram: Telegram, now: float) -> Telegram | None:
            if not dropped:
                dropped.append(True)
                return None
            return handle(telegram, now)

        engine.handle = drop_one  # type: ignore[method-assign]
        await eventually(lambda: drive.drive.missed == 1)
        await eventually(lambda: drive.drive.missed == 0)
        await asyncio.sleep(2 * JOG_GRACE + HEALTH_PERIOD)
        assert drive.drive.control & 0x0100, "the jog bit stays set"
        assert engine.drive.machine.state.name == "JOG"


async def test_process_data_a_request_did_not_get_through_with_do_not_act_later() -> None:
    """A control word or setpoint whose request failed - the master not started yet (a
    gateway's face listens before its bus starts), or the drive not answering - is taken
    back: the master sends the words of before, so the drive that answers again later does
    not start on a request its client was told failed."""
    drives = DRIVES[:1]
    bus = VirtualBus(BAUD)
    try:
        async with simulated_drives(bus, drives) as engines:
            engine = engines[1]
            model = line_model("line", drives, baud=BAUD, job_timeout=0.3)
            plant = Plant(model, transports={"line": bus.attach("master")})
            drive = plant.drive("line", 1)
            with pytest.raises(UssError, match="not started"):
                await drive.set_control_word(0x047E)
            with pytest.raises(UssError, match="not started"):
                await drive.set_setpoint(50, unit="%")
            assert sent(drive) == (0, (0,))
            async with plant:
                await eventually(lambda: drive.state.answered)
                await drive.command("off1")
                await eventually(lambda: drive.state.state == "ready to switch on")
                handle = engine.handle
                engine.handle = lambda telegram, now: None  # type: ignore[method-assign]
                # offline, the drive is given back: 0000h, the words before each request below
                await eventually(lambda: not drive.state.online)
                assert sent(drive) == (0, (0,))
                for request in (
                    drive.set_control_word(0x047F),
                    drive.set_setpoint(50, unit="%"),
                    drive.set_process(control=0x047F, words={2: 0x2000}),
                    drive.command("on"),
                ):
                    with pytest.raises(UssError, match="no answer"):
                        await request
                    assert sent(drive) == (0, (0,))
                engine.handle = handle  # type: ignore[method-assign]
                record = LineRecord(engine)
                await record.telegrams()
                record.close()
                assert set(record.pzd) == {(0, 0)}
                assert drive.state.state == "ready to switch on"
    finally:
        await bus.close()


async def test_the_drive_handle_refuses_to_acknowledge_a_running_drive_it_does_not_control() -> (
    None
):
    """What the points refuse (`NotInControl`), the master's own acknowledge refuses too:
    ``uss ack`` on a line whose drive a gateway, stopped since, left running sent 04FEh,
    047Eh, and the motor ramped down."""
    bus = VirtualBus(BAUD)
    try:
        async with simulated_drives(bus, DRIVES[:1]) as engines:
            model = line_model("line", DRIVES[:1], baud=BAUD)
            await switched_on_and_left(bus, model)
            async with Plant(model, transports={"line": bus.attach("ack")}) as again:
                handle = again.drive("line", 1).drive
                await handle.next_update()
                for command in (handle.acknowledge(), handle.jog(1), handle.enable()):
                    with pytest.raises(NotInControl, match="refused: the drive is switched on"):
                        await command
                assert handle.control == 0  # nothing taken over
                await handle.next_update()
                assert engines[1].drive.machine.control & 0x0001  # still ON
    finally:
        await bus.close()


async def test_process_data_become_values_in_one_place(plant: Plant) -> None:
    drive = plant.drive("line", 1)
    drive.keep_samples(100)
    await drive.set_setpoint(30, unit="Hz")
    await drive.command("on")
    await eventually(lambda: (drive.state.actual["main"].value or 0) > 5)
    state = drive.state
    main = state.actual["main"]
    assert main.value == pytest.approx(main.percent * 50.0 / 100, abs=1e-6)
    assert drive.actual_row(state.actual_words)[0] == pytest.approx(main.value, abs=1e-6)
    assert [c["unit"] for c in drive.actual_columns()][:1] == ["Hz"]
    samples = drive.take_samples()
    assert samples and all(len(s.values) == len(state.actual_words) for s in samples)
    await drive.command("off1")
    # a drive without a reference parameter shows percent
    other = plant.drive("line", 4)
    assert other.reference is None and other.model.unit == "%"
    assert other.check_setpoint(12.5, unit="value").value == 12.5


async def test_the_reference_is_read_anew_when_a_face_writes_it(plant: Plant) -> None:
    drive = plant.drive("line", 1)
    checked = drive.check_setpoint(10, unit="Hz")
    await drive.write_value(51, None, "EXPERT")
    await drive.write_value(352, None, "100")
    try:
        assert drive.reference == 100.0
        # 10 Hz is 10 % now, where it was 20 %
        assert checked.percent == pytest.approx(20.0, abs=0.01)
        assert drive.check_setpoint(10, unit="Hz").percent == pytest.approx(10.0, abs=0.01)
    finally:
        await drive.write_value(352, None, "50")
        await drive.write_value(51, None, "STANDARD")
    assert drive.reference == 50.0
    # a typed write is checked before anything is sent
    jobs = drive.drive.diagnostics().jobs
    done = jobs.completed + jobs.refused
    with pytest.raises(ConfigError, match="outside"):
        await drive.write_value(462, None, "1000")
    with pytest.raises(ConfigError, match="short text"):
        await drive.write_value(462, None, "1" * 400)
    jobs = drive.drive.diagnostics().jobs
    assert jobs.completed + jobs.refused == done


def test_the_one_check_of_a_setpoint_serves_every_face_alike() -> None:
    # uss run --setpoint and the faces share it: a double word, an unknown reference
    wide = checked_setpoint("150", "percent", reference=None, unit="%", dword=True)
    assert (wide.raw, wide.percent) == (0x6000_0000, 150.0)
    with pytest.raises(ConfigError, match=r"outside -200 % \.\. 199\.9999999 % .*32 bits"):
        checked_setpoint(200, "percent", reference=None, unit="%", dword=True)
    with pytest.raises(ConfigError, match="reference is not known yet"):
        checked_setpoint(25, "value", reference=None, unit="Hz", where="line/drive1")
    assert checked_setpoint(25, "value", reference=50.0, unit="Hz").raw == 0x2000


@pytest.mark.parametrize(
    ("text", "kind", "raw"),
    [
        ("25", "percent", 0x1000),
        (" -12.5 ", "percent", -0x800),
        ("1e1", "percent", 0x666),
        (".5", "percent", 82),
        ("0x2000", "raw", 0x2000),
        ("-0x10", "raw", -16),
        ("16384", "raw", 0x4000),
    ],
)
def test_a_setpoint_as_text_is_read_as_written(text: str, kind: str, raw: int) -> None:
    assert checked_setpoint(text, kind, reference=None, unit="%").raw == raw


@pytest.mark.parametrize(
    ("text", "kind", "words"),
    [
        # 0x10 % would be 16 %: who types hexadecimal means the word itself (0.1 %)
        ("0x10", "percent", "hexadecimal number is taken as a raw word only"),
        ("0x10", "value", "hexadecimal number is taken as a raw word only"),
        ("1_0", "percent", "is not a number"),  # Python's digit grouping: 10
        ("0b101", "raw", "is not a number"),
        ("0o17", "raw", "is not a number"),
        ("\u0661\u0662", "percent", "is not a number"),  # Arabic-Indic digits: 12 to float()
        ("\uff11\uff10", "percent", "is not a number"),  # full-width digits
        ("nan", "percent", "finite number"),
        ("-Infinity", "percent", "finite number"),
        ("1e400", "percent", "finite number"),
    ],
)
def test_a_setpoint_as_text_is_refused_where_it_could_be_misread(
    text: str, kind: str, words: str
) -> None:
    with pytest.raises(ConfigError, match=words):
        checked_setpoint(text, kind, reference=None, unit="%")


async def test_every_face_gets_the_refusal_with_what_to_do(plant: Plant) -> None:
    """The faces' one error shape (`error_dict`: the MQTT reply's ``error``, the page's) keeps
    its keys; its message carries the family's hint (Baumueller: P126)."""
    from pyuss.master import NoWriteAuthority
    from pyuss.points.errors import error_dict

    points = plant.drive("line", 4)
    await points.drive.write_raw(126, (0,))  # the communication interfaces may not change
    try:
        with pytest.raises(NoWriteAuthority) as denied:
            await points.write_value(60, None, "1")
        error = error_dict(denied.value)
        assert set(error) == {"type", "message", "class", "response_id", "pnu"}
        assert (error["type"], error["class"], error["pnu"]) == (
            "NoWriteAuthority",
            "no_authority",
            60,
        )
        assert error["message"].endswith(
            ": set bit 0 of P126 (communication source) so that the "
            "communication interfaces may change parameters "
            "(Baumueller manual 1.5)"
        )
    finally:
        await points.drive.write_raw(126, (1,))


async def test_the_fault_panel_shows_when_a_micromaster_440_tripped() -> None:
    """MICROMASTER 440 r0948 holds three words a trip (seconds high, low, 0) for the two fault
    numbers a trip has in r0947: the panel gives each fault its trip's time."""
    from pyuss.points.view import fault_panel

    drives = [(7, "micromaster440", None)]
    bus = VirtualBus(BAUD)
    try:
        async with simulated_drives(bus, drives) as engines:
            drive = engines[7].drive
            drive.update(947, 3, 2)  # the trip before the last: F0003 at 70000 s
            drive.update(948, 1, 3)
            drive.update(948, 70000 - 65536, 4)
            model = line_model("line", drives, baud=BAUD)
            async with Plant(model, transports={"line": bus.attach("master")}) as plant:
                await eventually(lambda: plant.drive("line", 7).state.answered)
                panel = await fault_panel(plant.drive("line", 7))
    finally:
        await bus.close()
    assert panel["parameters"]["times"] == 948
    assert [(f["index"], f["number"], f["time"]) for f in panel["history"]] == [(2, 3, 70000)]


async def test_what_the_faces_do_with_an_answer_keeps_no_telegram_off_the_line() -> None:
    # A face's work on a drive's new state (a state built, a message published, nodes
    # written) is done while the master's next telegram is on the line, not before it: the
    # start pause stays that of A 5.1.2, however long the faces take, and the bus keeps its
    # pace with every face attached.
    baud = 9600
    pause = start_pause(baud)  # 2.3 ms
    busy = 0.005  # each new state costs its subscriber twice the start pause
    async with scripted_bus((1, 2), baud=baud, layout=Layout(3, 2), record=True) as env:
        told: list[int] = []

        def slow(state: DriveState) -> None:
            end = time.perf_counter() + busy
            while time.perf_counter() < end:
                pass
            told.append(state.model.address)
            slave = env.slaves[state.model.address]
            slave.actual = (slave.actual + 1) & 0xFFFF  # its next answer is a new state

        points = [DrivePoints.around(env.master.drive(a)) for a in (1, 2)]
        for drive in points:
            drive.subscribe(slow)
        await eventually(lambda: len(told) >= 20, timeout=20)
        for drive in points:
            drive.close()
    assert env.recorder is not None
    gaps = [
        cur.start - prev.t
        for prev, cur in itertools.pairwise(env.recorder.records)
        if cur.sender == "master" and prev.sender != "master" and cur.byte == 0x02
    ]
    assert len(gaps) >= 20
    assert min(gaps) >= pause - 1e-9
    # the subscribers' 5 ms are not in the pauses (a loaded machine may be late now and then)
    assert statistics.median(gaps) < pause + 0.001
