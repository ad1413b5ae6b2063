"""The interface parameters of a simulated drive (USS specification C 3.1, C 3.2; Baumueller
communication software manual 2.5), read and shown through the parameter file's
``[interface]`` table.

Every profile names its own parameters there (generic P683..P687 index 1, MICROMASTER 4 and
SINAMICS P2010..P2014, NORD P511..P513, Baumueller 182..184); this module is the one place
that reads and writes them, so a new profile only needs its table:

- ``baud``: the baud rate. A value table (C 3.1: 1 = 300 ... 6 = 9600, 7 = 19200 ...) comes
  from the parameter's value texts ("19200 BAUD"); a parameter with the unit Baud holds the rate
  itself (`pyuss.drive.database.baud_codes`). The drive shows the rate its line runs at. A
  change takes effect at once where the line can follow (`guard_baud`: a pty or TCP line with
  this one drive on it switches to the new rate after the answer); elsewhere (a serial port,
  the virtual bus, several drives sharing a line) the rate is fixed while the simulator runs:
  the change must be stored (an EEPROM request into a drive with a store file) and takes
  effect at the next start, and a change that would never take effect is refused (error 1).
- ``failure_time``: the telegram failure time, in the parameter's time unit and scaling (C 3.1:
  seconds where it has no unit; C 3.2 P687 in ms; 0 = off). The drive shows the time in force,
  and a change through any interface is in force from then on.
- ``address``, ``pkw``, ``pzd``: shown as in force at start (`SlaveEngine`); a change is for the
  next start (C 7: the lengths must not change during operation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

from pyuss.drive.database import TIME_UNITS, Parameter, ParamRef
from pyuss.drive.datatypes import DataType, Value
from pyuss.drive.faults import ParameterFault
from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import ConfigError
from pyuss.protocol.pkw import ErrorNumber
from pyuss.protocol.timing import BAUD_RATES

__all__ = ["InterfaceParameters"]


class InterfaceParameters:
    """The ``[interface]`` parameters of one drive (see the module docstring)."""

    def __init__(self, drive: SimulatedDrive) -> None:
        self.drive = drive
        self.refs: Mapping[str, ParamRef] = drive.db.interface
        self._codes: Mapping[int, int] | None = drive.db.baud_codes()

    def _param(self, role: str) -> tuple[ParamRef, Parameter] | None:
        ref = self.refs.get(role)
        return None if ref is None else (ref, self.drive.db.parameter(ref.pnu))

    def _number(self, ref: ParamRef) -> int | float | None:
        value = self.drive.ref_value(ref)
        return value if isinstance(value, int | float) else None

    # -- baud rate ----------------------------------------------------------------------------

    def baud(self) -> int | None:
        """The baud rate the drive is set to (None: no baud parameter, or a value that names
        no rate)."""
        found = self._param("baud")
        if found is None:
            return None
        value = self._number(found[0])
        if value is None:
            return None
        if self._codes is None:
            return int(value)
        return self._codes.get(int(value))

    def rates(self) -> tuple[int, ...]:
        """The baud rates of B 2.4 the drive runs at (all of them without a baud parameter)."""
        found = self._param("baud")
        if found is None:
            return BAUD_RATES
        codes = self._codes
        known = set(self._rates(found[1]) if codes is None else codes.values())
        return tuple(rate for rate in BAUD_RATES if rate in known)

    def baud_value(self, baud: int) -> int:
        """The value of the baud parameter that stands for ``baud``; `ConfigError` when the
        parameter cannot show that rate (the drive does not run at it)."""
        found = self._param("baud")
        assert found is not None
        ref, param = found
        codes = (
            {rate: rate for rate in self._rates(param)}
            if self._codes is None
            else {rate: code for code, rate in sorted(self._codes.items(), reverse=True)}
        )
        if baud not in codes:
            rates = ", ".join(str(rate) for rate in sorted(codes))
            raise ConfigError(f"{self._who()} does not run at {baud} baud ({ref}: {rates})")
        return codes[baud]

    @staticmethod
    def _rates(param: Parameter) -> list[int]:
        """The rates a parameter holding the rate itself can show: any its type holds (the
        drive's own display is not bound by the limits of writes, `pyuss.drive.database`)."""
        low, high = param.dtype.type_range
        return [rate for rate in BAUD_RATES if low <= rate <= high]

    def show_baud(self, baud: int) -> None:
        """Show ``baud`` as the rate in force; `ConfigError` if the drive has no such rate."""
        found = self._param("baud")
        if found is None:
            return
        self.drive.update(found[0].pnu, self.baud_value(baud), found[0].index)

    def rate_of(self, value: Value) -> int | None:
        """The baud rate a value of the baud parameter stands for (None: no rate)."""
        if not isinstance(value, int):
            return None
        if self._codes is None:
            return value if value in BAUD_RATES else None
        rate = self._codes.get(value)
        return rate if rate in BAUD_RATES else None

    def guard_baud(self, line_follows: Callable[[], bool]) -> Callable[[], None]:
        """Let through only the changes of the baud parameter that take effect (see the module
        docstring): at once where ``line_follows()`` (the line switches to the new rate after
        the answer), else stored for the next start (an EEPROM write into a drive with a store
        file). Returns a function that lifts the rule."""
        found = self._param("baud")
        if found is None:
            return lambda: None
        ref, _ = found
        drive = self.drive

        def rule(value: Value, eeprom: bool) -> None:
            if drive.ref_value(ref) == value and not eeprom:
                return  # the value in force: nothing to change
            if self.rate_of(value) is None:
                raise ParameterFault(
                    ErrorNumber.LIMIT_EXCEEDED, f"{value!r} names no baud rate this line runs at"
                )
            if line_follows():
                return  # in force after the answer
            if not eeprom or drive.store_path is None:
                raise ParameterFault(
                    ErrorNumber.NOT_CHANGEABLE,
                    "this line keeps its baud rate while the simulator runs: store the rate "
                    "(an EEPROM request into a drive with a store file) for the next start",
                )

        return drive.add_write_rule(ref, rule)

    # -- telegram failure time ----------------------------------------------------------------

    def failure_time(self) -> float | None:
        """The telegram failure time the parameter holds, in seconds (None: no parameter)."""
        found = self._param("failure_time")
        if found is None:
            return None
        ref, param = found
        raw = self._number(ref)
        if raw is None:
            return None
        return max(0.0, raw * _seconds_per_raw(param))

    def failure_time_value(self, seconds: float) -> int | float:
        """The parameter value for ``seconds``; `ConfigError` when the parameter cannot hold
        that time exactly (a step or a limit of the drive)."""
        found = self._param("failure_time")
        assert found is not None
        ref, param = found
        step = _seconds_per_raw(param)
        raw: int | float = seconds / step
        if param.dtype is not DataType.FLOAT:
            rounded = round(raw)
            if not math.isclose(rounded, raw, rel_tol=1e-9, abs_tol=1e-9):
                raise ConfigError(
                    f"telegram failure time {seconds:g} s: {self._who()} sets it in steps of "
                    f"{step:g} s ({ref})"
                )
            raw = rounded
        low = 0.0 if param.minimum is None else param.minimum
        high = param.dtype.type_range[1] if param.maximum is None else param.maximum
        if param.dtype is not DataType.FLOAT and not low <= raw <= high:
            raise ConfigError(
                f"telegram failure time {seconds:g} s: {self._who()} takes "
                f"{low * step:g}..{high * step:g} s ({ref})"
            )
        return raw

    def show_failure_time(self, seconds: float) -> None:
        """Show ``seconds`` as the failure time in force; `ConfigError` if the parameter
        cannot hold it."""
        found = self._param("failure_time")
        if found is None:
            return
        self.drive.update(found[0].pnu, self.failure_time_value(seconds), found[0].index)

    def watch_failure_time(self, callback: Callable[[float], None]) -> Callable[[], None]:
        """Call ``callback(seconds)`` whenever the failure time parameter changes."""
        found = self._param("failure_time")
        if found is None:
            return lambda: None

        def changed(_pnu: int) -> None:
            seconds = self.failure_time()
            if seconds is not None:
                callback(seconds)

        return self.drive.watch(found[0].pnu, changed)

    def _who(self) -> str:
        return f"a {self.drive.db.profile.name} drive"


def _seconds_per_raw(param: Parameter) -> float:
    """Seconds one unit of the raw value stands for (C 3.1: seconds where no unit is given)."""
    scaling = 1.0 if param.scaling is None else param.scaling
    return scaling * TIME_UNITS.get(param.unit, 1.0)
