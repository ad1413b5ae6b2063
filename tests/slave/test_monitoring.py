"""Diagnostic parameters (A 5.2.3) and the telegram failure time (C 3.1), over TCP."""

from __future__ import annotations

import time

from pyuss.drive import DriveState, SimulatedDrive, parse_database
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
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
