"""Fault injection for the virtual bus: a seeded, reproducible plan of what goes wrong.

A `FaultPlan` is a list of `Fault` rules. Each rule names a kind, optionally the station it
concerns (``station``), a time window in seconds since the bus started (``at``,
``duration``), which occurrence it hits (``nth``, counted over the characters or answers of
that station, or of the whole bus when no station is named), a probability and a maximum
``count``. Random choices come from one ``random.Random(seed)`` of the bus, so the same
senders doing the same things meet the same faults.

Character faults act on the 11-bit frame of a character as it goes on the line (B 3.2: start
bit, 8 data bits, even parity, stop bit); every receiver then samples that frame:

=========  ==============================================================================
kind       effect
=========  ==============================================================================
flip       ``bits`` data bits flipped (default 1). An odd number breaks the even parity,
           so receivers see a parity error; an even number passes parity and only the
           BCC can catch it (A 4.5).
parity     the parity bit flipped: receivers get the byte with a parity error.
framing    the stop bit held low: receivers get a framing error.
drop       the character never reaches anyone; its time on the line stays empty.
insert     an extra character (``byte``, or a random one) follows the selected one; the
           sender's later characters move one character time later.
stretch    an idle gap of ``gap`` character times (default 3) before the selected
           character: inside a telegram this breaks A 6.3 (a gap >= 2 character times
           looks like a start pause, A 5.1.2).
=========  ==============================================================================

Station faults:

=========  ==============================================================================
deaf       the station receives nothing during the window (its sending still works).
dead       the station neither receives nor sends during the window.
delay      ``seconds`` of extra delay before the station's answer: each burst it starts
           while its line is idle begins that much later (A 5.2.1.1).
=========  ==============================================================================

The text form (``uss bus --fault``) is ``KIND[:key=value,...]`` with keys ``station``, ``p``,
``nth``, ``count``, ``at``, ``for``, ``bits``, ``byte``, ``gap``, ``seconds``, for example
``flip:station=master,nth=3`` or ``deaf:station=pty2,at=5,for=2``.
"""

from __future__ import annotations

import enum
import math
import random
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from pyuss.bus.line import frame_bits
from pyuss.errors import ConfigError


class FaultKind(enum.StrEnum):
    FLIP = "flip"
    PARITY = "parity"
    FRAMING = "framing"
    DROP = "drop"
    INSERT = "insert"
    STRETCH = "stretch"
    DEAF = "deaf"
    DEAD = "dead"
    DELAY = "delay"


CHARACTER_FAULTS = frozenset(
    {
        FaultKind.FLIP,
        FaultKind.PARITY,
        FaultKind.FRAMING,
        FaultKind.DROP,
        FaultKind.INSERT,
        FaultKind.STRETCH,
    }
)


@dataclass(frozen=True, slots=True)
class Fault:
    """One rule of a `FaultPlan`; see the module docstring."""

    kind: FaultKind
    station: str | None = None
    probability: float = 1.0
    nth: int | None = None
    count: int | None = None
    at: float = 0.0
    duration: float = math.inf
    bits: int = 1
    byte: int | None = None
    gap: float = 3.0
    seconds: float = 0.0

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "kind", FaultKind(self.kind))
        except ValueError:
            kinds = ", ".join(k.value for k in FaultKind)
            raise ConfigError(f"fault kind {self.kind!r} is not one of {kinds}") from None
        if not 0.0 <= self.probability <= 1.0:
            raise ConfigError(f"fault probability must be 0..1, not {self.probability!r}")
        if self.nth is not None and self.nth < 1:
            raise ConfigError(f"fault nth counts from 1, not {self.nth!r}")
        if self.count is not None and self.count < 0:
            raise ConfigError(f"fault count must be >= 0, not {self.count!r}")
        if not (0 <= self.at < math.inf and self.duration > 0):
            raise ConfigError(
                f"fault window needs a finite at >= 0 and for > 0, not {self.at}, {self.duration}"
            )
        if not 1 <= self.bits <= 8:
            raise ConfigError(f"a flip changes 1..8 data bits, not {self.bits!r}")
        if self.byte is not None and not 0 <= self.byte <= 255:
            raise ConfigError(f"inserted byte must be 0..255, not {self.byte!r}")
        if not (0 < self.gap < math.inf and 0 <= self.seconds < math.inf):
            raise ConfigError(
                f"fault gap must be finite and > 0 character times, seconds finite and >= 0, "
                f"not gap={self.gap}, seconds={self.seconds}"
            )
        if self.kind in (FaultKind.DEAF, FaultKind.DEAD, FaultKind.DELAY) and not self.station:
            raise ConfigError(f"fault {self.kind.value} needs station=NAME")
        if self.kind is FaultKind.DELAY and self.seconds <= 0:
            raise ConfigError("fault delay needs seconds=S > 0")

    def active(self, t: float) -> bool:
        """Whether ``t`` (seconds since the bus started) is inside the rule's window."""
        return self.at <= t < self.at + self.duration


_KEYS = {
    "station": ("station", str),
    "p": ("probability", float),
    "nth": ("nth", int),
    "count": ("count", int),
    "at": ("at", float),
    "for": ("duration", float),
    "bits": ("bits", int),
    "byte": ("byte", lambda s: int(s, 0)),
    "gap": ("gap", float),
    "seconds": ("seconds", float),
}


def parse_fault(text: str) -> Fault:
    """Parse ``KIND[:key=value,...]`` (see the module docstring) into a `Fault`."""
    kind, _, rest = text.strip().partition(":")
    values: dict[str, object] = {}
    for item in filter(None, (part.strip() for part in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq or key not in _KEYS:
            known = ", ".join(_KEYS)
            raise ConfigError(f"fault {text!r}: {item!r} is not KEY=VALUE with KEY one of {known}")
        name, convert = _KEYS[key]
        try:
            values[name] = convert(value)  # type: ignore[operator]
        except ValueError:
            raise ConfigError(f"fault {text!r}: {key}={value!r} is not a valid value") from None
    return Fault(kind=kind, **values)  # type: ignore[arg-type]


@dataclass(frozen=True, slots=True)
class FaultPlan:
    """The faults a `pyuss.bus.VirtualBus` injects."""

    faults: tuple[Fault, ...] = ()

    @classmethod
    def parse(cls, texts: Iterable[str]) -> FaultPlan:
        return cls(tuple(parse_fault(t) for t in texts))

    def __init__(self, faults: Sequence[Fault] | Iterable[Fault] = ()) -> None:
        object.__setattr__(self, "faults", tuple(faults))


@dataclass(slots=True)
class CharacterPlan:
    """What happens to one character a station sends."""

    frame: int
    drop: bool = False
    gap_before: float = 0.0
    insert_after: list[int] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


class FaultEngine:
    """Applies a `FaultPlan` as characters go on the line; one per bus."""

    def __init__(self, plan: FaultPlan | None, seed: int) -> None:
        self.plan = plan or FaultPlan()
        self.rng = random.Random(seed)
        self.applied: Counter[str] = Counter()
        self._hits: Counter[int] = Counter()
        self._chars: Counter[str | None] = Counter()
        self._bursts: Counter[str] = Counter()
        self._char_rules = [f for f in self.plan.faults if f.kind in CHARACTER_FAULTS]
        self._delay_rules = [f for f in self.plan.faults if f.kind is FaultKind.DELAY]
        self._window_rules = [
            f for f in self.plan.faults if f.kind in (FaultKind.DEAF, FaultKind.DEAD)
        ]

    @property
    def windows(self) -> bool:
        """Whether the plan makes stations deaf or dead for a while (`deaf`, `dead`)."""
        return bool(self._window_rules)

    @property
    def character_faults(self) -> bool:
        """Whether the plan has faults that act on single characters (`character` matters)."""
        return bool(self._char_rules)

    def _selected(self, index: int, rule: Fault, occurrence: int, t: float) -> bool:
        if not rule.active(t):
            return False
        if rule.count is not None and self._hits[index] >= rule.count:
            return False
        if rule.nth is not None and occurrence != rule.nth:
            return False
        if rule.probability < 1.0 and self.rng.random() >= rule.probability:
            return False
        self._hits[index] += 1
        self.applied[rule.kind.value] += 1
        return True

    def character(self, sender: str, byte: int, t: float) -> CharacterPlan:
        """Plan for ``byte`` sent by ``sender`` at ``t`` seconds since the bus started."""
        self._chars[sender] += 1
        self._chars[None] += 1
        plan = CharacterPlan(frame_bits(byte))
        for index, rule in enumerate(self._char_rules):
            if rule.station is not None and rule.station != sender:
                continue
            if not self._selected(index, rule, self._chars[rule.station], t):
                continue
            plan.notes.append(rule.kind.value)
            if rule.kind is FaultKind.FLIP:
                for bit in self.rng.sample(range(8), rule.bits):
                    plan.frame ^= 1 << (bit + 1)
            elif rule.kind is FaultKind.PARITY:
                plan.frame ^= 1 << 9
            elif rule.kind is FaultKind.FRAMING:
                plan.frame &= ~(1 << 10)
            elif rule.kind is FaultKind.DROP:
                plan.drop = True
            elif rule.kind is FaultKind.INSERT:
                extra = rule.byte if rule.byte is not None else self.rng.randrange(256)
                plan.insert_after.append(extra)
            elif rule.kind is FaultKind.STRETCH:
                plan.gap_before += rule.gap
        return plan

    def answer_delay(self, sender: str, t: float) -> float:
        """Extra seconds before a burst ``sender`` starts on an idle line."""
        self._bursts[sender] += 1
        delay = 0.0
        base = len(self._char_rules)
        for offset, rule in enumerate(self._delay_rules):
            if rule.station != sender:
                continue
            if self._selected(base + offset, rule, self._bursts[sender], t):
                delay += rule.seconds
        return delay

    def deaf(self, station: str, t: float) -> bool:
        """Whether ``station`` hears nothing at ``t`` (deaf or dead)."""
        return any(r.station == station and r.active(t) for r in self._window_rules)

    def dead(self, station: str, t: float) -> bool:
        """Whether what ``station`` sends at ``t`` is lost."""
        return any(
            r.kind is FaultKind.DEAD and r.station == station and r.active(t)
            for r in self._window_rules
        )
