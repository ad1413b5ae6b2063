"""``uss gateway`` runs on uvloop where it is installed and every bus is ``bus://`` (the bus
keeps the line's timing there), else on the loop of `pyuss.loop` (microsecond timers for the
start pause it keeps itself), and says which before ``ready``."""

from __future__ import annotations

import importlib.util
import sys

import pytest

from gateway.test_cli import first_line, start, stop
from pyuss.loop import uvloop_choice
from support.network import free_port

UVLOOP = importlib.util.find_spec("uvloop") is not None


def test_uvloop_only_where_the_bus_keeps_the_timing(monkeypatch: pytest.MonkeyPatch) -> None:
    own = uvloop_choice(False)
    assert own.name == "pyuss.loop" and own.factory is None
    assert "a line whose timing it keeps" in str(own)
    monkeypatch.setitem(sys.modules, "uvloop", None)  # as if it were not installed
    missing = uvloop_choice(True)
    assert missing.name == "pyuss.loop" and "uvloop is not installed" in str(missing)


@pytest.mark.skipif(not UVLOOP, reason="uvloop is not installed (pip install 'pyuss[gateway]')")
def test_uvloop_runs_a_coroutine_where_it_is_chosen() -> None:
    choice = uvloop_choice(True)
    assert choice.name.startswith("uvloop")

    async def loop_module() -> str:
        import asyncio

        return type(asyncio.get_running_loop()).__module__

    assert choice.run(loop_module()).startswith("uvloop")


def _gateway_loop(*port: str) -> str:
    gateway = start("gateway", *port, "--address", "5", "--modbus", f"127.0.0.1:{free_port()}")
    try:
        return first_line(gateway, "event loop: ").removeprefix("event loop: ")
    finally:
        stop(gateway)


def test_the_gateway_says_which_loop_it_runs_on() -> None:
    sim = start("simulate", "--bus-tcp", "127.0.0.1:0", "--address", "5")
    try:
        url = first_line(sim, "bus://")
        over_bus = _gateway_loop("--port", url)
    finally:
        stop(sim)
    if UVLOOP:
        assert over_bus.startswith("uvloop ") and "every bus is bus://" in over_bus
    else:
        assert over_bus.startswith("pyuss.loop") and "uvloop is not installed" in over_bus
    raw = start("simulate", "--tcp", "127.0.0.1:0", "--address", "5")
    try:
        url = first_line(raw, "tcp://")
        assert _gateway_loop("--port", url).startswith("pyuss.loop (microsecond timers: ")
    finally:
        stop(raw)
