"""A line that echoes (a 2-wire RS-485 adapter without echo suppression, ``loop://``): the
master never takes its own telegram, heard back, for the drive's answer."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator, Sequence

import pytest

from pyuss.bus import FaultPlan, VirtualBus
from pyuss.cli.main import main
from pyuss.errors import DriveRefusal
from pyuss.master import Master, NotSending
from pyuss.master.testing import simulated_drives
from pyuss.protocol.layout import Layout
from pyuss.slave import SlaveEngine
from support.buses import SimulatorThread
from support.waiting import eventually


@contextlib.asynccontextmanager
async def line(
    baud: int, addresses: Sequence[int], *stations: tuple[str, bool]
) -> AsyncIterator[tuple[dict[int, SlaveEngine], list[Master]]]:
    """Simulated drives (generic, PKW 3 + PZD 2) at ``addresses`` on a virtual bus, and a
    master per station ``(name, echo)``: with ``echo`` the bus gives the station its own
    characters back, as a 2-wire adapter without echo suppression does."""
    bus = VirtualBus(baud)
    try:
        async with contextlib.AsyncExitStack() as stack:
            engines = await stack.enter_async_context(
                simulated_drives(bus, [(a, "generic", Layout(3, 2)) for a in addresses])
            )
            masters = [
                await stack.enter_async_context(Master(bus.attach(name, echo=echo), layout="3,2"))
                for name, echo in stations
            ]
            yield engines, masters
    finally:
        await bus.close()


async def test_the_masters_own_telegram_heard_back_is_no_answer(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # the echo of "read P52" reads as "P52 = 0", of the request's control word as the status
    # word: the values are the drive's own, and its refusal comes through as a refusal
    async with line(19200, [5], ("master", True)) as (engines, (master,)):
        drive = master.drive(5)
        with caplog.at_level(logging.WARNING, logger="pyuss.master"):
            assert await drive.read(52) == 16384
            with pytest.raises(DriveRefusal, match="illegal parameter number"):
                await drive.write(60, 1)  # no P60 in this drive
            status = await master.exchange(5)
        assert status.word == engines[5].drive.status_word() != 0
        diagnostics = master.diagnostics()
        assert diagnostics.own_heard >= 3 and diagnostics.stray == 0
        assert diagnostics.slaves[0].counters.framing == 0  # no request collided
        told = [r for r in caplog.records if "hears its own telegrams" in r.message]
        assert len(told) == 1 and "echo=1" in told[0].message


async def test_no_drive_is_made_up_from_the_echo_of_a_request_to_an_empty_address() -> None:
    # a mirror telegram comes back unchanged from the slave, and from the echo: on a line
    # that stamps characters exactly, the echo is known by when it began
    async with line(19200, [5], ("master", True)) as (_, (master,)):
        assert (await master.mirror(5)).response_time > 0  # the answer, after the request
        with pytest.raises(NotSending):
            await master.mirror(6)


def test_a_read_over_loop_is_no_answer_of_a_drive(capsys: pytest.CaptureFixture[str]) -> None:
    # pyserial's loop:// gives back what is written: no drive is on it, and none answers;
    # without exact timestamps the bytes tell the echo of the read from an answer, and the
    # echo of the "no job" before it (net data zero) came back before it had left the line:
    # the drive answered nothing at all, not "stopped answering"
    code = main(["read", "--port", "loop://", "--layout", "3,2", "--timeout", "0.3", "5", "107"])
    out, err = capsys.readouterr()
    assert code == 1 and out == "", out
    assert err.startswith("P107: slave 5 does not answer (no reply within 0.3 s)"), err


async def test_a_line_that_does_not_echo_is_never_said_to(caplog: pytest.LogCaptureFixture) -> None:
    async with line(187500, [1, 2, 3], ("master", False)) as (_, (master,)):
        for address in (1, 2, 3):
            master.drive(address)
        with caplog.at_level(logging.WARNING, logger="pyuss.master"):
            for _ in range(20):
                for address in (1, 2, 3):
                    await master.exchange(address)
        assert master.diagnostics().own_heard == 0
        assert not [r for r in caplog.records if "own telegrams" in r.message]
        assert not [r for r in caplog.records if "another master" in r.message]


async def test_a_pkw_only_answer_with_the_requests_bytes_is_the_drives_over_tcp() -> None:
    # PKW only, the read of a zero value: the drive answers with the request's very bytes;
    # without exact timestamps nothing tells it from an echo, and it is taken as the answer
    with SimulatorThread([(3, "generic", Layout(3, 0))]) as sim:
        async with Master(sim.paths[0], baud=sim.baud, layout=Layout(3, 0)) as master:
            drive = master.drive(3)
            sim.call(lambda s: s.engines[3].drive.update(52, 0))
            assert await drive.read(52) == 0


def test_a_mirror_test_over_loop_is_no_drive(capsys: pytest.CaptureFixture[str]) -> None:
    # a mirror telegram's answer is its very bytes: the echo came back before the request had
    # left the line, so it is none, and the line echoes from then on
    code = main(["mirror", "5", "--port", "loop://", "--layout", "3,2", "--count", "3"])
    out, err = capsys.readouterr()
    assert code == 1, out
    assert "0 of 3 came back unchanged" in out and ": ok" not in out
    assert "slave 5 does not send" in err


def test_a_scan_over_loop_finds_no_drive(capsys: pytest.CaptureFixture[str]) -> None:
    # the scan's probes ("no job", process data zero) are answered by a drive of a PKW-only
    # layout with their very bytes: heard back, they are no drives at every address
    code = main(["scan", "--port", "loop://", "--address", "1-3", "--baud", "9600"])
    out, err = capsys.readouterr()
    assert code == 1, out
    assert "no drive answered" in out + err
    assert "9600" not in out


async def test_a_late_answer_to_a_mirror_telegram_is_no_echo() -> None:
    # the drive's answer to the first mirror telegram comes after the master gave it up: it
    # is the drive's, not the master's own telegram heard back, and the line does not echo
    # for that: the next mirror telegram's answer is taken
    late = FaultPlan.parse(["delay:station=drive5,seconds=0.3,nth=1,count=1"])
    with SimulatorThread([(5, "generic", Layout(3, 2))], faults=late) as sim:
        async with Master(sim.paths[0], baud=sim.baud, layout="3,2") as master:
            with pytest.raises(NotSending):
                await master.mirror(5)
            await asyncio.sleep(0.6)  # the late answer is in
            assert (await master.mirror(5)).round_trip > 0
            assert master.diagnostics().own_heard == 0


async def test_a_second_master_on_the_line_is_told_of_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # a page and a gateway on one line: each hears the other's telegrams, which it did not
    # ask for; USS has one master (A 2), so it says so, once
    async with line(187500, [1, 2], ("page", False), ("gateway", False)) as (_, masters):
        page, gateway = masters
        page.drive(1)
        gateway.drive(2)
        with caplog.at_level(logging.WARNING, logger="pyuss.master"):

            def told() -> list[logging.LogRecord]:
                return [r for r in caplog.records if "another master on the line" in r.message]

            # which of the two hears the other first is a matter of timing; each tells once
            await eventually(lambda: len(told()) >= 1, what="a master told")
            await asyncio.sleep(0.5)  # more of them: no master tells again
        assert len(told()) <= 2
