"""The blocking master (`pyuss.master.blocking`): the core run in the calling thread over a
pyserial port, here ``socket://`` to simulated drives on a virtual bus in another thread (a
serial line over TCP: no pty, so it runs on every platform)."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from pyuss.errors import ConfigError, DriveRefusal
from pyuss.master import MasterClosed, NotSending
from pyuss.master.blocking import Master
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.slave.engine import JobLatency
from support.buses import SimulatorThread

BAUD = 38400


@pytest.fixture
def sim() -> Iterator[SimulatorThread]:
    with SimulatorThread(
        [(5, "generic", Layout(4, 2)), (6, "generic", Layout(4, 2))],
        baud=BAUD,
        latency=JobLatency(cycles=2),  # the drive repeats its old answer for two telegrams
    ) as sim:
        yield sim


def url(sim: SimulatorThread) -> str:
    return sim.paths[0].replace("tcp://", "socket://")


def test_parameters_and_process_data_in_the_calling_thread(sim: SimulatorThread) -> None:
    with Master(url(sim), baud=BAUD, layout="4,2") as bus:
        drive = bus.drive(5)
        assert drive is bus.drive(5) and bus.drives == (drive,)
        assert drive.read(52) == 0x4000
        assert drive.write(18, 123) == 123
        assert drive.read(18) == 123  # never the write's answer the drive still repeats
        assert drive.write(18, 7) == 7 and drive.read(18) == 7
        assert drive.job(Pkw(RequestId.READ_VALUE, 18)).id == ResponseId.VALUE_WORD
        status = drive.on()
        assert status.control == 0x047F and not status.fault
        assert bus.exchange(5).control == 0x047F  # the process data in force, again
        bus.drive(6)
        assert bus.mirror(6).address == 6  # a telegram of its length
        reply = bus.request(Telegram(6, AddressMode.MIRROR, bytes(12)))
        assert reply is not None and reply.telegram.mode is AddressMode.MIRROR
        assert not any(t.name.startswith("uss") for t in threading.enumerate())
        slaves = bus.diagnostics().slaves
        assert slaves[0].answers == slaves[0].exchanges


def test_a_refused_write_sends_nothing_and_a_drive_refusal_is_named(sim: SimulatorThread) -> None:
    with Master(url(sim), baud=BAUD, layout="4,2", profile="generic") as bus:
        drive = bus.drive(5)
        drive.read(18)
        before = drive.counts().exchanges
        with pytest.raises(ConfigError):
            drive.write(7, 99)  # P7 takes 1..10 (generic profile): checked before sending
        assert drive.counts().exchanges == before
        with pytest.raises(DriveRefusal):
            drive.read(999)  # no such parameter: the drive's own refusal


def test_a_silent_address_is_named_and_the_line_goes_on(sim: SimulatorThread) -> None:
    with Master(url(sim), baud=BAUD, layout="4,2") as bus:
        with pytest.raises(NotSending):
            bus.exchange(9, timeout=0.3)
        assert bus.drive(9).not_sending
        assert bus.drive(5).read(52) == 0x4000


def test_an_interrupted_call_leaves_nothing_to_be_sent_later(sim: SimulatorThread) -> None:
    with Master(url(sim), baud=BAUD, layout="4,2") as bus:
        drive = bus.drive(5)
        drive.read(18)

        def interrupt(status: object) -> None:
            raise KeyboardInterrupt  # Ctrl+C while the write waits for its answer

        remove = drive.on_update(interrupt)
        with pytest.raises(KeyboardInterrupt):
            drive.write(18, 321)
        remove()
        channel = bus.core.slaves[5].channel
        assert channel.current is None and not channel.queue
        assert drive.read(52) == 0x4000  # the line goes on, the write is not sent again


def test_calls_from_threads_take_turns(sim: SimulatorThread) -> None:
    with Master(url(sim), baud=BAUD, layout="4,2") as bus:
        results: list[int] = []

        def reads(address: int) -> None:
            for _ in range(5):
                results.append(bus.drive(address).read(52))

        threads = [threading.Thread(target=reads, args=(a,)) for a in (5, 6, 5)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(30)
        assert results == [0x4000] * 15


def test_a_closed_master_refuses_and_other_lines_are_named() -> None:
    bus = Master("loop://", baud=BAUD)
    with pytest.raises(MasterClosed):
        bus.drive(5).read(52)
    with pytest.raises(ConfigError, match="serial port"):
        Master("tcp://127.0.0.1:1", baud=BAUD)
