"""The job/answer processing of the parameter channel (C 4.2.1.1), over TCP."""

from __future__ import annotations

import time

from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.slave import JobLatency
from slave.harness import LineSim, engine

LV = Layout(127, 2)
OFF1 = (0x047E, 0)


def test_no_job_is_answered_with_no_response() -> None:
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        net = master.ask(5, LV, Pkw(0), OFF1)
    assert net.pkw == Pkw(0, values=(0,))


def test_first_contact_answers_no_response_until_the_answer_is_ready() -> None:
    with (
        LineSim(engine(5, "generic", "v,2", latency=JobLatency(cycles=2))) as sim,
        sim.master() as master,
    ):
        answers = [master.ask(5, LV, Pkw(1, 52), OFF1).pkw for _ in range(4)]
    assert [a.id for a in answers] == [0, 0, 1, 1]
    assert answers[2].values == (0x4000,)


def test_old_answer_repeats_with_the_current_value_until_the_new_one_is_ready() -> None:
    setup = engine(5, "generic", "v,2", latency=JobLatency(cycles=2), spontaneous=False)
    with (
        LineSim(setup) as sim,
        sim.master() as master,
    ):
        for _ in range(3):
            master.ask(5, LV, Pkw(1, 52), OFF1)
        sim.call(lambda: sim.drive.update(52, 0x1111))
        write = Pkw(2, 18, values=(0x1234,))
        first = master.ask(5, LV, write, OFF1).pkw
        p18_first = sim.call(lambda: sim.drive.value(18))
        second = master.ask(5, LV, write, OFF1).pkw
        third = master.ask(5, LV, write, OFF1).pkw
        p18_third = sim.call(lambda: sim.drive.value(18))
    # the old job's answer, with P52's value of now
    assert (first.id, first.pnu, first.values) == (1, 52, (0x1111,))
    assert (second.id, second.pnu, second.values) == (1, 52, (0x1111,))
    assert p18_first == 0  # not carried out before its answer is ready
    assert (third.id, third.pnu, third.values) == (1, 18, (0x1234,))
    assert p18_third == 0x1234


def test_a_repeated_job_is_not_carried_out_again() -> None:
    write = Pkw(2, 18, values=(0x1234,))
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        assert master.ask(5, LV, write, OFF1).pkw.values == (0x1234,)
        sim.call(lambda: sim.drive.write(18, 0x0100, interface="panel"))
        again = master.ask(5, LV, write, OFF1).pkw
        kept = sim.call(lambda: sim.drive.value(18))
        master.ask(5, LV, Pkw(0), OFF1)  # a different job in between
        renewed = master.ask(5, LV, write, OFF1).pkw
        written = sim.call(lambda: sim.drive.value(18))
    assert again.values == (0x0100,)  # the answer repeats with the value of now
    assert kept == 0x0100
    assert renewed.values == (0x1234,)
    assert written == 0x1234


def test_any_change_of_the_job_is_a_new_job() -> None:
    """Same ID and PNU, other PWE: a new job (C 4.2.1.1), carried out at once."""
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        master.ask(5, LV, Pkw(2, 18, values=(1,)), OFF1)
        master.ask(5, LV, Pkw(2, 18, values=(2,)), OFF1)
        value = sim.call(lambda: sim.drive.value(18))
    assert value == 2


def test_latency_in_seconds() -> None:
    setup = engine(5, "generic", "v,2", latency=JobLatency(seconds=1.0))
    with LineSim(setup) as sim, sim.master() as master:
        early = master.ask(5, LV, Pkw(1, 52), OFF1).pkw
        time.sleep(1.1)
        late = master.ask(5, LV, Pkw(1, 52), OFF1).pkw
    assert early.id == 0
    assert (late.id, late.values) == (1, (0x4000,))
