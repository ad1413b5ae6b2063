"""The MQTT face builds each state message from the parts that changed since the last one
(`StatePayloads`): the messages stay byte for byte what `state_payload` makes of the whole
state, through a ramp, a parameter read, a refused write, a drive that stops answering and
comes back, and the reference read after the first answers. The OPC UA face's values made
from the parts that changed (`value_parts`) are those of the whole state, through the same."""

from __future__ import annotations

import asyncio
import contextlib
import math
from typing import Any

from pyuss.bus import VirtualBus
from pyuss.errors import UssError
from pyuss.gateway.payloads import StatePayloads, state_payload
from pyuss.gateway.uanodes import drive_values, value_parts
from pyuss.master.testing import simulated_drives
from pyuss.points.config import plant_from_flags
from pyuss.points.model import resolve
from pyuss.points.plant import Plant
from pyuss.points.state import DriveState
from pyuss.protocol.layout import Layout
from support.waiting import eventually

BAUD = 38400


async def _states() -> list[DriveState]:
    """The states of a drive through a ramp, a parameter read, a refused write, a drive
    that stops answering and comes back, and the reference read after the first answers."""
    bus = VirtualBus(BAUD)
    config = plant_from_flags(
        port="bus://simulated:1",
        addresses=[5],
        baud=BAUD,
        layout="4,2",
        name="line",
        profile="generic",
        parameters=["107"],
    )
    states: list[DriveState] = []
    async with simulated_drives(bus, [(5, "generic", Layout.parse("4,2"))]):
        plant = Plant(resolve(config), transports={"line": bus.attach("gateway")})
        await plant.start()
        try:
            drive = plant.drives[0]
            drive.subscribe(states.append)
            await eventually(lambda: drive.reference is not None)
            await drive.set_setpoint(100.0, unit="percent")
            await drive.command("on")
            await eventually(lambda: len(states) > 30)
            await drive.read_parameter(107)
            with contextlib.suppress(UssError):  # P107 may not change while it runs
                await drive.write_parameter(107, 60.0)
            await drive.command("off1")
            bus.make_dead("drive5", 0.3)
            await eventually(lambda: states[-1].health.not_sending)
            await eventually(lambda: not states[-1].health.not_sending)
            await drive.read_parameter(107)
            await asyncio.sleep(0.2)
        finally:
            await plant.close()
    return states


async def test_the_state_messages_are_those_of_the_whole_state() -> None:
    states = await _states()
    assert states[0].reference is None and states[-1].reference is not None
    assert any(s.health.not_sending for s in states)
    assert any(s.health.last_refusal is not None for s in states)
    assert any(s.parameters["P107"].value is not None for s in states)
    payloads = StatePayloads()
    for state in states:
        assert payloads.payload(state) == state_payload(state)


async def test_the_opcua_values_made_from_the_parts_that_changed_are_the_whole_states() -> None:
    # The OPC UA face makes again only the parts of a drive's values (`value_parts`) whose
    # source changed: what it holds after each state is the values of the whole state.
    held: dict[str, Any] = {}
    sources: list[object] = []
    for state in await _states():
        parts = value_parts(state)
        for part, (source, values) in enumerate(parts):
            if part >= len(sources) or sources[part] != source:
                held.update(values())
        sources = [source for source, _values in parts]
        for key, value in drive_values(state).items():
            assert held[key] == value or _both_nan(held[key], value), key


def _both_nan(a: Any, b: Any) -> bool:
    return isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)


async def test_the_drives_of_a_bus_whose_port_failed_are_not_shown_as_answering() -> None:
    bus = VirtualBus(BAUD)
    config = plant_from_flags(
        port="bus://simulated:1", addresses=[5], baud=BAUD, layout="4,2", name="line",
        profile="generic",
    )  # fmt: skip
    async with simulated_drives(bus, [(5, "generic", Layout.parse("4,2"))]):
        station = bus.attach("gateway")
        plant = Plant(resolve(config), transports={"line": station})
        await plant.start()
        try:
            drive = plant.drives[0]
            await drive.drive.next_update(timeout=5)
            assert drive.snapshot().online
            await station.close()  # the port fails: the master stops
            await eventually(lambda: not plant.bus("line").master.running, what="master stopped")
            await eventually(lambda: not drive.state.online, timeout=3, what="drive not online")
        finally:
            await plant.close()
