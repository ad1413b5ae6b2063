"""The state machine of the drive profile, driven by the control word (C 5.2.1).

States and what leads from one to the next (control bits of C Tables 5.2..5.4):

- ``NOT_READY`` ("nicht einschaltbereit"): electronics initialising after power-up, for the
  profile's init time (0 by default, then the drive starts in the next state at once).
- ``SWITCH_ON_INHIBIT`` ("Einschaltsperre", status bit 6): after power-up, OFF2, OFF3 and a
  fault acknowledgement. Left only by OFF1 with no OFF2/OFF3 (bits 0..2 = 0, 1, 1; for example
  047Eh, SIMOVERT P 6SE21 manual) - "switching on again only by OFF1 and then ON" (C Table 5.5).
- ``READY_TO_SWITCH_ON`` ("einschaltbereit", status bit 0).
- ``READY`` ("betriebsbereit", status bit 1): ON (bit 0 = 1). Without "enable operation" within
  the wait time t_wart the drive falls back to switch-on inhibit (C Table 5.2; 20 min or more
  means never).
- ``OPERATION`` ("Betrieb freigegeben", status bit 2): enable operation (bit 3 = 1). The ramp
  generator runs towards the setpoint: bit 6 = 0 sets its input to 0, bit 5 = 0 holds its
  output, bit 4 = 0 sets the output to 0 (the drive stops at the current limit, modelled as the
  quick-stop ramp). Bit 3 = 0 inhibits operation: pulses off, the motor coasts, state READY.
- ``JOG``: jog 1 or 2 (bits 8, 9) while operation is enabled and the drive stands with setpoint
  0 (C Table 5.4): the drive runs "as fast as possible" (the jog ramp) to the jog setpoint; when
  the jog bit drops it brakes the same way and is back in OPERATION at standstill.
  A family whose jog switches the drive on (``Motion.jog_switches_on``: MICROMASTER 4 and
  SINAMICS, whose manuals give control bits 8/9 as jog right/left) jogs from READY TO SWITCH ON
  instead: with ON/OFF1 = 0 and operation enabled, a jog bit switches the drive on and runs it
  to the jog setpoint while the bit is set; when it drops the drive brakes on the jog ramp and
  is back in READY TO SWITCH ON at standstill. While the drive is switched on (ON = 1) its jog
  bits are not acted on, and an ON during a jog waits for the jog to end. Operation inhibited
  (bit 3 = 0) during such a jog: pulses off, READY TO SWITCH ON.
- ``OFF1``: bit 0 = 0 while running: ramp down on the ramp-down time, at standstill READY TO
  SWITCH ON. ON again during the ramp returns to OPERATION.
- ``OFF3``: bit 2 = 0 while running: quick stop on the OFF3 ramp, then SWITCH-ON INHIBIT. An
  OFF3 under way is not cancelled by bit 2 returning to 1.
- OFF2 (bit 1 = 0) from any state but FAULT: pulses off at once, the motor coasts, SWITCH-ON
  INHIBIT.
- ``FAULT`` (status bit 3) from any state when a fault is raised: pulses off, the motor coasts.
  A rising edge of bit 7 acknowledges it once its cause is gone; then SWITCH-ON INHIBIT.

Not a state: bit 10 "control by PLC". When it is 0 the process data are invalid and the previous
ones stay in force (C Table 5.4): the whole telegram's control word and setpoints are ignored.

Status bits computed besides the state bits: 4/5 mirror control bits 1/2 (OFF2/OFF3 pending
when 0), 7 warning present, 8 actual value within the tolerance band around the setpoint while
running (a deviation is tolerated for t_max after the setpoint changed, C Table 5.6), 9 control
requested (always), 10 |actual| >= the comparison value.

All values are fractions of the reference (1.0 = 100 % = 4000h, C 5.2.2). Time is passed in by
the caller (seconds, any monotonic base); the machine never reads a clock.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from pyuss.drive import ramp
from pyuss.protocol.pzd import ControlWord, StatusWord

# the bits as plain integers: IntFlag arithmetic is slow in a loop run for every telegram
_ON = int(ControlWord.ON)
_NO_OFF2 = int(ControlWord.NO_OFF2)
_NO_OFF3 = int(ControlWord.NO_OFF3)
_ENABLE_OPERATION = int(ControlWord.ENABLE_OPERATION)
_ENABLE_RAMP = int(ControlWord.ENABLE_RAMP_GENERATOR)
_START_RAMP = int(ControlWord.START_RAMP_GENERATOR)
_ENABLE_SETPOINT = int(ControlWord.ENABLE_SETPOINT)
_ACKNOWLEDGE = int(ControlWord.ACKNOWLEDGE_FAULT)
_JOG1 = int(ControlWord.JOG1)
_JOG2 = int(ControlWord.JOG2)
_BY_PLC = int(ControlWord.CONTROL_BY_PLC)

TIME_EPSILON = 1e-9
"""A ramp that ends within this many seconds after a step is taken as ended (float rounding)."""

WAIT_FOREVER = 20 * 60.0
"""t_wart of 20 min or more is "infinite" (C Table 5.2)."""


class DriveState(enum.Enum):
    """States of the drive profile (C 5.2.1); the values name them in ``[state_codes]``."""

    NOT_READY = "not_ready"
    SWITCH_ON_INHIBIT = "switch_on_inhibit"
    READY_TO_SWITCH_ON = "ready_to_switch_on"
    READY = "ready"
    OPERATION = "operation"
    JOG = "jog"
    OFF1 = "off1"
    OFF3 = "off3"
    FAULT = "fault"


_RUNNING = (DriveState.OPERATION, DriveState.JOG, DriveState.OFF1, DriveState.OFF3)
_READY = (DriveState.READY, *_RUNNING)
_SWITCHABLE = (DriveState.READY_TO_SWITCH_ON, *_READY)


def _state_bits(state: DriveState) -> int:
    """Status bits 0, 1, 2, 3, 6 and 9 that follow from the state alone."""
    word = StatusWord.CONTROL_REQUESTED
    if state in _SWITCHABLE:
        word |= StatusWord.READY_TO_SWITCH_ON
    if state in _READY:
        word |= StatusWord.READY
    if state in _RUNNING:
        word |= StatusWord.OPERATION_ENABLED
    if state is DriveState.FAULT:
        word |= StatusWord.FAULT
    if state is DriveState.SWITCH_ON_INHIBIT:
        word |= StatusWord.SWITCH_ON_INHIBITED
    return int(word)


_STATE_BITS = {state: _state_bits(state) for state in DriveState}
_S_NO_OFF2 = int(StatusWord.NO_OFF2)
_S_NO_OFF3 = int(StatusWord.NO_OFF3)
_S_WARNING = int(StatusWord.WARNING)
_S_IN_TOLERANCE = int(StatusWord.IN_TOLERANCE)
_S_REACHED = int(StatusWord.TARGET_REACHED)


@dataclass(frozen=True, slots=True)
class Motion:
    """Settings of the simulated motion; times in seconds, values as fractions of 100 %."""

    ramp_up: float = 10.0
    """Ramp-function generator, 0 to 100 %."""
    ramp_down: float = 10.0
    """Ramp-function generator, 100 % to 0 (also OFF1)."""
    quick_stop: float = 1.0
    """OFF3 ramp, 100 % to 0; also the stop when control bit 4 is 0."""
    coast: float | None = None
    """Coasting from 100 % to standstill with pulses off; None: the ramp-down time."""
    jog_ramp: float | None = None
    """Jog ramp (up and down); None: the OFF3 ramp ("as fast as possible")."""
    jog1: float = 0.0
    jog2: float = 0.0
    jog_switches_on: bool = False
    """The family's jog: bits 8/9 switch the drive on from READY TO SWITCH ON and off again
    (see the module docstring); False: the USS specification's jog from standstill in
    OPERATION."""
    tolerance: float = 0.02
    """Half width of the band around the setpoint for status bit 8."""
    tolerance_time: float = 0.0
    """t_max: how long a deviation after a setpoint change still counts as in tolerance."""
    compare: float = 1.0
    """Status bit 10: |actual| >= compare."""
    wait: float = WAIT_FOREVER
    """t_wart in READY before falling back to switch-on inhibit."""
    init: float = 0.0
    """Duration of NOT_READY after power-up."""


class DriveStateMachine:
    """The drive profile's state machine with its ramp-function generator.

    ``motion`` may be replaced at any time (the simulated drive refreshes it from parameters);
    the new settings apply from then on.
    """

    def __init__(self, now: float = 0.0, motion: Motion | None = None) -> None:
        self.motion = motion or Motion()
        self.time = now
        self.state = DriveState.NOT_READY
        self.control = 0
        """The control word in force (the last one accepted with bit 10 set)."""
        self.setpoint = 0.0
        """The main setpoint in force, a fraction of 100 %."""
        self.actual = 0.0
        """The ramp output and (ideal motor) actual value, a fraction of 100 %."""
        self.fault_code = 0
        self.warnings: dict[int, None] = {}
        self._causes: set[int] = set()
        self._entered = now
        self._jog = 0
        self._target = 0.0
        self._target_since = now
        if self.motion.init <= 0:
            self._enter(DriveState.SWITCH_ON_INHIBIT, now)

    # ------------------------------------------------------------------ inputs

    @property
    def running(self) -> bool:
        """Pulses enabled (operation, jog, OFF1 or OFF3 ramp)."""
        return self.state in _RUNNING

    def step(self, now: float) -> None:
        """Advance the simulation to ``now`` (earlier times are ignored)."""
        if now <= self.time:
            return
        self._run(self.time, now - self.time)
        self.time = now
        self._timers(now)

    def _run(self, t: float, remaining: float) -> None:
        """Move the ramp for ``remaining`` seconds from ``t``, taking the transitions that
        happen on the way (end of OFF1, OFF3, jog braking); 0 s settles an instant change."""
        for _ in range(8):
            mode = self._mode()
            if mode is None:
                break
            target, up, down = mode
            if self.actual == target:
                need = 0.0
            else:
                need = ramp.duration(self.actual, target, ramp.rate_of(up), ramp.rate_of(down))
            if need > remaining + TIME_EPSILON:
                self.actual = ramp.advance(
                    self.actual, target, remaining, ramp.rate_of(up), ramp.rate_of(down)
                )
                break
            self.actual = target
            t += need
            remaining = max(remaining - need, 0.0)
            if not self._reached(t):
                break

    def apply(self, control: int, setpoint: float | None, now: float) -> bool:
        """Take a control word (and main setpoint) from a telegram at time ``now``.

        Returns False when bit 10 "control by PLC" is 0: then nothing is taken over.
        """
        self.step(now)
        if not control & _BY_PLC:
            return False
        acknowledge = bool(control & ~self.control & _ACKNOWLEDGE)
        self.control = control & 0xFFFF
        if setpoint is not None:
            self.setpoint = setpoint
        self._transitions(now, acknowledge)
        self._note_target(now)
        self._run(now, 0.0)
        return True

    def take_setpoint(self, setpoint: float, now: float) -> None:
        """Take a main setpoint alone at time ``now``, the control word in force staying as it
        is (a drive that takes its setpoint from USS and its commands from elsewhere)."""
        self.step(now)
        self.setpoint = setpoint
        self._note_target(now)
        self._run(now, 0.0)

    def raise_fault(self, code: int, now: float, *, cause_present: bool = False) -> None:
        """Trip a fault: pulses off, status bit 3. With ``cause_present`` the fault cannot be
        acknowledged before `clear_fault_cause`."""
        self.step(now)
        if cause_present:
            self._causes.add(code)
        if self.state is not DriveState.FAULT:
            self.fault_code = code
            self._enter(DriveState.FAULT, now)

    def clear_fault_cause(self, code: int) -> None:
        self._causes.discard(code)

    def raise_warning(self, code: int) -> None:
        self.warnings[code] = None

    def clear_warning(self, code: int) -> None:
        self.warnings.pop(code, None)

    # ------------------------------------------------------------------ outputs

    def status_word(self) -> int:
        """The status word for the present state (C Tables 5.5, 5.6)."""
        state, control = self.state, self.control
        word = _STATE_BITS[state]
        if control & _NO_OFF2:
            word |= _S_NO_OFF2
        if control & _NO_OFF3:
            word |= _S_NO_OFF3
        if self.warnings:
            word |= _S_WARNING
        if state in (DriveState.OPERATION, DriveState.JOG) and (
            abs(self._target - self.actual) <= self.motion.tolerance
            or self.time - self._target_since < self.motion.tolerance_time
        ):
            word |= _S_IN_TOLERANCE
        if abs(self.actual) >= self.motion.compare:
            word |= _S_REACHED
        return word

    @property
    def warning_code(self) -> int:
        """The first warning present, 0 for none."""
        return next(iter(self.warnings), 0)

    @property
    def ramp_input(self) -> float:
        """What the ramp-function generator is heading for."""
        return self._target

    # ------------------------------------------------------------------ internals

    def _enter(self, state: DriveState, t: float) -> None:
        if state is not self.state:
            self.state = state
            self._entered = t
        if state is DriveState.FAULT:
            return
        if state is DriveState.SWITCH_ON_INHIBIT and not self._causes:
            self.fault_code = 0

    def _operation_target(self) -> float:
        control = self.control
        if not control & _ENABLE_RAMP:
            return 0.0
        return self.setpoint if control & _ENABLE_SETPOINT else 0.0

    def _jog_target(self) -> float:
        return {1: self.motion.jog1, 2: self.motion.jog2}.get(self._jog, 0.0)

    def _mode(self) -> tuple[float, float, float] | None:
        """(target, ramp-up time, ramp-down time) of the present state; None holds."""
        m, state, control = self.motion, self.state, self.control
        if state is DriveState.OPERATION:
            if not control & _ENABLE_RAMP:
                return 0.0, m.quick_stop, m.quick_stop
            if not control & _START_RAMP:
                return None
            return self._operation_target(), m.ramp_up, m.ramp_down
        if state is DriveState.JOG:
            jog = m.quick_stop if m.jog_ramp is None else m.jog_ramp
            return self._jog_target(), jog, jog
        if state is DriveState.OFF1:
            return 0.0, m.ramp_down, m.ramp_down
        if state is DriveState.OFF3:
            return 0.0, m.quick_stop, m.quick_stop
        coast = m.ramp_down if m.coast is None else m.coast
        return 0.0, coast, coast

    def _reached(self, t: float) -> bool:
        """The ramp reached its target at ``t``: end of OFF1, OFF3 or jog braking."""
        if self.actual != 0.0:
            return False
        if self.state is DriveState.OFF1:
            self._enter(DriveState.READY_TO_SWITCH_ON, t)
        elif self.state is DriveState.OFF3:
            self._enter(DriveState.SWITCH_ON_INHIBIT, t)
        elif self.state is DriveState.JOG and self._jog == 0:
            back = DriveState.READY_TO_SWITCH_ON if self.motion.jog_switches_on else None
            self._enter(back or DriveState.OPERATION, t)
        else:
            return False
        self._transitions(t, False)
        self._note_target(t)
        return True

    def _timers(self, now: float) -> None:
        m = self.motion
        if self.state is DriveState.NOT_READY and now - self._entered >= m.init:
            self._enter(DriveState.SWITCH_ON_INHIBIT, self._entered + m.init)
            self._transitions(now, False)
        elif (
            self.state is DriveState.READY
            and m.wait < WAIT_FOREVER
            and now - self._entered >= m.wait
        ):
            self._enter(DriveState.SWITCH_ON_INHIBIT, self._entered + m.wait)

    def _note_target(self, t: float) -> None:
        if self.state is DriveState.JOG:
            target = self._jog_target()
        elif self.state is DriveState.OPERATION:
            target = self._operation_target()
        else:
            target = 0.0
        if target != self._target:
            self._target = target
            self._target_since = t

    def _transitions(self, t: float, acknowledge: bool) -> None:
        for _ in range(6):
            before = (self.state, self._jog)
            self._transition(t, acknowledge)
            acknowledge = False
            if (self.state, self._jog) == before:
                return

    def _transition(self, t: float, acknowledge: bool) -> None:
        control, state = self.control, self.state
        on = bool(control & _ON)
        enabled = bool(control & _ENABLE_OPERATION)
        if state is DriveState.FAULT:
            if acknowledge and not self._causes:
                self._enter(DriveState.SWITCH_ON_INHIBIT, t)
            return
        if state is DriveState.NOT_READY:
            return
        if not control & _NO_OFF2:
            self._enter(DriveState.SWITCH_ON_INHIBIT, t)
            return
        if not control & _NO_OFF3:
            if state in (DriveState.OPERATION, DriveState.JOG, DriveState.OFF1):
                self._enter(DriveState.OFF3, t)
            elif state in (DriveState.READY_TO_SWITCH_ON, DriveState.READY):
                self._enter(DriveState.SWITCH_ON_INHIBIT, t)
            return
        if state is DriveState.SWITCH_ON_INHIBIT:
            if not on:
                self._enter(DriveState.READY_TO_SWITCH_ON, t)
        elif state is DriveState.READY_TO_SWITCH_ON:
            if on:
                self._enter(DriveState.READY, t)
            elif enabled and self.motion.jog_switches_on and (wanted := _jog_wanted(control)):
                self._jog = wanted  # the family's jog switches the drive on
                self._enter(DriveState.JOG, t)
        elif state is DriveState.READY:
            if not on:
                self._enter(DriveState.READY_TO_SWITCH_ON, t)
            elif enabled:
                self._enter(DriveState.OPERATION, t)
        elif state is DriveState.JOG and self.motion.jog_switches_on:
            if enabled:
                self._jog_bits(state, control, t)
            else:  # pulses off, the motor coasts
                self._jog = 0
                self._enter(DriveState.READY_TO_SWITCH_ON, t)
        elif state in (DriveState.OPERATION, DriveState.JOG):
            if not on:
                self._enter(DriveState.OFF1, t)
            elif not enabled:
                self._enter(DriveState.READY, t)
            else:
                self._jog_bits(state, control, t)
        elif state is DriveState.OFF1:
            if on:
                self._enter(DriveState.OPERATION if enabled else DriveState.READY, t)
            elif not enabled:
                self._enter(DriveState.READY_TO_SWITCH_ON, t)

    def _jog_bits(self, state: DriveState, control: int, t: float) -> None:
        wanted = _jog_wanted(control)
        if state is DriveState.OPERATION:
            if self.motion.jog_switches_on:
                return  # the family jogs from READY TO SWITCH ON only
            standing = self.actual == 0.0 and self._operation_target() == 0.0
            if wanted and standing:
                self._jog = wanted
                self._enter(DriveState.JOG, t)
            return
        if self._jog and not control & (_JOG1 if self._jog == 1 else _JOG2):
            self._jog = 0  # brake, back to OPERATION at standstill
        elif not self._jog and wanted:
            self._jog = wanted


def _jog_wanted(control: int) -> int:
    """The jog the control word asks for: 1, 2 or 0 (none; jog 1 when both bits are set)."""
    return 1 if control & _JOG1 else 2 if control & _JOG2 else 0
