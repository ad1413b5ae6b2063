"""Diagnostic parameters (A 5.2.3) and the telegram failure time (C 3.1), over TCP."""

from __future__ import annotations

import time

import pytest

from pyuss.drive import DriveState, SimulatedDrive, parse_database
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.slave import SlaveEngine
from pyuss.slave.engine import TELEGRAM_FAILURE_FAULT
from slave.harness import LineSim, engine, frame

LV = Layout(127, 2)
OFF1 = (0x047E, 0)
BASE = 2030  # the generic profile's diagnostic parameters


def test_diagnostic_parameters_show_the_receive_diagnostics() -> None:
    good = frame(5, "1012 0000 0000 047E 0000")
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        master.exchange(good)
        assert master.silent(good[:-1] + b"\x00")  # wrong BCC
        status = master.ask(5, LV, Pkw(1, BASE + 3), OFF1).pkw
        bcc = master.ask(5, LV, Pkw(1, BASE + 13), OFF1).pkw
        count = master.ask(5, LV, Pkw(1, BASE + 6), OFF1).pkw
        element = master.ask(5, LV, Pkw(6, BASE + 16, 2), OFF1).pkw
        length = master.ask(5, LV, Pkw(1, BASE + 17), OFF1).pkw
        elements = master.ask(5, LV, Pkw(9, BASE + 16), OFF1).pkw
        name = master.ask(5, LV, Pkw(4, BASE + 13, 6), OFF1).pkw
        bit_text = master.ask(5, LV, Pkw(15, BASE + 3, 10), OFF1).pkw
        written = master.ask(5, LV, Pkw(2, BASE + 6, values=(0,)), OFF1).pkw
    assert status.values[0] & 0x0010  # bit 4: wrong BCC
    assert bcc.values == (1,)
    assert count.values == (4,)  # the good telegram and three reads so far
    # the request that read it: 02 0C 05 | 6 7FE ...: element 2 is ADR and the PKE high byte
    assert element.values == (0x0567,)
    assert length.values == (14,)
    assert elements.values == (128,)
    assert name.text() == "USS BCC error"
    assert bit_text.text() == "BCC ERROR"  # bit 4 = 1: text element 2 x 4 + 1 + 1
    assert (written.id, written.values) == (7, (1,))  # read-only


def test_telegram_failure_time_trips_a_fault_shown_in_the_status_word() -> None:
    setup = engine(5, "generic", "v,2", failure_time=0.3)
    with LineSim(setup) as sim, sim.master() as master:
        time.sleep(0.5)  # no monitoring before the first good telegram
        first = master.ask(5, LV, Pkw(0), OFF1)
        time.sleep(0.6)
        state = sim.call(lambda: sim.drive.state)  # the server noticed without a telegram
        # monitoring off from here, so that a stalled test process cannot trip it again
        sim.call(lambda: setattr(sim.engines[0], "failure_time", 0.0))
        tripped = master.ask(5, LV, Pkw(0), OFF1)
        timeouts = master.ask(5, LV, Pkw(1, BASE + 15, spm_toggle=True), OFF1).pkw
        master.ask(5, LV, Pkw(0, spm_toggle=True), (0x04FE, 0))  # acknowledge: rising bit 7
        recovered = master.ask(5, LV, Pkw(0, spm_toggle=True), OFF1)
    assert not first.pzd[0] & 0x0008
    assert state is DriveState.FAULT
    assert tripped.pzd[0] & 0x0008  # status bit 3: fault
    assert (tripped.pkw.id, tripped.pkw.pnu, tripped.pkw.values) == (9, 947, (65,))
    assert timeouts.values == (1,)
    assert not recovered.pzd[0] & 0x0008
    assert recovered.pzd[0] & 0x0001  # ready to switch on again


def test_failure_time_trips_a_fault_even_when_the_file_names_no_fault_code() -> None:
    """A parameter file of the user's own without ``[faults]``: the drive still trips a fault
    that the status word shows (C 3.1)."""
    bare = parse_database(
        '[profile]\nname = "bare"\n\n[drive]\nfault = 1\n\n'
        '[[parameter]]\npnu = 1\nname = "Fault"\ntype = "uint16"\naccess = "ro"\n'
    )

    def make(now: float) -> list[SlaveEngine]:
        drive = SimulatedDrive(bare, now=now)
        profile = get_profile("generic")
        return [SlaveEngine(5, drive, profile, layout=LV, failure_time=0.2, now=now)]

    with LineSim(make) as sim, sim.master() as master:
        first = master.ask(5, LV, Pkw(0), OFF1)
        time.sleep(0.4)
        tripped = master.ask(5, LV, Pkw(1, 1), OFF1)
    assert not first.pzd[0] & 0x0008
    assert tripped.pzd[0] & 0x0008  # status bit 3: fault
    assert tripped.pkw.values == (TELEGRAM_FAILURE_FAULT,)


def test_failure_time_from_the_interface_parameter() -> None:
    """P687.1 (ms) sets the generic drive's failure time; 0 switches monitoring off."""
    profile = get_profile("generic")
    drive = SimulatedDrive.from_profile("generic")
    assert SlaveEngine(5, drive, profile).failure_time == 0.0
    drive.write(687, 250, 1)
    assert SlaveEngine(5, drive, profile).failure_time == 0.25
    nord = SimulatedDrive.from_profile("nord")
    nord.write(513, 15)  # 0.1 s units
    assert SlaveEngine(5, nord, get_profile("nord")).failure_time == 1.5


def test_changing_a_diagnostic_parameter_is_refused_and_serving_goes_on() -> None:
    """The diagnostic parameters are read-only displays: a change job gets error 1 (also on a
    Baumueller drive, whose write authority is parameter 126), and without write authority
    response ID 8, as every change job (C 4.2.1.1)."""
    l32 = Layout(3, 2)
    with LineSim(engine(5, "baumueller", "3,2")) as sim, sim.master() as master:
        master.ask(5, l32, Pkw(2, 181, values=(4,)), OFF1)  # response-delay mode: direct answers
        written = master.ask(5, l32, Pkw(2, 190, values=(1,)), OFF1).pkw  # P190: hardware
        read = master.ask(5, l32, Pkw(1, 190 + 6), OFF1).pkw  # good telegrams so far
    assert (written.id, written.values) == (7, (1,))
    assert (read.id, read.values) == (1, (3,))
    with LineSim(engine(5, "generic", "v,2", write_authority=False)) as sim, sim.master() as master:
        denied = master.ask(5, LV, Pkw(2, BASE + 6, values=(0,)), OFF1).pkw
    assert denied.id == 8


SIEMENS = ["micromaster420", "micromaster440", "sinamics-g110", "sinamics-g120", "sinamics-v20"]


@pytest.mark.parametrize("family", SIEMENS)
def test_a_running_siemens_drive_trips_on_the_telegram_off_time_and_coasts(family: str) -> None:
    """P2014 (ms) on a running drive: when the master keeps quiet longer, the drive trips the
    fault of its file (F0072), shows it in r0947 and status bit 3, switches the pulses off and
    coasts (the simulator's fault reaction: OFF2); a rising edge of control bit 7 acknowledges
    it, and OFF1 then ON run the drive again. Sans-io: the times are given."""
    profile = get_profile(family)
    drive = SimulatedDrive(profile.database(), now=0.0)
    slave = SlaveEngine(5, drive, profile, layout=Layout(4, 2), now=0.0)
    drive.write(2014, 500, 0, interface="uss")
    assert slave.failure_time == 0.5

    def send(words: tuple[int, int], now: float) -> tuple[int, ...]:
        data = Layout(4, 2).pack(Pkw(0), words)
        answer = slave.handle(Telegram(5, AddressMode.NORMAL, data), now)
        assert answer is not None
        net = Layout(4, 2).unpack(answer.data)
        return net.pzd

    send(OFF1, 0.0)
    t = 0.0
    for _ in range(100):  # ON at 50 %, 0.1 s apart: up the ramp
        t += 0.1
        status, _ = send((0x047F, 0x2000), t)
    assert status & 0x0004 and drive.machine.actual > 0
    slave.tick(t + 0.49)
    assert drive.state is DriveState.OPERATION
    slave.tick(t + 0.51)  # no telegram for longer than P2014
    assert drive.state is DriveState.FAULT
    code = profile.database().faults["telegram_failure"]
    assert drive.value(947, 0) == code == 72
    assert drive.status_word() & 0x0008 and not drive.status_word() & 0x0004
    running = drive.machine.actual
    drive.step(t + 1.0)
    assert 0 <= drive.machine.actual < running  # coasting, pulses off
    status, _ = send((0x047F, 0x2000), t + 1.1)  # ON does not leave the fault
    assert status & 0x0008
    send((0x04FE, 0x2000), t + 1.2)  # bit 7 rising: acknowledged
    status, _ = send((0x047E, 0x2000), t + 1.3)
    assert not status & 0x0008 and drive.value(947, 0) == 0
    assert status & 0x0001  # ready to switch on
    status, _ = send((0x047F, 0x2000), t + 1.4)
    assert status & 0x0004  # running again
