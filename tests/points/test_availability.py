"""Availability in the drive model, which every face follows: one lost answer leaves a drive
online with its values stale, several in a row (the bus's ``offline_after_missed``) or a time
without an answer make it offline, and a lost line makes the bus and every drive offline at
once; a drive lost is given back (0000h), so neither its return nor the line's resends a
command nobody gave again. The faults come from the virtual bus's fault plan
(`pyuss.bus.faults`), the lost line from a TCP line whose server goes away."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import re
import tomllib
from collections.abc import AsyncIterator, Sequence

import pytest

from pyuss.bus import Fault, FaultPlan, VirtualBus
from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import ConfigError, UssError
from pyuss.gateway.registers import DriveRegisters
from pyuss.gateway.uanodes import value_status
from pyuss.master.testing import simulated_drives
from pyuss.points import NotInControl, Plant, classify, parse_plant, plant_from_flags, resolve
from pyuss.points.errors import Failure
from pyuss.points.model import MIN_SILENCE, OfflineRule
from pyuss.points.state import BusState, DriveState
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.slave import SlaveEngine, SlaveServer
from pyuss.transport.tcp import TcpServerTransport
from support.line import LineRecord
from support.network import free_port
from support.waiting import eventually

BAUD = 38400
ANSWER = 16
"""Characters of an answer of layout 4,2: STX, LGE, ADR, 6 words, BCC."""
LATER = 400
"""The answer of drive 5 the faults hit: seconds after the start, once the plant settled (at
the start, loading what the gateway reads can hold the event loop of the simulated drives
too, making answers late)."""
LOGGER = "pyuss.points"


def _first_characters(*answers: int) -> FaultPlan:
    """The fault plan that drops the first character of each of drive 5's ``answers``
    (counted from 0): each of them is no answer."""
    return FaultPlan(
        [Fault("drop", station="drive5", nth=answer * ANSWER + 1) for answer in answers]
    )


@contextlib.asynccontextmanager
async def _plant(
    bus: VirtualBus,
) -> AsyncIterator[tuple[Plant, list[DriveState], SlaveEngine]]:
    """Drive 5 (generic, 4,2) on ``bus`` behind a plant, settled (online, its reference read);
    every state it tells from then on, recorded; its simulated drive's engine."""
    config = plant_from_flags(
        port="bus://simulated:1", addresses=[5], baud=BAUD, profile="generic", layout="4,2",
        name="line",
    )  # fmt: skip
    async with simulated_drives(bus, [(5, "generic", Layout(4, 2))]) as engines:
        plant = Plant(resolve(config), transports={"line": bus.attach("gateway")})
        states: list[DriveState] = []
        async with plant:
            drive = plant.drives[0]
            await eventually(lambda: drive.state.online and drive.reference, what="settled")
            assert not bus.stats.faults, "the faults came before the plant settled"
            drive.subscribe(states.append)
            yield plant, states, engines[5]


async def _faults_over(bus: VirtualBus, count: int) -> None:
    """Wait until ``count`` faults were applied and the drive answered well since."""
    await eventually(lambda: bus.stats.faults["drop"] >= count, what="the faults")
    answers = bus.stats.chars
    await eventually(lambda: bus.stats.chars > answers + 10 * ANSWER, what="answers after")


def _around_faults(states: Sequence[DriveState], count: int) -> list[DriveState]:
    """The states from the answer the first fault hit to the first answer after the last:
    told apart from answers a loaded machine makes late by the no-STX counter the dropped
    first characters count up (A 5.2.3)."""
    first = next(i for i, s in enumerate(states) if s.health.counters.no_stx == 1)
    last = next(i for i, s in enumerate(states) if s.health.counters.no_stx == count)
    back = next(i for i in range(last, len(states)) if states[i].missed == 0)
    return list(states[first : back + 1])


def _availability_lines(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [
        r.getMessage() for r in caplog.records if r.name == LOGGER and r.levelno >= logging.WARNING
    ]


async def test_one_lost_answer_leaves_the_drive_online_its_values_stale(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    bus = VirtualBus(BAUD, faults=_first_characters(LATER))
    try:
        async with _plant(bus) as (plant, states, _):
            caplog.clear()
            await _faults_over(bus, 1)
            drive = plant.drives[0]
            await eventually(lambda: not drive.state.stale, what="live again")
    finally:
        await bus.close()
    seen = _around_faults(states, 1)
    assert seen[0].stale and seen[0].missed == 1, "the missed answer was not told"
    assert all(s.online for s in seen), "one lost answer made the drive offline"
    assert not seen[-1].stale
    # what the faces make of it: OPC UA Uncertain, Modbus register 2 bit 5 (bit 0 clear)
    assert value_status(seen[0], ".StatusWord") == "UncertainLastUsableValue"
    assert value_status(seen[-1], ".StatusWord") is None
    registers = DriveRegisters(drive)
    drive.snapshot = lambda: seen[0]  # type: ignore[method-assign]
    assert registers.input_image()[2] & 0b1100001 == 0b0100000
    if all(s.online for s in states):  # (no late answers of a loaded machine in a row)
        assert not _availability_lines(caplog)


async def test_answers_missed_in_a_row_make_it_offline_and_its_next_answer_online(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    bus = VirtualBus(BAUD, faults=_first_characters(LATER, LATER + 1, LATER + 2))
    try:
        async with _plant(bus) as (plant, states, _):
            caplog.clear()
            assert plant.bus("line").model.offline.missed == 3  # the default
            await _faults_over(bus, 3)
            await eventually(lambda: plant.drives[0].state.online, what="online again")
    finally:
        await bus.close()
    seen = _around_faults(states, 3)
    assert seen[0].stale and seen[0].missed == 1  # one missed: online, stale
    offline = [s for s in seen if not s.online]
    assert offline, "three answers missed in a row left the drive online"
    assert offline[0].missed == 3 and offline[0].answered
    assert seen[-1].online and not seen[-1].stale
    lines = _availability_lines(caplog)
    assert "line/drive5 offline: 3 answers missed in a row" in lines, lines
    # each outage one line when it begins and one when it ends (more outages only where a
    # loaded machine made answers late), nothing else
    assert len(lines) % 2 == 0 and len(lines) <= 6, lines
    for begins, ends in zip(lines[::2], lines[1::2], strict=True):
        assert begins == "line/drive5 offline: 3 answers missed in a row", lines
        assert ends.startswith("line/drive5 online again after "), lines


@pytest.mark.parametrize("meanwhile", ["ran on", "powered up again"])
async def test_a_drive_gone_offline_is_given_back_and_its_return_commands_nothing(
    meanwhile: str,
) -> None:
    # it ran at 50 % under ON (047Fh) when it stopped answering: the model gives it back
    # (0000h: no control by the interface); when it answers again it gets 0000h - it runs
    # on as it was (a drive without telegram monitoring), or stays stopped after a power
    # cut - and the takeover rules hold: an acknowledge of a running drive is refused, a
    # command or a control word with ON takes control again
    bus = VirtualBus(BAUD)
    try:
        async with _plant(bus) as (plant, _, engine):
            drive = plant.drives[0]
            await eventually(lambda: drive.reference is not None, what="the reference")
            await drive.set_setpoint(50.0, unit="percent")
            await drive.command("on")
            await eventually(lambda: drive.state.running, what="running")
            engine.handle = lambda telegram, now: None  # type: ignore[method-assign]
            await eventually(lambda: not drive.state.online, what="offline")
            assert drive.drive.control == 0 and drive.drive.setpoints == (0x2000,)
            if meanwhile == "powered up again":
                machine = engine.drive.machine
                engine.drive.machine = type(machine)(machine.time, machine.motion)
            del engine.handle  # it answers again
            await eventually(lambda: drive.state.online, what="online again")
            record = LineRecord(engine)
            await record.telegrams()
            record.close()
            assert {pzd[0] for pzd in record.pzd} == {0}  # nothing resent
            if meanwhile == "ran on":
                assert drive.state.running
                with pytest.raises(NotInControl):
                    await drive.command("acknowledge")
                await drive.set_control_word(0x047F)  # a PLC writing its word: control again
            else:
                assert not drive.state.running
                assert engine.drive.machine.state.name == "SWITCH_ON_INHIBIT"
                await drive.command("on")  # asked for, now
                await eventually(lambda: drive.state.running, what="running again")
            assert drive.drive.control == 0x047F
    finally:
        await bus.close()


class _TcpDrive:
    """Drive 5 (generic, 4,2) served on a TCP line at ``port``, as ``uss simulate --tcp``;
    `stop` takes the line away (the connection drops), `start` brings it back."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.stop_event: asyncio.Event | None = None
        self.task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        line = TcpServerTransport("127.0.0.1", self.port, baud=BAUD)
        await line.open()
        engine = SlaveEngine(
            5, SimulatedDrive.from_profile("generic"), get_profile("generic"), layout=Layout(4, 2)
        )
        self.stop_event = asyncio.Event()
        self.task = asyncio.create_task(SlaveServer(line, engine).run(self.stop_event))
        self.line = line

    async def stop(self) -> None:
        assert self.stop_event is not None and self.task is not None
        self.stop_event.set()
        self.task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self.task
        await self.line.close()


async def test_a_lost_line_makes_the_bus_and_its_drives_offline_at_once_and_back() -> None:
    port = free_port()
    line = _TcpDrive(port)
    await line.start()
    config = plant_from_flags(
        port=f"tcp://127.0.0.1:{port}", addresses=[5], baud=BAUD, profile="generic",
        layout="4,2", name="line",
    )  # fmt: skip
    plant = Plant(resolve(config))  # the port URL, reconnecting by default
    bus = plant.bus("line")
    told: list[BusState] = []
    bus.subscribe(told.append)
    assert not bus.online  # not started yet
    try:
        async with plant:
            drive = plant.drives[0]
            await eventually(lambda: drive.state.online, what="online")
            assert bus.online and told[-1].online
            await line.stop()
            await eventually(lambda: not bus.online, what="the bus offline")
            assert told[-1].lost is None  # being reopened, not lost for good
            state = drive.snapshot()
            assert not state.online and not state.bus_online and state.answered
            registers = DriveRegisters(drive)
            assert registers.input_image()[2] & 0b1000001 == 0b1000001  # offline, bus offline
            assert value_status(state, ".StatusWord") == "BadNoCommunication"
            with pytest.raises(UssError) as refused:  # at once: nothing waits to go out
                await drive.set_setpoint(10.0, unit="percent")
            assert classify(refused.value) is Failure.UNAVAILABLE  # Modbus 0A
            assert drive.drive.setpoints == (0,)  # taken back
            await line.start()
            await eventually(lambda: drive.state.online, timeout=30, what="online again")
            assert bus.online and told[-1].online
            assert registers.input_image()[2] & 0b1100001 == 0
    finally:
        await line.stop()


async def test_a_line_lost_for_good_says_why() -> None:
    port = free_port()
    line = _TcpDrive(port)
    await line.start()
    config = plant_from_flags(
        port=f"tcp://127.0.0.1:{port}?reconnect=0", addresses=[5], baud=BAUD,
        profile="generic", layout="4,2", name="line",
    )  # fmt: skip
    plant = Plant(resolve(config))
    try:
        async with plant:
            await eventually(lambda: plant.drives[0].state.online, what="online")
            lost = asyncio.ensure_future(plant.lost())
            await line.stop()
            state = await asyncio.wait_for(lost, 15)
            assert state.name == "line" and not state.online
            assert state.lost is not None and str(port) in state.lost
            assert not plant.drives[0].state.online
    finally:
        with contextlib.suppress(Exception):
            await line.stop()


def test_the_offline_rule_follows_the_line_s_cycle_unless_given() -> None:
    def rule(extra: str, drives: int = 1, baud: int = 38400) -> OfflineRule:
        tables = "\n".join(f"[[bus.drive]]\naddress = {a}" for a in range(1, drives + 1))
        data = tomllib.loads(f'[[bus]]\nport = "/dev/null"\nbaud = {baud}\n{extra}\n{tables}')
        return resolve(parse_plant(data["bus"])).buses[0].offline

    assert rule("") == OfflineRule(3, MIN_SILENCE)  # one drive, a fast line: 1 s
    full = rule('layout = "4,2"', drives=31, baud=9600)
    # 31 drives at 9600 baud: a round of silent drives takes some 3 s, four of them
    assert 4 * 31 * 0.09 < full.silence < 4 * 31 * 0.12
    assert rule("cycle_time = 10") == OfflineRule(3, 40.0)
    assert rule("offline_after_missed = 5") == OfflineRule(5, MIN_SILENCE)
    assert rule("offline_after_missed = 2\noffline_after_silence = 0.5") == OfflineRule(2, 0.5)
    for extra, words in [
        ("offline_after_missed = 0", "bus[0].offline_after_missed: 0 is not 1..1000"),
        ("offline_after_missed = true", "expected an integer"),
        ("offline_after_silence = -1", "bus[0].offline_after_silence: -1 is not a positive"),
        ("offline_after_silence = 7200", "more than the 3600 allowed"),
    ]:
        with pytest.raises(ConfigError, match=re.escape(words)):
            rule(extra)
