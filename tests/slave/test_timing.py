"""Line timing on the virtual bus (exact character times): start pause before the answer,
the profiles' response delays, and the receive rules of A 5.2 (A 5.1.2, A 5.2.1, A 6)."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from dataclasses import dataclass, field

import pytest

from commission.test_docs import uss
from pyuss.bus import Fault, FaultKind, FaultPlan, VirtualBus, WireChar
from pyuss.drive import SimulatedDrive
from pyuss.errors import ConfigError
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.slave import SlaveEngine, SlaveServer
from pyuss.transport.base import Transport
from slave.harness import WAIT, frame
from support.processes import simulator_bus

#: Upper bounds are spec rules too, but a loaded machine may be late; they get this slack.
SLACK = 0.25
REQUEST = frame(5, "1034 0000 0000 047E 0000")


@dataclass
class Line:
    bus: VirtualBus
    master: Transport
    server: SlaveServer
    chars: list[WireChar] = field(default_factory=list)

    async def exchange(self, data: bytes, *, answer: bool = True) -> float | None:
        """Send ``data``; the time from its last character's end to the answer's first
        character's start on the wire, or None when no answer starts within a while."""
        self.chars.clear()
        await self.master.write(data)
        deadline = asyncio.get_running_loop().time() + (WAIT if answer else 0.25)
        while asyncio.get_running_loop().time() < deadline:
            sent = [c for c in self.chars if c.sender == "master"]
            replies = [c for c in self.chars if c.sender == "slave"]
            if len(sent) == len(data) and len(replies) >= 2 and len(replies) == replies[1].byte + 2:
                await asyncio.sleep(3 * self.bus.char_time)  # a start pause before the next
                return replies[0].start - sent[-1].end
            await asyncio.sleep(0.002)
        return None


@contextlib.asynccontextmanager
async def line(
    profile: str,
    baud: int,
    *,
    address: int = 5,
    layout: str = "3,2",
    faults: FaultPlan | None = None,
    response_delay: float | None = None,
    manual_delay: bool = False,
) -> AsyncIterator[Line]:
    bus = VirtualBus(baud, faults=faults)
    master = bus.attach("master")
    slave = bus.attach("slave")
    await master.open()
    await slave.open()
    prof = get_profile(profile)
    drive = SimulatedDrive(prof.database(), now=slave.clock())
    if profile == "baumueller":
        drive.update(181, 4)  # response-delay mode: answers to the request itself
    engine = SlaveEngine(address, drive, prof, layout=Layout.parse(layout), now=slave.clock())
    server = SlaveServer(slave, engine, response_delay=response_delay, manual_delay=manual_delay)
    result = Line(bus, master, server)
    bus.on_char.append(result.chars.append)
    stop = asyncio.Event()
    task = asyncio.create_task(server.run(stop))
    try:
        yield result
    finally:
        stop.set()
        await asyncio.wait_for(task, WAIT)
        server.close()
        await bus.close()


@pytest.mark.parametrize("baud", [9600, 187500])
async def test_answer_comes_after_the_start_pause_and_within_20_ms(baud: int) -> None:
    async with line("generic", baud) as wire:
        delays = [await wire.exchange(REQUEST) for _ in range(5)]
    pause = 2 * 11 / baud
    for delay in delays:
        assert delay is not None
        assert pause <= delay <= 0.020 + SLACK
    assert wire.server.stats.answers == 5


async def test_6se21_answers_2_5_ms_or_later_at_9600_baud() -> None:
    request = frame(1, "1014 0000 0000 047E 0000")
    async with line("6se21", 9600, address=1) as wire:
        delay = await wire.exchange(request)
    assert delay is not None
    assert 0.0025 <= delay <= 0.0175 + SLACK


async def test_baumueller_keeps_33_bit_times_before_its_answer() -> None:
    request = frame(5, "1034 0000 0000 047E 0000")
    async with line("baumueller", 9600) as wire:
        delay = await wire.exchange(request)
    assert delay is not None
    assert delay >= 33 / 9600


async def test_a_chosen_response_delay() -> None:
    async with line("generic", 19200, response_delay=0.010) as wire:
        delay = await wire.exchange(REQUEST)
    assert delay is not None
    assert 0.010 <= delay <= 0.010 + SLACK


async def test_a_sinamics_v20_answers_after_its_manuals_response_delay() -> None:
    """SINAMICS V20 Operating Instructions 10/2019, 7.1: response delay 20 ms (the parameter
    file's ``response_delay_ms``), when the server is asked for the manual's delay."""
    async with line("sinamics-v20", 19200, manual_delay=True) as wire:
        delay = await wire.exchange(REQUEST)
    assert delay is not None
    assert 0.020 <= delay <= 0.020 + SLACK


async def test_by_default_a_sinamics_v20_answers_as_early_as_allowed() -> None:
    async with line("sinamics-v20", 19200) as wire:
        delay = await wire.exchange(REQUEST)
    assert delay is not None
    assert 2 * 11 / 19200 <= delay < 0.010


async def test_a_family_without_a_manual_delay_answers_as_early_as_allowed() -> None:
    async with line("generic", 19200, manual_delay=True) as wire:
        delay = await wire.exchange(REQUEST)
    assert delay is not None
    assert 2 * 11 / 19200 <= delay < 0.010


def test_a_delay_of_its_own_and_the_manuals_are_not_both_given() -> None:
    prof = get_profile("generic")
    drive = SimulatedDrive(prof.database(), now=0.0)
    engine = SlaveEngine(5, drive, prof, layout=Layout(3, 2), now=0.0)
    bus = VirtualBus(19200)
    with pytest.raises(ConfigError, match="not both"):
        SlaveServer(bus.attach("slave"), engine, response_delay=0.01, manual_delay=True)


def test_uss_simulate_answers_after_the_manuals_delay_when_asked() -> None:
    # The simulated V20 answers 20 ms after each request, the longest its manual allows and
    # the master's limit: the master here waits 5 ms more, so that a simulator a moment late
    # on a busy machine (the bus stamps its answer when it is written) is still heard.
    with simulator_bus(
        "--profile", "sinamics-v20", "--address", "5", "--response-delay", "manual"
    ) as port:
        code, out = uss(
            ["read", "5", "P0700.0", "--port", port, "--profile", "sinamics-v20", "--baud", "38400",
             "--response-delay", "25"]
        )  # fmt: skip
    assert code == 0, out
    assert out.startswith("P0700.0 = 5")


@pytest.mark.parametrize("value", ["abc", "0", "-3", "nan"])
def test_uss_simulate_refuses_a_response_delay_that_is_no_delay(value: str) -> None:
    code, out = uss(
        ["simulate", "--profile", "generic", "--tcp", "127.0.0.1:0", "--response-delay", value]
    )
    assert code == 2 and f"--response-delay {value}" in out and "'manual'" in out


async def test_a_telegram_with_a_parity_error_is_not_answered() -> None:
    plan = FaultPlan([Fault(FaultKind.PARITY, station="master", nth=6)])
    async with line("generic", 19200, faults=plan) as wire:
        assert await wire.exchange(REQUEST, answer=False) is None
        assert await wire.exchange(REQUEST) is not None
        parity = wire.server.diagnostics.parity
    assert parity == 1


async def test_a_start_pause_inside_a_telegram_breaks_it() -> None:
    """A gap of 2 character times or more inside a telegram (A 6.3, A 5.1.2): no answer."""
    plan = FaultPlan([Fault(FaultKind.STRETCH, station="master", nth=8, gap=3)])
    async with line("generic", 19200, faults=plan) as wire:
        assert await wire.exchange(REQUEST, answer=False) is None
        assert await wire.exchange(REQUEST) is not None


async def test_stx_without_a_start_pause_starts_no_telegram() -> None:
    async with line("generic", 19200) as wire:
        glued = b"\x55" + REQUEST  # a stray character right before STX
        assert await wire.exchange(glued, answer=False) is None
        no_stx = wire.server.diagnostics.no_stx
    assert no_stx == 1


@pytest.mark.parametrize(
    ("profile", "gap", "answered"),
    [
        ("nord", 1.5, True),
        ("nord", 1.7, True),
        ("nord", 1.9, False),
        ("generic", 1.5, True),
        ("generic", 1.7, False),
    ],
)
async def test_nord_residual_telegram_time(profile: str, gap: float, answered: bool) -> None:
    """NORD BU 0050 1.3.5: a request must be complete 1.5 x (n + 4) character times after the start
    of its STX, 21 for these 14 bytes; A 6.3 allows 1 + 1.5 x (n + 3) = 20.5. Gaps before
    characters 2..5 of 4 x 1.5 = 6 character times (20 in all) keep it for both; 4 x 1.7 = 6.8
    (20.8 in all) only for NORD; 4 x 1.9 = 7.6 (21.6 in all) for neither."""
    plan = FaultPlan([Fault(FaultKind.STRETCH, station="master", gap=gap, count=5)])
    async with line(profile, 19200, faults=plan) as wire:
        delay = await wire.exchange(REQUEST, answer=answered)
        residual = wire.server.diagnostics.residual_time
    assert (delay is not None) == answered
    assert residual == (0 if answered else 1)
