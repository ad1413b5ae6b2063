"""Spontaneous messages with the toggle bit until acknowledged (C 4.2.1.2), over TCP."""

from __future__ import annotations

from collections.abc import Sequence

from pyuss.drive import SimulatedDrive, parse_database
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.slave import SlaveEngine
from slave.harness import LineSim, engine

LV = Layout(127, 2)
L42 = Layout(4, 2)
OFF1 = (0x047E, 0)

ACTIVE_ARRAY = """
[profile]
name = "with-active-array"
extends = "generic"

[[parameter]]
pnu = 60
name = "Active array"
type = "int16"
array = 3
active = true
"""


def _with_active_array(layout: Layout):  # type: ignore[no-untyped-def]
    def make(now: float) -> Sequence[SlaveEngine]:
        drive = SimulatedDrive(parse_database(ACTIVE_ARRAY), now=now)
        return [SlaveEngine(5, drive, get_profile("generic"), layout=layout, now=now)]

    return make


def test_changes_are_reported_until_acknowledged_one_after_the_other() -> None:
    job = Pkw(1, 18)
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        normal = master.ask(5, LV, job, OFF1).pkw
        sim.call(lambda: sim.drive.update(52, 0x0111))
        sim.call(lambda: sim.drive.update(52, 0x0222))  # the same element: the newest counts
        sim.call(lambda: sim.drive.raise_fault(99))  # P947 (active) shows the fault number
        first = master.ask(5, LV, job, OFF1).pkw
        repeated = master.ask(5, LV, job, OFF1).pkw  # toggle not changed: not acknowledged
        second = master.ask(5, LV, Pkw(1, 18, spm_toggle=True), OFF1).pkw  # acknowledge
        third = master.ask(5, LV, Pkw(1, 18, spm_toggle=True), OFF1).pkw  # not yet
        back = master.ask(5, LV, job, OFF1).pkw  # acknowledge (toggle back to 0)
    assert (normal.id, normal.spm_toggle) == (1, False)
    assert (first.id, first.pnu, first.values, first.spm_toggle) == (9, 52, (0x0222,), True)
    assert repeated == first
    assert (second.id, second.pnu, second.values, second.spm_toggle) == (9, 947, (99,), False)
    assert third == second
    assert (back.id, back.pnu, back.spm_toggle) == (1, 18, False)


def test_answers_keep_the_toggle_of_the_last_message() -> None:
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        sim.call(lambda: sim.drive.update(52, 1))
        message = master.ask(5, LV, Pkw(1, 18), OFF1).pkw
        after = master.ask(5, LV, Pkw(1, 18, spm_toggle=True), OFF1).pkw
    assert (message.id, message.spm_toggle) == (9, True)
    assert (after.id, after.spm_toggle) == (1, True)


def test_jobs_go_on_while_a_message_is_shown() -> None:
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        sim.call(lambda: sim.drive.update(52, 1))
        shown = master.ask(5, LV, Pkw(2, 18, values=(0x1234,)), OFF1).pkw
        written = sim.call(lambda: sim.drive.value(18))
        answer = master.ask(5, LV, Pkw(2, 18, spm_toggle=True, values=(0x1234,)), OFF1).pkw
    assert shown.id == 9
    assert written == 0x1234
    assert (answer.id, answer.values) == (1, (0x1234,))


def test_array_changes() -> None:
    """Table 4.8: IDs 11/12 with the index; a whole array (IND 255) with its values only on a
    variable-length interface, else PNU and IND alone (C 4.2.1.2)."""
    for layout, values in ((LV, (1, 2, 3)), (L42, (0, 0))):
        with LineSim(_with_active_array(layout)) as sim, sim.master() as master:
            sim.call(lambda: sim.drive.write(60, 9, 2, interface="panel"))
            single = master.ask(5, layout, Pkw(0), OFF1).pkw
            master.ask(5, layout, Pkw(0, spm_toggle=True), OFF1)
            sim.call(lambda: sim.drive.write_array_words(60, (1, 2, 3), interface="panel"))
            whole = master.ask(5, layout, Pkw(0, spm_toggle=True), OFF1).pkw
        assert (single.id, single.pnu, single.index) == (11, 60, 2)
        assert single.values[-1] == 9
        assert (whole.id, whole.pnu, whole.index, whole.values) == (11, 60, 255, values)


def test_own_changes_are_not_reported() -> None:
    with LineSim(_with_active_array(LV)) as sim, sim.master() as master:
        master.ask(5, LV, Pkw(7, 60, 1, values=(5,)), OFF1)
        answer = master.ask(5, LV, Pkw(0), OFF1).pkw
    assert answer.id == 0


def test_messages_can_be_switched_off() -> None:
    with LineSim(engine(5, "generic", "v,2", spontaneous=False)) as sim, sim.master() as master:
        sim.call(lambda: sim.drive.update(52, 1))
        answer = master.ask(5, LV, Pkw(1, 18), OFF1).pkw
    assert (answer.id, answer.spm_toggle) == (1, False)
