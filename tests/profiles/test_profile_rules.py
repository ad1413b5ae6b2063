"""Each profile's special rules, over TCP with raw bytes."""

from __future__ import annotations

from collections.abc import Sequence

from pyuss.drive import SimulatedDrive
from pyuss.profiles import baumueller, get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, pwe_float
from pyuss.slave import SlaveEngine
from slave.harness import LineSim, engine, frame

OFF1 = 0x047E
L32 = Layout(3, 2)
L33 = Layout(3, 3)
L42 = Layout(4, 2)
LV = Layout(127, 2)


def refused(pkw: Pkw) -> int | None:
    return pkw.values[-1] if pkw.id == 7 else None


# -- 6SE21 (SIMOVERT P 6SE21 manual 7.5)
# ----------------------------------------------------------------------


def test_6se21_uses_14_byte_telegrams_and_answers_ind_0() -> None:
    with LineSim(engine(1, "6se21"), baud=9600) as sim, sim.master() as master:
        assert master.silent(frame(1, "1014 0000 0000 0000 047E 0000"))  # 16 bytes: ignored
        element = master.ask(1, L32, Pkw(4, 20, 7), (OFF1, 0)).pkw
        missing = master.ask(1, L32, Pkw(4, 20, 99), (OFF1, 0)).pkw
        layout = sim.engines[0].layout
    assert layout == L32
    assert (element.id, element.index) == (3, 0)  # IND 7 asked, IND 0 answered
    assert (missing.id, missing.index) == (7, 0)


# -- Baumueller (Baumueller manual part 2)
# ---------------------------------------------------------------


def _baumueller(addresses: Sequence[int], layout: Layout, *, setpoint_id: int | None = None):  # type: ignore[no-untyped-def]
    def make(now: float) -> list[SlaveEngine]:
        profile = get_profile("baumueller")
        engines = []
        for address in addresses:
            drive = SimulatedDrive(profile.database(), now=now)
            drive.update(181, 0x0006)  # broadcast coding and response-delay mode on
            if setpoint_id is not None:
                drive.update(185, setpoint_id)
            engines.append(SlaveEngine(address, drive, profile, layout=layout, now=now))
        return engines

    return make


def test_baumueller_description_elements_and_error_numbers() -> None:
    with LineSim(_baumueller([2], L42)) as sim, sim.master() as master:
        ask = lambda job: master.ask(2, L42, job, (OFF1, 0)).pkw  # noqa: E731
        attribute = ask(Pkw(4, 50, 1))
        info = ask(Pkw(4, 50, 2))
        minimum = ask(Pkw(4, 50, 5))
        maximum = ask(Pkw(4, 50, 6))
        other = ask(Pkw(4, 50, 3))
        array_job = ask(Pkw(6, 50, 1))
        text_job = ask(Pkw(15, 50, 1))
        protected = ask(Pkw(4, 185, 2))
    # attribute: 2 bytes (01), signed (00), one element, data, format DEC (0001), 0 decimals
    assert (attribute.id, attribute.values) == (3, (0, 0x0101))
    assert info.values == (0, 0x0008)  # not protected, stored
    assert minimum.values == (0, 0x8000)
    assert maximum.values == (0, 0x7FFF)
    assert refused(other) == 104  # element does not exist
    assert refused(array_job) == 102  # request IDs 0..4 only
    assert refused(text_job) == 102
    assert protected.values == (0, 0x0009)  # display only: write protection 1


def test_baumueller_prepared_answers_without_response_delay_mode() -> None:
    """181 bit 2 = 0: each answer is the one prepared after the previous request (2.5)."""
    with LineSim(engine(2, "baumueller", "3,2")) as sim, sim.master() as master:
        ask = lambda job: master.ask(2, L32, job, (OFF1, 0)).pkw  # noqa: E731
        first = ask(Pkw(1, 183))
        second = ask(Pkw(1, 184))
        third = ask(Pkw(1, 184))
        switch = ask(Pkw(2, 181, values=(0x0004,)))  # response-delay mode on
        fourth = ask(Pkw(1, 183))
        fifth = ask(Pkw(1, 184))
        window = sim.call(lambda: sim.engines[0].response_window(sim.baud))
    assert first.id == 0  # nothing prepared yet
    assert (second.pnu, second.values) == (183, (3,))
    assert (third.pnu, third.values) == (184, (2,))
    assert (switch.pnu, switch.values) == (184, (2,))
    assert (fourth.pnu, fourth.values) == (183, (3,))  # from now on: processed, then answered
    assert (fifth.pnu, fifth.values) == (184, (2,))
    assert window[1] == 0.020


def test_baumueller_too_large_is_103() -> None:
    with LineSim(engine(2, "baumueller", "3,2")) as sim, sim.master() as master:
        master.ask(2, L32, Pkw(2, 181, values=(4,)), (OFF1, 0))  # delay mode: direct answers
        answer = master.ask(2, L32, Pkw(1, 70), (OFF1, 0)).pkw  # int32 in PKW 3
    assert refused(answer) == 103


def test_baumueller_masked_control_word_broadcast() -> None:
    with LineSim(_baumueller([2], L32)) as sim, sim.master() as master:
        master.ask(2, L32, Pkw(0), (OFF1, 0x1000))
        assert master.silent(frame(0x20, "0000 0000 0001 047F 2000"))  # mask: bit 0 only
        control, setpoint = sim.call(
            lambda: (sim.drive.machine.control, sim.drive.machine.setpoint)
        )
        assert master.silent(frame(0x20, "1000 0000 FFFF 0000 0000"))  # a job: not taken
        unchanged = sim.call(lambda: sim.drive.machine.control)
    assert control == 0x047F
    assert setpoint == 0x1000 / 0x4000  # setpoints are not taken from broadcasts
    assert unchanged == 0x047F


def test_baumueller_broadcast_without_pkw_takes_the_whole_control_word() -> None:
    with LineSim(_baumueller([2], Layout(0, 2))) as sim, sim.master() as master:
        assert master.silent(frame(0x20, "047F 2000"))
        control = sim.call(lambda: sim.drive.machine.control)
    assert control == 0x047F


def test_baumueller_broadcast_address_coding() -> None:
    """181 bit 1: PZD2/PZD3 name the addresses that react (here 0, 9 and 23)."""
    high, low = baumueller.address_mask([0, 9, 23])
    with LineSim(_baumueller([9, 5], L33)) as sim, sim.master() as master:
        assert master.silent(frame(0x20, f"0000 0000 FFFF 047E {high:04X} {low:04X}"))
        controls = sim.call(lambda: [e.drive.machine.control for e in sim.engines])
    assert controls == [0x047E, 0]


def test_baumueller_32_bit_setpoint_over_pzd2_and_pzd3() -> None:
    with LineSim(_baumueller([2], L33, setpoint_id=70)) as sim, sim.master() as master:
        answer = master.ask(2, L33, Pkw(0), (OFF1, 0x0001, 0x0002))
        p70 = sim.call(lambda: sim.drive.value(70))
    assert p70 == 0x0001_0002
    assert answer.pzd[1] == 0  # the 16-bit actual value (P51) travels in PZD3


def test_baumueller_16_bit_setpoint_in_pzd3_and_format_fault() -> None:
    with LineSim(_baumueller([2], L33)) as sim, sim.master() as master:
        master.ask(2, L33, Pkw(0), (OFF1, 0x7777, 0x1234))
        p50 = sim.call(lambda: sim.drive.value(50))
    assert p50 == 0x1234
    with LineSim(_baumueller([2], L32, setpoint_id=70)) as sim, sim.master() as master:
        master.ask(2, L32, Pkw(0), (OFF1, 0x0001))
        state = master.ask(2, L32, Pkw(1, 180), (OFF1, 0x0001)).pkw
    assert state.values[0] & baumueller.SETPOINT_FORMAT_FAULT  # 32 bits do not fit PZD 2


# -- NORD (NORD BU 0050) ---------------------------------------------------------------------------


def test_nord_defaults_and_error_numbers() -> None:
    with LineSim(engine(3, "nord")) as sim, sim.master() as master:
        layout = sim.engines[0].layout
        text = master.ask(3, L42, Pkw(15, 511, 1), (OFF1, 0)).pkw
        reserved = master.ask(3, L42, Pkw(10, 511), (OFF1, 0)).pkw
    assert layout == L42
    assert refused(text) == 202
    assert refused(reserved) == 201


# -- MICROMASTER 4 -----------------------------------------------------------------------------


def test_micromaster4_reaches_parameters_above_1999_through_the_page_bits() -> None:
    with LineSim(engine(4, "micromaster4"), baud=9600) as sim, sim.master() as master:
        ask = lambda job: master.ask(4, LV, job, (OFF1, 0)).pkw  # noqa: E731
        baud = ask(Pkw(6, 10, 0x8001))  # P2010[1]: the line runs at 9600 baud, code 6
        write = ask(Pkw(7, 11, 0x8001, values=(7,)))  # P2011[1] = 7
        reference = ask(Pkw(1, 0, 0x8000))  # P2000, float
        low = ask(Pkw(1, 3))  # P3 (page 0)
        reserved = ask(Pkw(10, 3))
        p2011 = sim.call(lambda: sim.drive.value(2011, 1))
    assert (baud.id, baud.pnu, baud.index, baud.values) == (4, 10, 0x8001, (6,))
    assert (write.id, write.index, write.values) == (4, 0x8001, (7,))
    assert p2011 == 7
    assert (reference.id, reference.values) == (2, pwe_float(50.0))
    assert low.values == (1,)
    assert refused(reserved) == 22


def test_micromaster4_too_large_and_no_broadcasts() -> None:
    with LineSim(engine(4, "micromaster4", "4,2")) as sim, sim.master() as master:
        whole = master.ask(4, L42, Pkw(6, 10, 0x80FF), (OFF1, 0)).pkw
        assert master.silent(frame(0x20, "0003 FFFF 0000 0000 047F 2000"))
        control = sim.call(lambda: sim.drive.machine.control)
        spontaneous = sim.engines[0].spontaneous
    assert refused(whole) == 102
    assert control == OFF1  # the broadcast was not taken
    assert not spontaneous


def test_baumueller_write_authority_follows_parameter_126() -> None:
    """Baumueller manual 1.5: only with bit 0 of 126 set may the interfaces change drive
    parameters."""
    with LineSim(_baumueller([2], L32)) as sim, sim.master() as master:
        ask = lambda job: master.ask(2, L32, job, (OFF1, 0)).pkw  # noqa: E731
        off = ask(Pkw(2, 126, values=(0,)))
        denied = ask(Pkw(2, 60, values=(1000,)))
        read = ask(Pkw(1, 60))
        on = ask(Pkw(2, 126, values=(1,)))
        allowed = ask(Pkw(2, 60, values=(1000,)))
    assert (off.id, off.values) == (1, (0,))
    assert denied.id == 8
    assert read.values == (2000,)
    assert (on.id, on.values) == (1, (1,))
    assert (allowed.id, allowed.values) == (1, (1000,))
