"""The ramp-function generator ("Hochlaufgeber", HLG) of the simulated drive (C 5.2.1).

Values are fractions of the reference: 1.0 is 100 % (4000h in a 16-bit process data word,
C 5.2.2). The output moves towards its target at a constant rate: the ramp-up rate while the
magnitude grows, the ramp-down rate while it shrinks; a target on the other side of zero is
reached by ramping down to zero and up again. A ramp time T (from 0 to 100 %) gives the rate
1/T per second; T = 0 makes the output jump. Motion is linear, so any time step is computed
exactly: the result does not depend on how often the simulation is stepped.
"""

from __future__ import annotations

import math


def rate_of(ramp_time: float) -> float:
    """Rate (fraction per second) of a ramp time from 0 to 100 % in seconds; 0 s jumps."""
    return math.inf if ramp_time <= 0 else 1.0 / ramp_time


def _leg(value: float, target: float, up_rate: float, down_rate: float) -> tuple[float, float]:
    """The next straight piece towards ``target``: (where it ends, its rate). A piece either
    shrinks the magnitude (down rate, ending at the target or at zero) or grows it (up rate)."""
    if value != 0.0 and (target * value <= 0.0 or abs(target) < abs(value)):
        return (target if target * value > 0.0 else 0.0), down_rate
    return target, up_rate


def advance(value: float, target: float, dt: float, up_rate: float, down_rate: float) -> float:
    """Where a ramp starting at ``value`` is after ``dt`` seconds on the way to ``target``."""
    remaining = max(dt, 0.0)
    for _ in range(3):  # at most: down to zero, then up to the target
        if value == target:
            break
        goal, rate = _leg(value, target, up_rate, down_rate)
        distance = abs(goal - value)
        if math.isinf(rate):
            value = goal
            continue
        if distance <= rate * remaining:
            remaining -= distance / rate
            value = goal
        else:
            value += math.copysign(rate * remaining, goal - value)
            break
    return value


def duration(value: float, target: float, up_rate: float, down_rate: float) -> float:
    """Seconds a ramp from ``value`` needs to reach ``target`` (0 for a jump)."""
    total = 0.0
    for _ in range(3):
        if value == target:
            break
        goal, rate = _leg(value, target, up_rate, down_rate)
        if not math.isinf(rate):
            total += abs(goal - value) / rate
        value = goal
    return total
