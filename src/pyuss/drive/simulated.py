"""`SimulatedDrive`: parameter values, EEPROM store and the drive profile's state machine.

This is the object a slave engine serves. It is a `ParameterMemory` (reads, checked writes,
texts, descriptions, EEPROM writes, change notification) and runs a `DriveStateMachine` whose
settings come from the parameters the profile names in ``[drive]``: writing the ramp-up time
through USS changes the ramp of the next step.

Process data: ``apply_control(control_word, setpoint, now)`` takes PZD1 and the main setpoint
(a raw 16-bit PZD word, or with ``bits=32`` a double word, 4000h resp. 4000 0000h = 100 %,
C 5.2.2); ``status_word()`` and ``actual_value()`` give PZD1 and the main actual value of the
answer; ``exchange(words, now)`` does all of it for the usual mapping (PZD1 control/status,
PZD2 main setpoint/actual, PZD3.. from ``[process]``). Time is always passed in.

The displays named in ``[drive]`` (state code, fault and warning numbers, control and status
word, ramp input and actual value) are updated by the drive at every step (a display is
written when its value changes); an active display is reported to subscribers like any other
change of an active parameter.

Family rules read from the parameter file (docs/drive.md):

- ``[commissioning]`` (`pyuss.drive.database.Commissioning`): while the commissioning
  parameter (Siemens P0010) is not 0 the drive does not switch on (control bits 0, 8 and 9,
  ON and jog, are taken as 0) and shows the ``commissioning`` state code; a write of the end
  parameter (P3900) calculates the motor data and leaves commissioning; a write of the reset
  parameter (P0970) in the factory-setting state restores the factory values.
- ``[words]`` (`pyuss.drive.database.WordBits`): the control bit that inverts the setpoint,
  the status bits shown as 1 while their low-active warning is absent, the direction bit, and
  whether the jog bits switch the drive on (`pyuss.drive.states`).
- ``[sources]`` (`pyuss.drive.database.Sources`): while the command source parameter (Siemens
  P0700) does not hold its USS value, the control word of USS is ignored - the drive keeps the
  word in force and answers as before, and the further PZD setpoints are not taken; while the
  setpoint source (P1000) does not, the main setpoint of USS is ignored. A drive starts "ready
  for USS" (each source parameter at its USS value, unless the EEPROM store holds one) or,
  with ``factory=True``, with the file's factory values, as out of the box.
- ``[drive]`` motor roles: from the rated motor data (``motor_voltage``, ``motor_current``,
  ``motor_power``) a simple motor model (`motor_outputs`) shows output voltage, current and
  power (``output_voltage``, ``output_current``, ``output_power``) while the pulses are on.
  This is simulation, not a fact of any drive.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pyuss.drive.database import (
    LEVEL_ROLES,
    MOTOR_ROLES,
    OUTPUT_ROLES,
    TIME_ROLES,
    TIME_UNITS,
    ParameterDatabase,
    ParamRef,
)
from pyuss.drive.datatypes import DataType, Value, round_float
from pyuss.drive.faults import ParameterFault
from pyuss.drive.loader import load_profile
from pyuss.drive.memory import ParameterMemory
from pyuss.drive.states import WAIT_FOREVER, DriveState, DriveStateMachine, Motion
from pyuss.protocol.pzd import FULL_SCALE_16, FULL_SCALE_32, SWITCHES_ON

_DEFAULTS = Motion()

_PLAIN_DISPLAYS = ("state", "fault", "warning", "control_word", "status_word")
_LEVEL_DISPLAYS = ("setpoint", "actual")


@dataclass(frozen=True, slots=True)
class _Display:
    """Where a display role is shown and how: the element, its type's range, and for a level
    (setpoint, actual value) the physical value of 100 % and the parameter's scaling."""

    pnu: int
    index: int | None
    position: int
    is_float: bool
    low: float
    high: float
    factor: float = 1.0
    divisor: float = 1.0


@dataclass(frozen=True, slots=True)
class RatedMotor:
    """The rated data of the simulated motor: voltage (V), current (A), power (kW) and
    frequency (Hz)."""

    voltage: float
    current: float
    power: float
    frequency: float


EFFICIENCY = 0.8
"""Efficiency of the simulated motor at its rated point (electrical power in = rated power /
efficiency): the share of the rated current that is active current follows from it."""


def motor_outputs(
    motor: RatedMotor, frequency: float, running: bool
) -> tuple[float, float, float, float]:
    """Output voltage (V), current (A), power (kW) and DC link voltage (V) of the simulated
    drive and motor at ``frequency`` (Hz) - a model for the simulation, not a fact of a drive:

    - voltage by V/f: rated voltage x f / rated frequency, at most the rated voltage;
    - current: the magnetising current (what the rated current holds beyond the active current
      of the rated point) and an active current for a load whose torque rises with the square of
      the speed (a fan or pump), the rated active current at the rated frequency;
    - power: sqrt(3) x voltage x active current;
    - DC link: the peak of a supply of the motor's rated voltage, sqrt(2) x rated voltage
      (565 V for 400 V), whether the pulses are on or not (the drive is powered).

    Pulses off (``running`` False): output voltage, current and power 0."""
    dc_link = math.sqrt(2) * max(motor.voltage, 0.0)
    if not running or motor.frequency <= 0 or motor.voltage <= 0:
        return 0.0, 0.0, 0.0, dc_link
    share = min(abs(frequency) / motor.frequency, 1.0)
    rated_active = min(
        motor.current, motor.power * 1000.0 / (math.sqrt(3) * motor.voltage * EFFICIENCY)
    )
    magnetising = math.sqrt(max(motor.current**2 - rated_active**2, 0.0))
    active = rated_active * share * share
    voltage = motor.voltage * share
    current = math.hypot(magnetising, active)
    return voltage, current, math.sqrt(3) * voltage * active / 1000.0, dc_link


@dataclass(frozen=True, slots=True)
class _Displays:
    """The displays of `_PLAIN_DISPLAYS` and `_LEVEL_DISPLAYS` in that order (None where the
    parameter file names none)."""

    plain: tuple[_Display | None, ...]
    levels: tuple[_Display | None, ...]
    outputs: tuple[_Display | None, ...]
    """The motor model's displays (`OUTPUT_ROLES`)."""
    motor: RatedMotor | None
    """The rated motor data (None: the file names no motor, the model shows nothing)."""


class SimulatedDrive(ParameterMemory):
    """A drive without hardware: parameters, persistence, state machine and ramp.

    ``store`` is the file of the simulated EEPROM (None: EEPROM writes stay in RAM); ``now``
    the time of power-up in the caller's time base.
    """

    def __init__(
        self,
        db: ParameterDatabase,
        *,
        store: str | Path | None = None,
        now: float = 0.0,
        factory: bool = False,
    ) -> None:
        self._motion_pnus = {
            ref.pnu
            for name, ref in db.roles.items()
            if name in (*TIME_ROLES, *LEVEL_ROLES, "reference")
        }
        rule = db.commissioning
        rated = () if rule is None or rule.rated_frequency is None else (rule.rated_frequency,)
        self._motor_pnus = {
            ref.pnu for ref in (*(db.roles[n] for n in MOTOR_ROLES if n in db.roles), *rated)
        }
        self._motion_cache: Motion | None = None
        self._displays_cache: _Displays | None = None
        self._display_pnus = {
            ref.pnu for name, ref in db.roles.items() if name in _PLAIN_DISPLAYS + _LEVEL_DISPLAYS
        }
        self._published: tuple[object, ...] | None = None
        self._setpoint: float | None = None
        super().__init__(db, store=store, running=lambda: self.machine.running)
        if not factory:
            self._ready_for_uss()
        self.machine = DriveStateMachine(now, self._motion())
        self._publish()

    def _ready_for_uss(self) -> None:
        """Each source parameter of ``[sources]`` at its USS value, where the EEPROM store
        holds none (what is stored is what the drive powers up with)."""
        stored = self.stored()
        for _, source in self.db.sources:
            ref = source.ref
            if (ref.pnu, ref.index) not in stored:
                self.update(ref.pnu, source.uss, ref.index)

    def follows_uss(self, kind: str) -> bool:
        """Whether the drive takes ``kind`` (``command``: the control word, ``setpoint``: the
        main setpoint) from USS: its ``[sources]`` parameter holds the USS value, or the family
        has none."""
        source = self.db.sources.get(kind)
        return source is None or self.ref_value(source.ref) == source.uss

    @classmethod
    def from_profile(
        cls,
        name: str,
        *,
        store: str | Path | None = None,
        now: float = 0.0,
        factory: bool = False,
    ) -> SimulatedDrive:
        """A drive of a built-in profile (``generic``, ``6se21``, ``baumueller`` ...)."""
        return cls(load_profile(name), store=store, now=now, factory=factory)

    # ---------------------------------------------------------------- process data

    @property
    def state(self) -> DriveState:
        return self.machine.state

    @property
    def running(self) -> bool:
        return self.machine.running

    def step(self, now: float) -> None:
        """Advance ramps and timers to ``now``."""
        self.machine.motion = self._motion()
        self.machine.step(now)
        self._publish()

    def apply_control(
        self, control_word: int, setpoint: int | None, now: float, *, bits: int = 16
    ) -> bool:
        """Take PZD1 and the main setpoint (raw, two's complement; None keeps the old one).

        Returns False when control bit 10 is 0: the process data are ignored (C Table 5.4);
        also when the command source (``[sources]``) is not USS: the control word in force
        stays, and the setpoint is taken alone if the setpoint source is USS.
        """
        self.machine.motion = self._motion()
        if not self.follows_uss("setpoint"):
            setpoint = None  # the setpoint comes from elsewhere: the one in force stays
        if not self.follows_uss("command"):
            self._setpoint_alone(setpoint, now, bits)
            return False
        if self.commissioning_active():
            control_word &= ~SWITCHES_ON  # in commissioning the drive does not switch on
        fraction = None if setpoint is None else _fraction_of_raw(setpoint, bits)
        reverse = self.db.words.reverse
        if reverse is not None and control_word >> 10 & 1:
            if fraction is not None:
                self._setpoint = fraction
            if self._setpoint is not None:
                inverted = control_word >> reverse & 1
                fraction = -self._setpoint if inverted else self._setpoint
        accepted = self.machine.apply(control_word, fraction, now)
        self._publish()
        return accepted

    def _setpoint_alone(self, setpoint: int | None, now: float, bits: int) -> None:
        """A main setpoint without the control word (the command source is not USS): taken
        as the word in force says (bit 11 inverts it where the family has that bit)."""
        if setpoint is None:
            self.machine.step(now)
        else:
            fraction = _fraction_of_raw(setpoint, bits)
            self._setpoint = fraction
            reverse = self.db.words.reverse
            if reverse is not None and self.machine.control >> reverse & 1:
                fraction = -fraction
            self.machine.take_setpoint(fraction, now)
        self._publish()

    def status_word(self) -> int:
        """PZD1 of the answer (C Tables 5.5, 5.6, and the family's bits of ``[words]``)."""
        word = self.machine.status_word()
        bits = self.db.words
        for bit in bits.status_ones:
            word |= 1 << bit
        if bits.direction is not None:
            machine = self.machine
            right = machine.actual > 0 or (machine.actual == 0 and machine.ramp_input >= 0)
            word = word | 1 << bits.direction if right else word & ~(1 << bits.direction)
        return word

    def actual_value(self, *, bits: int = 16) -> int:
        """The main actual value as a raw PZD word (``bits=32``: double word), 4000h = 100 %."""
        return _raw_of_fraction(self.machine.actual, bits)

    def exchange(self, words: Sequence[int], now: float) -> tuple[int, ...]:
        """One process data exchange: the PZD words received, the PZD words to answer.

        PZD1 control word, PZD2 main setpoint (16 bit), PZD3.. the parameters of
        ``[process] setpoints``; the answer has the same length: status word, main actual
        value, then the parameters of ``[process] actuals`` (0 where none is named).
        """
        count = len(words)
        if count == 0:
            self.step(now)
            return ()
        accepted = self.apply_control(words[0], words[1] if count > 1 else None, now)
        if accepted:
            for word, pnu in zip(words[2:], self.db.process_setpoints, strict=False):
                if pnu:
                    self._take_setpoint(pnu, word)
        reply = [self.status_word(), self.actual_value()]
        for pnu in self.db.process_actuals:
            reply.append(self.read_words(pnu)[0] if pnu else 0)
        reply.extend([0] * max(0, count - len(reply)))
        return tuple(reply[:count])

    def raise_fault(
        self, code: int, now: float | None = None, *, cause_present: bool = False
    ) -> None:
        """Trip fault ``code`` (for example the telegram failure time expired, C 3.1).

        ``cause_present``: acknowledging is refused until `clear_fault_cause`.
        """
        self.machine.raise_fault(
            code, self.machine.time if now is None else now, cause_present=cause_present
        )
        self._publish()

    def clear_fault_cause(self, code: int) -> None:
        self.machine.clear_fault_cause(code)

    def raise_warning(self, code: int) -> None:
        """Set a warning (status bit 7) until `clear_warning`."""
        self.machine.raise_warning(code)
        self._publish()

    def clear_warning(self, code: int) -> None:
        self.machine.clear_warning(code)
        self._publish()

    # ---------------------------------------------------------------- commissioning

    def _written(self, pnu: int) -> None:
        rule = self.db.commissioning
        if rule is None:
            return
        if pnu == rule.end and self.value(pnu) != 0:
            self._end_commissioning()
        elif (
            pnu == rule.reset
            and self.value(pnu) == 1
            and rule.factory is not None
            and self.value(rule.parameter) == rule.factory
        ):
            self.restore_factory(rule.keep_on_reset)
            self.set_own(pnu, 0)
            self.set_own(rule.parameter, 0)
        if pnu in (rule.parameter, rule.end, rule.reset):
            self._publish()

    def _end_commissioning(self) -> None:
        """The end of quick commissioning: motor data calculated, back to ready."""
        rule = self.db.commissioning
        assert rule is not None
        if rule.pole_pairs is not None and rule.rated_frequency and rule.rated_speed:
            frequency = self.ref_value(rule.rated_frequency)
            speed = self.ref_value(rule.rated_speed)
            assert isinstance(frequency, int | float) and isinstance(speed, int | float)
            if speed > 0:
                pairs = max(1, round(60.0 * frequency / speed))
                ref = rule.pole_pairs
                param = self.db.parameter(ref.pnu)
                low, high = param.dtype.type_range
                value: float = min(max(pairs, low), high)
                is_float = param.dtype is DataType.FLOAT
                self.set_own(ref.pnu, value if is_float else int(value), ref.index)
        assert rule.end is not None
        self.set_own(rule.end, 0)
        self.set_own(rule.parameter, 0)

    # ---------------------------------------------------------------- roles

    def _take_setpoint(self, pnu: int, word: int) -> None:
        param = self.db.parameter(pnu)
        with contextlib.suppress(ParameterFault):  # a PZD word cannot be refused: old one stays
            self.update(pnu, param.from_words([word]))

    def _role(self, name: str) -> tuple[ParamRef, float] | None:
        """The parameter of a role and its physical value (raw x scaling)."""
        ref = self.db.roles.get(name)
        if ref is None:
            return None
        raw = self.ref_value(ref)
        assert isinstance(raw, int | float)
        scaling = self.db.parameter(ref.pnu).scaling
        return ref, raw * (1.0 if scaling is None else scaling)

    def _seconds(self, name: str) -> float | None:
        found = self._role(name)
        if found is None:
            return None
        ref, value = found
        return value * TIME_UNITS[self.db.parameter(ref.pnu).unit]

    def _level_factor(self, ref: ParamRef) -> float:
        """Physical value of 100 % in the unit of the role's parameter."""
        param = self.db.parameter(ref.pnu)
        if param.unit == "%":
            return 100.0
        if param.unit == "":
            return float(FULL_SCALE_32 if param.dtype.byte_size == 4 else FULL_SCALE_16)
        reference = self._role("reference")
        return 1.0 if reference is None or reference[1] == 0 else reference[1]

    def _fraction(self, name: str) -> float | None:
        found = self._role(name)
        if found is None:
            return None
        ref, value = found
        return value / self._level_factor(ref)

    def _changed(self, pnu: int) -> None:
        if pnu in self._motor_pnus:  # the rated motor data: the motor model's
            self._displays_cache = None
            self._published = None
        if pnu in self._motion_pnus:  # the reference among them: the level displays' factor
            self._motion_cache = None
            self._displays_cache = None
            self._published = None
        if pnu in self._display_pnus:  # a display changed: it is shown again at the next step
            self._published = None

    def _motion(self) -> Motion:
        """The motion settings from the role parameters (cached until one of them changes)."""
        if self._motion_cache is None:
            self._motion_cache = self._read_motion()
        return self._motion_cache

    def _read_motion(self) -> Motion:
        def pick(value: float | None, default: float) -> float:
            return default if value is None else value

        wait = self._seconds("wait_time")
        return Motion(
            ramp_up=pick(self._seconds("ramp_up_time"), _DEFAULTS.ramp_up),
            ramp_down=pick(self._seconds("ramp_down_time"), _DEFAULTS.ramp_down),
            quick_stop=pick(self._seconds("quick_stop_time"), _DEFAULTS.quick_stop),
            coast=self._seconds("coast_time"),
            jog_ramp=self._seconds("jog_ramp_time"),
            jog1=pick(self._fraction("jog1"), _DEFAULTS.jog1),
            jog2=pick(self._fraction("jog2"), _DEFAULTS.jog2),
            jog_switches_on=self.db.words.jog_switches_on,
            tolerance=pick(self._fraction("tolerance"), _DEFAULTS.tolerance),
            tolerance_time=pick(self._seconds("tolerance_time"), _DEFAULTS.tolerance_time),
            compare=pick(self._fraction("compare_value"), _DEFAULTS.compare),
            wait=WAIT_FOREVER if wait is None else wait,
            init=pick(self._seconds("init_time"), _DEFAULTS.init),
        )

    def _displays(self) -> _Displays:
        """Where the displays go (cached until a role parameter, such as the reference,
        changes: the database itself does not change)."""
        if self._displays_cache is None:
            self._displays_cache = _Displays(
                tuple(self._display(name, level=False) for name in _PLAIN_DISPLAYS),
                tuple(self._display(name, level=True) for name in _LEVEL_DISPLAYS),
                tuple(self._display(name, level=False) for name in OUTPUT_ROLES),
                self._rated_motor(),
            )
        return self._displays_cache

    def _rated_motor(self) -> RatedMotor | None:
        """The rated motor data from the motor roles; the rated frequency from the
        commissioning rule's, else the reference (None: a role is missing)."""
        values = [self._role(name) for name in MOTOR_ROLES]
        rule = self.db.commissioning
        frequency: float | None = None
        if rule is not None and rule.rated_frequency is not None:
            held = self.ref_value(rule.rated_frequency)
            assert isinstance(held, int | float)
            frequency = float(held)
        elif (reference := self._role("reference")) is not None:
            frequency = reference[1]
        if frequency is None or any(v is None for v in values):
            return None
        voltage, current, power = (v[1] for v in values if v is not None)
        return RatedMotor(voltage, current, power, frequency)

    def _display(self, name: str, *, level: bool) -> _Display | None:
        ref = self.db.roles.get(name)
        if ref is None:
            return None
        param = self.db.parameter(ref.pnu)
        low, high = param.dtype.type_range
        return _Display(
            ref.pnu,
            ref.index,
            self.db.position(param, ref.index),
            param.dtype is DataType.FLOAT,
            low,
            high,
            self._level_factor(ref) if level else 1.0,
            1.0 if param.scaling is None else param.scaling,
        )

    def _publish(self) -> None:
        """Write the displays the profile names."""
        machine = self.machine
        displays = self._displays()
        code = self.db.state_codes.get(machine.state.value)
        if self.commissioning_active() and "commissioning" in self.db.state_codes:
            code = self.db.state_codes["commissioning"]
        plain = (
            code,
            machine.fault_code,
            machine.warning_code,
            machine.control,
            self.status_word(),
        )
        levels = (machine.ramp_input, machine.actual)
        outputs = self._outputs(displays.motor)
        published = (plain, levels, outputs)
        if published == self._published:
            return  # the displays show these values already (`_changed` forgets them)
        for display, value in zip(displays.plain, plain, strict=True):
            if display is not None and value is not None:
                self._show(display, value)
        for display, fraction in zip(displays.levels, levels, strict=True):
            if display is not None:
                self._show(display, fraction * display.factor / display.divisor)
        for display, output in zip(displays.outputs, outputs, strict=False):
            if display is not None:
                self._show(display, output / display.divisor)
        self._published = published

    def _outputs(self, motor: RatedMotor | None) -> tuple[float, ...]:
        """The motor model's output voltage, current, power and DC link voltage now (empty
        without a motor)."""
        if motor is None:
            return ()
        reference = self._role("reference")
        hertz = abs(self.machine.actual) * (motor.frequency if reference is None else reference[1])
        return motor_outputs(motor, hertz, self.machine.running)

    def _show(self, display: _Display, value: float) -> None:
        """Show ``value`` in a display, rounded to what its type holds; a value the display
        holds already changes nothing and is not written again."""
        held: Value
        if display.is_float:
            number = float(value)
            if not (math.isfinite(number) and abs(number) <= display.high):
                self.update(display.pnu, number, display.index)  # refused as `update` says
                return
            held = round_float(number)
        else:
            held = int(min(max(round(value), display.low), display.high))
        if self._values[display.pnu][display.position] != held:
            self.update(display.pnu, held, display.index)


def _fraction_of_raw(raw: int, bits: int) -> float:
    if bits not in (16, 32):
        raise ValueError(f"setpoints are 16 or 32 bits, not {bits}")
    mask = (1 << bits) - 1
    value = raw & mask
    if value >> (bits - 1):
        value -= 1 << bits
    return value / (FULL_SCALE_16 if bits == 16 else FULL_SCALE_32)


def _raw_of_fraction(fraction: float, bits: int) -> int:
    if bits not in (16, 32):
        raise ValueError(f"actual values are 16 or 32 bits, not {bits}")
    full = FULL_SCALE_16 if bits == 16 else FULL_SCALE_32
    low, high = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
    return min(max(round(fraction * full), low), high) & ((1 << bits) - 1)
