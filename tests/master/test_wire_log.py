"""Raw frames go to the ``pyuss.wire`` logger, one line per frame with direction and hex bytes,
from the master and from the simulated slave alike."""

from __future__ import annotations

import logging

import pytest

from pyuss.protocol.layout import Layout
from support.buses import simulated_bus


async def test_raw_frames_are_logged_on_pyuss_wire(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger="pyuss.wire")
    async with simulated_bus([(5, "generic", Layout(3, 2))]) as env:
        assert await env.master.drive(5).read(52) == 0x4000
    lines = [r.getMessage() for r in caplog.records if r.name == "pyuss.wire"]
    # The master's request for P52 and the drive's answer, byte for byte (C 8.1 example 2).
    assert any(m.startswith("tx ") and "02 0C 05 10 34 00 00 00 00" in m for m in lines)
    assert any(m.startswith("rx ") and "02 0C 05 10 34 00 00 40 00" in m for m in lines)


async def test_nothing_is_formatted_when_the_wire_logger_is_off(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger="pyuss.wire")
    async with simulated_bus([(5, "generic", Layout(3, 2))]) as env:
        await env.master.drive(5).read(52)
    assert not [r for r in caplog.records if r.name == "pyuss.wire"]
