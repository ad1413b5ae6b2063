"""SimulatedDrive: process data, displays, parameters that steer the simulation, profiles."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pyuss.drive.faults import DriveErrorNumber, ParameterFault
from pyuss.drive.loader import load_database
from pyuss.drive.memory import ParameterChange
from pyuss.drive.simulated import SimulatedDrive
from pyuss.drive.states import DriveState
from pyuss.drive.store import ParameterStore
from pyuss.protocol.pzd import ControlWord, StatusWord, join_dword, split_dword
from support.paths import load_vectors


def vector_words(name: str) -> list[int]:
    for vector in load_vectors("uss")["telegrams"]:
        if vector["name"] == name:
            return [int(w, 16) for w in vector["words_hex"]]
    raise KeyError(name)


def test_c8_example_1_process_data() -> None:
    drive = SimulatedDrive.from_profile("generic")
    request = vector_words("pzd_only_request")  # 047F, setpoint 2000h = 50 %
    drive.exchange([0x047E, 0x0000], 0.0)  # OFF1 first: leaves the switch-on inhibit
    first = drive.exchange(request, 0.1)
    assert first[0] & StatusWord.OPERATION_ENABLED
    reply = drive.exchange(request, 60.0)  # ramp done (10 s per 100 %)
    assert list(reply) == vector_words("pzd_only_response")  # 0337h, 2000h


def test_c8_example_2_status_after_047e() -> None:
    drive = SimulatedDrive.from_profile("generic")
    request = vector_words("read_word_request")
    assert list(drive.exchange(request[3:], 0.0)) == vector_words("read_word_response")[3:]


def test_6se21_p20_switch_on_mode_cleared_by_047e() -> None:
    drive = SimulatedDrive.from_profile("6se21")
    assert drive.value(20) == 3  # SIMOVERT P 6SE21 manual 7.5.1.1: P20 = 003 at power-up
    assert drive.status_word() & StatusWord.SWITCH_ON_INHIBITED  # bit 6 in the answer
    init = vector_words("6se21_init")
    drive.exchange(init[3:], 0.0)  # PZD1 047Eh
    assert not drive.status_word() & StatusWord.SWITCH_ON_INHIBITED
    assert drive.value(20) != 3
    assert drive.state is DriveState.READY_TO_SWITCH_ON


def test_bit_10_zero_ignores_the_telegram() -> None:
    drive = SimulatedDrive.from_profile("6se21")
    assert drive.exchange([0x007E, 0x0000], 0.0)[0] & StatusWord.SWITCH_ON_INHIBITED
    assert drive.state is DriveState.SWITCH_ON_INHIBIT


def test_displays_follow_the_drive() -> None:
    drive = SimulatedDrive.from_profile("generic")
    assert drive.value(1) == 8  # r001: switch-on inhibit
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0x2000], 0.0)
    drive.step(2.0)  # 20 % of 50 Hz
    assert drive.value(2) == 1000  # 10.00 Hz in 0.01 Hz
    assert drive.value(3) == 2500  # ramp input 25.00 Hz
    assert drive.value(1) == 14
    assert drive.value(550) == 0x047F
    assert drive.value(552) == drive.status_word()


def test_parameters_steer_the_simulation() -> None:
    drive = SimulatedDrive.from_profile("generic")
    drive.write_words(462, [20], interface="uss")  # ramp-up 2.0 s
    drive.write_words(796, [2500], interface="uss")  # comparison value 25 Hz = 50 %
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0x2000], 0.0)
    drive.step(0.5)
    assert drive.actual_value() == 0x1000  # 25 % after 0.5 s
    assert not drive.status_word() & StatusWord.TARGET_REACHED
    drive.step(1.0)
    assert drive.status_word() & StatusWord.TARGET_REACHED


def test_jog_setpoint_in_hz_relative_to_the_reference() -> None:
    drive = SimulatedDrive.from_profile("generic")  # jog 1 = 5.00 Hz of 50.00 Hz
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F | ControlWord.JOG1, 0], 0.0)
    drive.step(10.0)
    assert drive.state is DriveState.JOG
    assert drive.actual_value() == 0x0666  # 10 %


def test_stopped_only_parameter_is_refused_while_running() -> None:
    drive = SimulatedDrive.from_profile("generic")
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0], 0.0)
    with pytest.raises(ParameterFault) as info:
        drive.write(107, 60.0, interface="uss")
    assert info.value.number == DriveErrorNumber.WRONG_STATE
    drive.exchange([0x047E, 0], 1.0)
    assert drive.write(107, 60.0, interface="uss") == 60.0


def test_fault_is_shown_and_reported() -> None:
    drive = SimulatedDrive.from_profile("generic")
    seen: list[ParameterChange] = []
    drive.subscribe("uss", seen.append)
    code = drive.db.faults["telegram_failure"]
    drive.raise_fault(code, 1.0)
    assert drive.status_word() & StatusWord.FAULT
    assert drive.value(947) == code
    assert drive.value(1) == 7
    assert ParameterChange(947, None, (code,), False, "local") in seen  # P947 is active
    drive.exchange([0x047E, 0], 2.0)
    drive.exchange([0x04FE, 0], 2.1)  # acknowledge
    assert drive.value(947) == 0
    assert drive.state is DriveState.READY_TO_SWITCH_ON


def test_warning_sets_status_bit_7() -> None:
    drive = SimulatedDrive.from_profile("generic")
    drive.raise_warning(12)
    assert drive.status_word() & StatusWord.WARNING and drive.value(953) == 12
    drive.clear_warning(12)
    assert not drive.status_word() & StatusWord.WARNING and drive.value(953) == 0


def test_thirty_two_bit_setpoint_and_actual() -> None:
    drive = SimulatedDrive.from_profile("baumueller")
    drive.apply_control(0x047E, None, 0.0)
    drive.apply_control(0x047F, join_dword(0x2000, 0x0000), 0.0, bits=32)
    drive.step(10.0)
    assert split_dword(drive.actual_value(bits=32)) == (0x2000, 0x0000)
    assert drive.actual_value() == 0x2000
    assert drive.value(51) == 0x2000  # normalised actual display (no unit: 4000h = 100 %)


def test_negative_setpoint_and_clamped_actual() -> None:
    drive = SimulatedDrive.from_profile("baumueller")
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0xE000], 0.0)  # -50 %
    drive.step(10.0)
    assert drive.actual_value() == 0xE000
    drive.exchange([0x047F, 0x7FFF], 10.0)
    drive.step(30.0)
    assert drive.actual_value() == 0x7FFF


def test_exchange_keeps_the_length_and_maps_more_words(tmp_path: Path) -> None:
    path = tmp_path / "p.toml"
    path.write_text(
        '[profile]\nname = "plus"\nextends = "generic"\n'
        "[process]\nsetpoints = [18]\nactuals = [52, 0, 900]\n"
        '[[parameter]]\npnu = 900\nname = "Address"\ntype = "uint16"\ndefault = 5\n'
    )
    drive = SimulatedDrive(load_database(path))
    assert drive.exchange([], 0.0) == ()
    assert len(drive.exchange([0x047E], 0.0)) == 1
    reply = drive.exchange([0x047E, 0, 0x1234, 9, 9, 9], 0.0)
    assert reply[2:] == (0x4000, 0, 5, 0)
    assert drive.value(18) == 0x1234  # PZD3 setpoint into P18
    drive.exchange([0x007E, 0, 0x4321], 0.1)  # bit 10 = 0: kept
    assert drive.value(18) == 0x1234


def test_float_parameters_of_micromaster4() -> None:
    drive = SimulatedDrive.from_profile("micromaster4")
    assert drive.value(2) == 1  # r0002 "ready"
    drive.write(1120, 2.0, interface="uss")  # ramp-up 2 s
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0x4000], 0.0)
    drive.step(1.0)
    assert drive.value(21) == pytest.approx(25.0)  # r0021 in Hz, float
    assert drive.value(947, 0) == 0
    drive.raise_fault(drive.db.faults["telegram_failure"], 1.5)
    assert drive.value(947, 0) == 72
    assert drive.value(2) == 2


def test_power_cycle_of_a_simulated_drive(tmp_path: Path) -> None:
    store = tmp_path / "d.store"
    drive = SimulatedDrive.from_profile("generic", store=store)
    drive.write_words(462, [20], interface="uss", eeprom=True)
    drive.exchange([0x047E, 0], 0.0)
    drive = SimulatedDrive.from_profile("generic", store=store, now=100.0)
    assert drive.value(462) == 20
    assert drive.state is DriveState.SWITCH_ON_INHIBIT
    drive.exchange([0x047E, 0], 100.0)
    drive.exchange([0x047F, 0x4000], 100.0)
    drive.step(101.0)
    assert drive.actual_value() == 0x2000  # the stored ramp time is in force


def _running_at_half_speed() -> SimulatedDrive:
    """A generic drive at 50 % of its 50.00 Hz reference (25.00 Hz, P2 and P3 = 2500)."""
    drive = SimulatedDrive.from_profile("generic")
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0x2000], 0.0)
    drive.step(20.0)
    assert drive.value(2) == drive.value(3) == 2500
    return drive


def test_a_display_changed_elsewhere_is_shown_again_at_the_next_step() -> None:
    # the drive writes its displays only when they change: one overwritten by another path
    # (here the drive's own update) must not keep the foreign value while nothing moves
    drive = _running_at_half_speed()
    for pnu in (1, 2, 3, 550, 552):
        held = drive.value(pnu)
        drive.update(pnu, 1234)
        drive.step(20.0)  # same time: the machine's values are the same as before
        assert drive.value(pnu) == held
        drive.update(pnu, 4321)
        drive.exchange([0x047F, 0x2000], 20.5)  # same control word and setpoint
        assert drive.value(pnu) == held


def test_level_displays_follow_a_changed_reference() -> None:
    drive = _running_at_half_speed()
    drive.update(352, 4000)  # reference 40.00 Hz: 50 % is now 20.00 Hz
    drive.step(20.0)
    assert drive.value(2) == drive.value(3) == 2000
    drive.restore_factory()  # back to 50.00 Hz
    assert drive.value(352) == 5000
    drive.step(20.1)
    assert drive.value(2) == drive.value(3) == 2500


def test_level_displays_use_the_stored_reference_from_power_up(tmp_path: Path) -> None:
    store = tmp_path / "d.store"
    ParameterStore(store, "generic").save({(352, None): (4000,)})
    drive = SimulatedDrive.from_profile("generic", store=store)
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0x2000], 0.0)
    drive.step(20.0)
    assert drive.value(2) == drive.value(3) == 2000


def test_unchanged_displays_are_not_reported_again() -> None:
    drive = SimulatedDrive.from_profile("generic")
    seen: list[ParameterChange] = []
    drive.subscribe("uss", seen.append)
    for t in (0.0, 0.1, 0.2):
        drive.exchange([0x047E, 0], t)
    code = drive.db.faults["telegram_failure"]
    drive.raise_fault(code, 1.0)
    for t in (1.1, 1.2):
        drive.exchange([0x047E, 0], t)
    assert seen == [ParameterChange(947, None, (code,), False, "local")]  # P947 is active
    drive.update(947, 0)  # the display changed elsewhere: shown and reported again
    drive.step(1.3)
    assert drive.value(947) == code
    assert seen[-1] == ParameterChange(947, None, (code,), False, "local")


def test_in_commissioning_a_jog_does_not_switch_the_drive_on() -> None:
    drive = SimulatedDrive.from_profile("micromaster440")
    drive.write(10, 1)  # P0010 = 1: quick commissioning
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047E | ControlWord.JOG1, 0], 0.1)
    assert drive.state is DriveState.READY_TO_SWITCH_ON
    drive.write(10, 0)
    drive.exchange([0x047E | ControlWord.JOG1, 0], 0.2)
    assert drive.state is DriveState.JOG


@pytest.mark.parametrize("profile", ["micromaster440", "sinamics-v20"])
def test_a_running_motor_draws_current_at_a_voltage_by_v_f(profile: str) -> None:
    """r0025/r0027/r0032 of the simulation's motor model: 0 with the pulses off; running,
    the voltage follows V/f up to the rated voltage (P0304), the current and the power rise
    with the speed, and at the rated point the current is the rated current (P0305)."""
    drive = SimulatedDrive.from_profile(profile)
    rated_voltage, rated_current = drive.value(304, 0), drive.value(305, 0)
    assert [drive.value(p) for p in (25, 27, 32)] == [0, 0, 0]
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0x2000], 0.1)  # 50 % of P2000 = 50 Hz: 25 Hz
    drive.exchange([0x047F, 0x2000], 30.0)
    half = [drive.value(p) for p in (21, 25, 27, 32)]
    assert half[0] == pytest.approx(25.0)
    assert half[1] == pytest.approx(rated_voltage / 2, rel=1e-3)
    assert 0 < half[2] < rated_current and half[3] > 0
    drive.exchange([0x047F, 0x4000], 30.1)  # 50 Hz, the rated frequency (P0310)
    drive.exchange([0x047F, 0x4000], 60.0)
    rated = [drive.value(p) for p in (21, 25, 27, 32)]
    assert rated[0] == pytest.approx(50.0)
    assert rated[1] == pytest.approx(rated_voltage, rel=1e-3)
    assert rated[2] == pytest.approx(rated_current, rel=1e-3) and rated[3] > half[3]
    drive.exchange([0x047C, 0x4000], 60.1)  # OFF2: pulses off at once
    assert [drive.value(p) for p in (25, 27, 32)] == [0, 0, 0]
    # the DC link stays charged while the drive is powered: the peak of its supply
    assert drive.value(26) == pytest.approx(math.sqrt(2) * rated_voltage, rel=1e-3)
