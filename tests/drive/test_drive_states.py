"""The drive profile's state machine (C 5.2.1): every transition, ramps, status bits."""

from __future__ import annotations

import pytest

from pyuss.drive.states import DriveState, DriveStateMachine, Motion
from pyuss.protocol.pzd import ControlWord as C
from pyuss.protocol.pzd import StatusWord as S

PLC = C.CONTROL_BY_PLC
OFF1 = PLC | C.NO_OFF2 | C.NO_OFF3 | C.ENABLE_OPERATION | 0x70  # 047Eh
RUN = OFF1 | C.ON  # 047Fh
MOTION = Motion(ramp_up=10.0, ramp_down=4.0, quick_stop=1.0, coast=8.0, tolerance=0.01)


def running_machine(setpoint: float = 0.5, motion: Motion = MOTION) -> DriveStateMachine:
    m = DriveStateMachine(0.0, motion)
    m.apply(OFF1, 0.0, 0.0)
    m.apply(RUN, setpoint, 0.0)
    return m


def test_power_up_in_switch_on_inhibit() -> None:
    m = DriveStateMachine(0.0, MOTION)
    assert m.state is DriveState.SWITCH_ON_INHIBIT
    assert m.status_word() == S.SWITCH_ON_INHIBITED | S.CONTROL_REQUESTED


def test_not_ready_during_initialisation() -> None:
    m = DriveStateMachine(5.0, Motion(init=2.0))
    assert m.state is DriveState.NOT_READY
    assert m.status_word() & 0x7F == 0
    m.apply(OFF1, 0.0, 6.0)  # no reaction while initialising
    assert m.state is DriveState.NOT_READY
    m.step(7.0)  # init over: OFF1 already present leads on to ready to switch on
    assert m.state is DriveState.READY_TO_SWITCH_ON


def test_switching_on_needs_off1_first() -> None:
    m = DriveStateMachine(0.0, MOTION)
    m.apply(RUN, 0.5, 0.0)  # ON straight from the inhibit: refused
    assert m.state is DriveState.SWITCH_ON_INHIBIT
    m.apply(OFF1, 0.5, 0.1)
    assert m.state is DriveState.READY_TO_SWITCH_ON
    assert m.status_word() == 0x0231  # uss.json read_word_response
    m.apply(RUN & ~C.ENABLE_OPERATION, 0.5, 0.2)
    assert m.state is DriveState.READY
    assert m.status_word() & 0x7 == S.READY_TO_SWITCH_ON | S.READY
    m.apply(RUN, 0.5, 0.3)
    assert m.state is DriveState.OPERATION
    assert m.status_word() & 0x7 == 0x7


def test_ramp_and_status_bits_8_and_10() -> None:
    motion = Motion(ramp_up=10.0, ramp_down=4.0, tolerance=0.01, tolerance_time=1.0, compare=0.4)
    m = running_machine(0.5, motion)
    m.step(0.5)
    assert m.status_word() & S.IN_TOLERANCE  # within t_max of the setpoint change
    m.step(2.5)
    assert m.actual == pytest.approx(0.25)
    assert not m.status_word() & S.IN_TOLERANCE
    assert not m.status_word() & S.TARGET_REACHED
    m.step(4.0)
    assert m.status_word() & S.TARGET_REACHED  # 40 % >= comparison value 40 %
    m.step(5.0)
    assert m.actual == 0.5
    assert m.status_word() == 0x0737  # C 8 example 1 (0337h) plus bit 10 reached


def test_control_by_plc_0_keeps_the_old_process_data() -> None:
    m = running_machine(0.5)
    assert not m.apply(RUN & ~PLC & ~C.ON, 0.9, 1.0)
    assert m.state is DriveState.OPERATION
    assert m.control == RUN and m.setpoint == 0.5


def test_off1_ramps_down_then_ready_to_switch_on() -> None:
    m = running_machine(0.5)
    m.step(5.0)
    m.apply(OFF1, 0.5, 5.0)
    assert m.state is DriveState.OFF1
    assert m.status_word() & 0x7 == 0x7  # still running while ramping down
    m.step(5.0 + 1.999)
    assert m.state is DriveState.OFF1
    m.step(7.0)  # 50 % at 4 s per 100 %: 2 s
    assert m.state is DriveState.READY_TO_SWITCH_ON
    assert m.actual == 0.0


def test_on_again_during_off1_returns_to_operation() -> None:
    m = running_machine(0.5)
    m.step(5.0)
    m.apply(OFF1, 0.5, 5.0)
    m.apply(RUN, 0.5, 6.0)
    assert m.state is DriveState.OPERATION
    m.step(7.0)
    assert m.actual == pytest.approx(0.35)  # 0.25 at 6 s, then up at 0.1 per s


def test_off2_coasts_into_switch_on_inhibit() -> None:
    m = running_machine(0.5)
    m.step(5.0)
    m.apply(RUN & ~C.NO_OFF2, 0.5, 5.0)
    assert m.state is DriveState.SWITCH_ON_INHIBIT
    assert not m.status_word() & S.NO_OFF2
    m.step(6.0)
    assert m.actual == pytest.approx(0.375)  # coasting, 8 s per 100 %


def test_off3_quick_stop_is_not_cancelled() -> None:
    m = running_machine(0.5)
    m.step(5.0)
    m.apply(RUN & ~C.NO_OFF3, 0.5, 5.0)
    assert m.state is DriveState.OFF3
    assert not m.status_word() & S.NO_OFF3
    m.apply(RUN, 0.5, 5.2)  # bit 2 back to 1: the quick stop goes on
    assert m.state is DriveState.OFF3
    m.step(5.5)  # 50 % at 1 s per 100 %
    assert m.state is DriveState.SWITCH_ON_INHIBIT


def test_inhibit_operation_coasts_to_ready() -> None:
    m = running_machine(0.5)
    m.step(5.0)
    m.apply(RUN & ~C.ENABLE_OPERATION, 0.5, 5.0)
    assert m.state is DriveState.READY
    m.step(9.0)
    assert m.actual == 0.0


def test_ramp_generator_bits_4_5_6() -> None:
    m = running_machine(0.5)
    m.step(5.0)
    m.apply(RUN & ~C.START_RAMP_GENERATOR, 1.0, 5.0)  # bit 5 = 0: hold
    m.step(8.0)
    assert m.actual == 0.5
    m.apply(RUN, 1.0, 8.0)
    m.step(9.0)
    assert m.actual == pytest.approx(0.6)
    m.apply(RUN & ~C.ENABLE_SETPOINT, 1.0, 9.0)  # bit 6 = 0: input 0, normal ramp down
    m.step(10.0)
    assert m.actual == pytest.approx(0.35)
    m.apply(RUN & ~C.ENABLE_RAMP_GENERATOR, 1.0, 10.0)  # bit 4 = 0: stop at current limit
    m.step(10.2)
    assert m.actual == pytest.approx(0.15)
    assert m.state is DriveState.OPERATION


def test_fault_and_acknowledge_on_a_rising_edge() -> None:
    m = running_machine(0.5)
    m.step(5.0)
    held = RUN | C.ACKNOWLEDGE_FAULT
    m.apply(held, 0.5, 5.0)
    m.raise_fault(65, 5.0)
    assert m.state is DriveState.FAULT and m.fault_code == 65
    assert m.status_word() & S.FAULT and not m.status_word() & S.OPERATION_ENABLED
    m.apply(held, 0.5, 5.1)  # bit 7 already 1: no edge, no acknowledgement
    assert m.state is DriveState.FAULT
    m.apply(OFF1, 0.5, 5.2)
    m.apply(OFF1 | C.ACKNOWLEDGE_FAULT, 0.5, 5.3)  # rising edge
    # acknowledged into switch-on inhibit; OFF1 present leads on to ready to switch on
    assert m.state is DriveState.READY_TO_SWITCH_ON
    assert m.fault_code == 0


def test_fault_with_its_cause_present_cannot_be_acknowledged() -> None:
    m = DriveStateMachine(0.0, MOTION)
    m.raise_fault(7, 0.0, cause_present=True)
    m.apply(PLC | C.ACKNOWLEDGE_FAULT, 0.0, 0.1)
    assert m.state is DriveState.FAULT
    m.clear_fault_cause(7)
    m.apply(PLC, 0.0, 0.2)
    m.apply(PLC | C.ACKNOWLEDGE_FAULT, 0.0, 0.3)
    assert m.state is DriveState.SWITCH_ON_INHIBIT


def test_jog_from_standstill_and_back() -> None:
    motion = Motion(quick_stop=1.0, jog1=0.2, jog2=-0.1, jog_ramp=2.0)
    m = running_machine(0.0, motion)
    m.apply(RUN | C.JOG1, 0.0, 1.0)
    assert m.state is DriveState.JOG
    m.step(1.2)
    assert m.actual == pytest.approx(0.1)
    m.step(3.0)
    assert m.actual == pytest.approx(0.2)
    m.apply(RUN, 0.0, 3.0)  # jog off: brake
    assert m.state is DriveState.JOG
    m.step(3.4)
    assert m.state is DriveState.OPERATION and m.actual == 0.0
    m.apply(RUN | C.JOG2, 0.0, 4.0)
    m.step(9.0)
    assert m.actual == pytest.approx(-0.1)


def test_jog_needs_standstill_with_setpoint_zero() -> None:
    m = running_machine(0.5, Motion(jog1=0.2))
    m.apply(RUN | C.JOG1, 0.5, 1.0)
    assert m.state is DriveState.OPERATION


FAMILY_JOG = Motion(quick_stop=1.0, jog1=0.2, jog2=-0.1, jog_ramp=2.0, jog_switches_on=True)


def test_a_familys_jog_switches_the_drive_on_from_standstill_and_off_again() -> None:
    """MICROMASTER 4 / SINAMICS: jog right with ON/OFF1 = 0 (057Eh) switches on, runs to the
    jog setpoint while the bit is set, brakes when it drops, ready to switch on at standstill."""
    m = DriveStateMachine(0.0, FAMILY_JOG)
    m.apply(OFF1 | C.JOG1, 0.0, 1.0)  # straight from switch-on inhibit: OFF1, then jog
    assert m.state is DriveState.JOG
    assert m.status_word() & 0x7 == 0x7  # switched on, pulses enabled
    m.step(3.0)
    assert m.actual == pytest.approx(0.2)
    m.apply(OFF1, 0.0, 3.0)  # jog off: brake on the jog ramp
    assert m.state is DriveState.JOG and m.status_word() & S.OPERATION_ENABLED
    m.step(3.4)
    assert m.state is DriveState.READY_TO_SWITCH_ON and m.actual == 0.0
    assert m.status_word() == 0x0231
    m.apply(OFF1 | C.JOG2, 0.0, 4.0)
    m.step(9.0)
    assert m.state is DriveState.JOG and m.actual == pytest.approx(-0.1)


def test_a_familys_jog_bits_are_not_acted_on_while_switched_on() -> None:
    m = running_machine(0.0, FAMILY_JOG)
    assert m.state is DriveState.OPERATION
    m.apply(RUN | C.JOG1, 0.0, 1.0)
    m.step(5.0)
    assert m.state is DriveState.OPERATION and m.actual == 0.0


def test_a_familys_jog_needs_operation_enabled_and_stops_when_it_is_inhibited() -> None:
    m = DriveStateMachine(0.0, FAMILY_JOG)
    m.apply(OFF1 & ~C.ENABLE_OPERATION | C.JOG1, 0.0, 1.0)
    assert m.state is DriveState.READY_TO_SWITCH_ON
    m.apply(OFF1 | C.JOG1, 0.0, 2.0)
    m.step(4.0)
    assert m.state is DriveState.JOG
    m.apply(OFF1 & ~C.ENABLE_OPERATION | C.JOG1, 0.0, 4.0)  # pulses off: the motor coasts
    assert m.state is DriveState.READY_TO_SWITCH_ON and not m.running
    m.apply(OFF1 & ~C.NO_OFF2 | C.JOG1, 0.0, 5.0)  # OFF2 with the jog bit still set
    assert m.state is DriveState.SWITCH_ON_INHIBIT


def test_an_on_during_a_familys_jog_waits_for_the_jog_to_end() -> None:
    m = DriveStateMachine(0.0, FAMILY_JOG)
    m.apply(OFF1 | C.JOG1, 0.0, 0.0)
    m.apply(RUN | C.JOG1, 0.5, 1.0)
    m.step(3.0)
    assert m.state is DriveState.JOG and m.actual == pytest.approx(0.2)
    m.apply(RUN, 0.5, 3.0)  # the jog ends: brake, then the ON asked for switches on
    m.step(3.4)
    assert m.state is DriveState.OPERATION


def test_wait_time_in_ready_falls_back_to_inhibit() -> None:
    m = DriveStateMachine(0.0, Motion(wait=30.0))
    m.apply(OFF1, 0.0, 0.0)
    m.apply(RUN & ~C.ENABLE_OPERATION, 0.0, 1.0)
    m.step(30.9)
    assert m.state is DriveState.READY
    m.step(31.0)
    assert m.state is DriveState.SWITCH_ON_INHIBIT
    forever = DriveStateMachine(0.0, Motion(wait=20 * 60.0))
    forever.apply(OFF1, 0.0, 0.0)
    forever.apply(RUN & ~C.ENABLE_OPERATION, 0.0, 1.0)
    forever.step(10_000.0)
    assert forever.state is DriveState.READY  # 20 min means "infinite"


def test_one_big_step_equals_many_small_ones() -> None:
    big, small = running_machine(0.8), running_machine(0.8)
    big.apply(OFF1, 0.8, 6.0)
    small.step(6.0)
    small.apply(OFF1, 0.8, 6.0)
    big.step(7.0)
    for i in range(1, 101):
        small.step(6.0 + i * 0.01)
    assert small.state is big.state is DriveState.OFF1
    assert small.actual == pytest.approx(big.actual) == pytest.approx(0.35)
    big.step(20.0)
    assert big.state is DriveState.READY_TO_SWITCH_ON
