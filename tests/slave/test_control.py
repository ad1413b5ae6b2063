"""The drive profile's state machine (C 5.2.1) driven by control words over TCP, raw bytes.

Ramp times are set through the parameter channel first: 0 s makes a ramp end within the
telegram that starts it, 999.9 s keeps it under way for the whole test, so no assertion
depends on how fast the machine is.
"""

from __future__ import annotations

from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from slave.harness import LineSim, Master, engine

LV = Layout(127, 2)

OFF1 = 0x047E  # bits 1..6 and 10: OFF1 with no OFF2/OFF3, control by PLC
ON = 0x047F  # ON and enable operation
ACK = 0x0080  # bit 7
JOG1 = 0x0100
JOG2 = 0x0200
NO_OFF2 = 0x0002
NO_OFF3 = 0x0004

# status word bits (C Tables 5.5, 5.6)
READY_TO_SWITCH_ON = 0x0001
READY = 0x0002
OPERATION = 0x0004
FAULT = 0x0008
SWITCH_ON_INHIBIT = 0x0040
IN_TOLERANCE = 0x0100
REACHED = 0x0400

RAMP_UP, RAMP_DOWN, QUICK_STOP, TOLERANCE_TIME = 462, 464, 466, 794
SLOW = 9999  # 999.9 s
STATE, ACTUAL_HZ, CONTROL_DISPLAY, FAULT_NUMBER = 1, 2, 550, 947


class Drive:
    """Slave 5 over the line: control word and setpoint in, status word and actual value out."""

    def __init__(self, master: Master) -> None:
        self.master = master

    def send(self, control: int, setpoint: int = 0, job: Pkw | None = None) -> tuple[int, int]:
        net = self.master.ask(5, LV, job or Pkw(0), (control, setpoint))
        return net.pzd[0], net.pzd[1]

    def read(self, pnu: int, control: int = OFF1, setpoint: int = 0) -> int:
        net = self.master.ask(5, LV, Pkw(1, pnu), (control, setpoint))
        assert net.pkw.id == 1, net.pkw
        return int(net.pkw.values[0])

    def write(self, pnu: int, value: int) -> None:
        # bit 10 = 0: the process data of these telegrams are not taken
        net = self.master.ask(5, LV, Pkw(2, pnu, values=(value,)), (0, 0))
        assert (net.pkw.id, net.pkw.values) == (1, (value,)), net.pkw


def _serve() -> LineSim:
    return LineSim(engine(5, "generic", "v,2", spontaneous=False))


def test_switching_on_and_the_status_bits() -> None:
    with _serve() as sim, sim.master() as master:
        drive = Drive(master)
        drive.write(RAMP_UP, 0)
        power_up = drive.send(0x0000)  # bit 10 = 0: not taken
        off1 = drive.send(OFF1)
        on_at_once = drive.send(0x0477, 0x2000)  # ON, no OFF2/OFF3, operation not enabled
        half = drive.send(ON, 0x2000)
        full = drive.send(ON, 0x4000)
        hz = drive.read(ACTUAL_HZ, ON, 0x4000)
        drive.write(TOLERANCE_TIME, 0)
        drive.write(RAMP_UP, SLOW)
        lagging = drive.send(ON, -0x4000 & 0xFFFF)
    assert power_up == (SWITCH_ON_INHIBIT | 0x0200, 0)  # status bit 9: control requested
    assert off1[0] == 0x0231  # ready to switch on, no OFF2, no OFF3 (C 8.1 example 2)
    assert on_at_once[0] & (READY_TO_SWITCH_ON | READY | OPERATION) == READY_TO_SWITCH_ON | READY
    assert half == (0x0337, 0x2000)  # C 8.1 example 1: in operation at 50 %
    assert full == (0x0737, 0x4000)  # bit 10: actual value reached; 4000h = 100 %
    assert hz == 5000  # 100 % = the reference P352, 50.00 Hz
    status, actual = lagging
    assert not status & IN_TOLERANCE  # far from the new setpoint, t_max 0
    assert status & REACHED  # still at 100 % on its way down
    assert 0x3000 < actual <= 0x4000


def test_off1_ramps_off3_stops_quickly_off2_coasts() -> None:
    with _serve() as sim, sim.master() as master:
        drive = Drive(master)
        drive.write(RAMP_UP, 0)
        drive.write(RAMP_DOWN, SLOW)
        drive.write(QUICK_STOP, 0)
        drive.send(OFF1)
        drive.send(ON, 0x4000)
        ramping = drive.send(OFF1, 0x4000)  # OFF1: down the ramp-down time
        state_off1 = drive.read(STATE, OFF1, 0x4000)
        back = drive.send(ON, 0x4000)  # ON again during OFF1: operation again
        quick = drive.send(ON & ~NO_OFF3, 0x4000)  # OFF3: quick stop (0 s), then inhibit
        still = drive.send(ON, 0x4000)  # bit 2 back to 1: stays in the switch-on inhibit
        drive.send(OFF1)
        drive.send(ON, 0x4000)
        coasting = drive.send(ON & ~NO_OFF2, 0x4000)  # OFF2: pulses off at once, coasts
    assert ramping[0] & OPERATION  # the ramp is under way with pulses on
    assert not ramping[0] & SWITCH_ON_INHIBIT
    assert 0x3000 < ramping[1] <= 0x4000
    assert state_off1 == 15  # r001 "OFF1"
    assert back[0] & (OPERATION | IN_TOLERANCE) == OPERATION | IN_TOLERANCE
    assert quick == (0x0250, 0)  # inhibit, no OFF2, OFF3 pending (bit 5 = 0), standing
    assert still[0] & SWITCH_ON_INHIBIT  # "switching on again only by OFF1 and then ON"
    status, actual = coasting
    assert status & ~REACHED == 0x0260  # inhibit, OFF2 pending (bit 4 = 0), no OFF3
    assert 0x3000 < actual <= 0x4000  # coasting down on the ramp-down time, not stopped


def test_fault_is_acknowledged_on_a_rising_edge_of_bit_7() -> None:
    with _serve() as sim, sim.master() as master:
        drive = Drive(master)
        drive.write(RAMP_UP, 0)
        drive.write(RAMP_DOWN, 0)
        drive.send(OFF1)
        drive.send(ON | ACK, 0x2000)  # bit 7 already 1 when the fault comes
        sim.call(lambda: sim.drive.raise_fault(99))
        held = drive.send(ON | ACK, 0x2000)  # no edge: no acknowledgement
        number = drive.read(FAULT_NUMBER, ON, 0x2000)
        dropped = drive.send(ON, 0x2000)
        acknowledged = drive.send(ON | ACK, 0x2000)  # rising edge
        cleared = drive.read(FAULT_NUMBER, ON | ACK, 0x2000)
        again = [drive.send(OFF1), drive.send(ON, 0x2000)]
    assert held == (0x0238, 0)  # fault, pulses off
    assert number == 99
    assert dropped[0] & FAULT
    assert acknowledged == (0x0270, 0)  # switch-on inhibit
    assert cleared == 0
    assert again == [(0x0231, 0), (0x0337, 0x2000)]


def test_jog_1_and_2_from_standstill() -> None:
    with _serve() as sim, sim.master() as master:
        drive = Drive(master)
        drive.write(RAMP_UP, 0)
        drive.write(QUICK_STOP, 0)  # the jog ramp: "as fast as possible"
        drive.send(OFF1)
        drive.send(ON)
        jog1 = drive.send(ON | JOG1)
        stop = drive.send(ON)
        jog2 = drive.send(ON | JOG2)
        drive.send(ON)
        not_standing = drive.send(ON | JOG1, 0x2000)  # setpoint not 0: no jog
    # P448 = 5.00 Hz, P449 = -5.00 Hz of the 50.00 Hz reference: +-10 % = +-0666h
    assert jog1[0] & OPERATION and abs(jog1[1] - 0x0666) <= 1
    assert stop == (0x0337, 0)  # braked, back in operation at standstill
    assert jog2[0] & OPERATION and abs(jog2[1] - 0xF99A) <= 1
    assert not_standing == (0x0337, 0x2000)


def test_a_micromaster_jogs_from_standstill_with_on_off1_zero() -> None:
    """MICROMASTER 440 control word bits 8/9 (jog right/left): with ON/OFF1 = 0 the drive
    switches on and runs at the jog frequency while the bit is set, and is back in "ready to
    switch on" when it drops; while switched on the bits do nothing."""
    with (
        LineSim(engine(5, "micromaster440", "v,2", spontaneous=False)) as sim,
        sim.master() as master,
    ):
        drive = Drive(master)
        net = master.ask(5, LV, Pkw(8, 1060, 0, values=(0, 0)), (0, 0))  # P1060[0] = 0.0 s
        assert net.pkw.id == 5, net.pkw
        drive.send(OFF1)
        jogging = drive.send(OFF1 | JOG1)
        again = drive.send(OFF1 | JOG1)
        stopped = drive.send(OFF1)
        after = drive.send(OFF1)
        drive.send(ON)
        switched_on = drive.send(ON | JOG1)
    # P1058[0] = 5.00 Hz of the 50.00 Hz reference P2000: 10 % = 0666h
    assert jogging[0] & OPERATION and abs(again[1] - 0x0666) <= 1
    assert stopped[1] == 0 and after[0] & 0x7 == READY_TO_SWITCH_ON
    assert switched_on[0] & OPERATION and switched_on[1] == 0  # ON = 1: no jog


def test_bit_10_zero_keeps_the_old_process_data() -> None:
    with _serve() as sim, sim.master() as master:
        drive = Drive(master)
        drive.write(RAMP_UP, 0)
        drive.send(OFF1)
        running = drive.send(ON, 0x2000)
        ignored = drive.send(0x0000, 0x4000)  # everything off, 100 %: but bit 10 = 0
        in_force = drive.read(CONTROL_DISPLAY, 0x0000, 0x4000)
    assert running == (0x0337, 0x2000)
    assert ignored == running  # neither the OFF nor the setpoint was taken
    assert in_force == ON
