"""Receive diagnostics of A 5.2.3: the error status word, the counters and the per-minute rates.

A 5.2.3 suggests 16 diagnostic parameters of 16 bits each; `Counters` holds them in that order
(a slave can show them as one indexed parameter, `Counters.words`):

====  ==========================================  ==========================================
  no. (A 5.2.3)                                  `Counters` field
====  ==========================================  ==========================================
  1   Hardwareausführungsstand der Schnittstelle  ``hardware_version``
  2   Softwarestand der Schnittstellensoftware    ``software_version``
  3   Reserve                                     ``reserved``
  4   Fehlerstatus (bits 0..7)                    ``error_status`` (`ErrorStatus`)
  5   fehlerfrei empfangene Telegramme je Minute  ``good_per_minute``
  6   verworfene Telegramme je Minute             ``discarded_per_minute``
  7   Zähler: fehlerfreie Telegramme              ``good``
  8   Zähler: verworfene Telegramme               ``discarded``
  9   Zähler: Zeichenrahmenfehler                 ``framing``
 10   Zähler: Überlauffehler                      ``overrun``
 11   Zähler: Parity-Fehler                       ``parity``
 12   Zähler: Telegrammstart nicht erkannt        ``no_stx``
 13   Zähler: Telegrammrestlaufzeit abgelaufen    ``residual_time``
 14   Zähler: BCC-Fehler                          ``bcc``
 15   Zähler: falsche Telegrammlänge              ``bad_lge``
 16   Zähler: Überwachungszeit abgelaufen         ``timeout``
====  ==========================================  ==========================================

`Diagnostics` is the live object the receiver, the master and the slave update:

- `Diagnostics.record_received`: a telegram received without fault (counter 7, rate 5).
- `Diagnostics.record_fault`: a telegram discarded for a `FaultKind` (counter 8, rate 6, the
  counter of that kind and its status bit). Every discarded telegram counts once, under the
  first cause found; `FaultKind.BAD_ADR` (undefined ADR bits) has no counter and no bit of its
  own, it counts as discarded only.
- `Diagnostics.record_discarded`: a telegram dropped for a reason of the caller's (for example
  a slave dropping telegrams for other addresses, if it wants them counted).
- `Diagnostics.record_timeout`: status bit 7 and counter 16; the master calls it when a slave
  does not answer within the response delay, the slave when its telegram failure time expires.

Status bits latch until `Diagnostics.clear_status`. Counters are Python integers and never
wrap; `Counters.words` reduces them modulo 65536 for a 16-bit parameter. The per-minute rates
count the events of the last 60 seconds in whole seconds: events whose second (``floor(t)``)
lies within the 60 seconds up to ``floor(now)``. Nothing is extrapolated during the first
minute.
"""

from __future__ import annotations

import enum
import math
from collections import deque
from dataclasses import dataclass

from pyuss.protocol.frozen import builder

__all__ = ["Counters", "Diagnostics", "ErrorStatus", "FaultKind"]

_WINDOW = 60


class ErrorStatus(enum.IntFlag):
    """The error status word of A 5.2.3 (diagnostic parameter 4); bits 8..15 are reserved."""

    NONE = 0
    FRAMING = 1 << 0
    """Bit 0: framing error (Zeichenrahmenfehler)."""
    OVERRUN = 1 << 1
    """Bit 1: buffer overrun (Puffer-Überlauf)."""
    PARITY = 1 << 2
    """Bit 2: parity error."""
    NO_STX = 1 << 3
    """Bit 3: telegram start not recognised, the first character was no STX."""
    BCC = 1 << 4
    """Bit 4: wrong block check character."""
    RESIDUAL_TIME = 1 << 5
    """Bit 5: residual telegram time exceeded (Telegrammrestlaufzeit abgelaufen)."""
    BAD_LGE = 1 << 6
    """Bit 6: wrong telegram length LGE."""
    TIMEOUT = 1 << 7
    """Bit 7: master: response delay exceeded; slave: telegram failure time exceeded."""


class FaultKind(enum.IntEnum):
    """Why a received telegram was discarded: the classes of A 5.2.2 (and A 5.2.3 bits).

    The value of each kind with a status bit is that bit's `ErrorStatus` value; `BAD_ADR`
    has none (its value 100h lies in the reserved bits). No kind is 0 (false).
    """

    FRAMING = 1 << 0
    """A character with a framing error (or a break) reported by the transport."""
    OVERRUN = 1 << 1
    """The transport reported an overrun: characters were lost."""
    PARITY = 1 << 2
    """A character with a parity error reported by the transport."""
    NO_STX = 1 << 3
    """Bytes that start no telegram: not STX after a start pause, or bytes without a pause."""
    BCC = 1 << 4
    """The BCC does not match."""
    RESIDUAL_TIME = 1 << 5
    """The telegram was not complete within its residual time, or the line fell idle first."""
    BAD_LGE = 1 << 6
    """LGE out of 2..254, or not the fixed length configured for the address."""
    BAD_ADR = 1 << 8
    """ADR bits 5..7 in a combination the spec leaves undefined (A 4.3); no status bit."""

    @property
    def status(self) -> ErrorStatus:
        """The `ErrorStatus` bit of this kind (`ErrorStatus.NONE` for `BAD_ADR`)."""
        return ErrorStatus(self.value) if self.value <= 0x80 else ErrorStatus.NONE


_KIND_FIELD = {
    FaultKind.FRAMING: "framing",
    FaultKind.OVERRUN: "overrun",
    FaultKind.PARITY: "parity",
    FaultKind.NO_STX: "no_stx",
    FaultKind.BCC: "bcc",
    FaultKind.RESIDUAL_TIME: "residual_time",
    FaultKind.BAD_LGE: "bad_lge",
}


@dataclass(frozen=True, slots=True)
class Counters:
    """A snapshot of the 16 diagnostic parameters of A 5.2.3, in the USS specification's order."""

    hardware_version: int = 0
    software_version: int = 0
    reserved: int = 0
    error_status: ErrorStatus = ErrorStatus.NONE
    good_per_minute: int = 0
    discarded_per_minute: int = 0
    good: int = 0
    discarded: int = 0
    framing: int = 0
    overrun: int = 0
    parity: int = 0
    no_stx: int = 0
    residual_time: int = 0
    bcc: int = 0
    bad_lge: int = 0
    timeout: int = 0

    def counts(self) -> dict[str, int]:
        """The telegram counters and rates by name (A 5.2.3 order, from good per minute to
        timeouts), as the monitor's and the web page's JSON give them."""
        return {
            "good_per_minute": self.good_per_minute,
            "discarded_per_minute": self.discarded_per_minute,
            "good": self.good,
            "discarded": self.discarded,
            "framing": self.framing,
            "overrun": self.overrun,
            "parity": self.parity,
            "no_stx": self.no_stx,
            "residual_time": self.residual_time,
            "bcc": self.bcc,
            "bad_lge": self.bad_lge,
            "timeout": self.timeout,
        }

    def words(self) -> tuple[int, ...]:
        """The 16 parameters as 16-bit words (counters modulo 65536), in A 5.2.3 order."""
        return (
            self.hardware_version & 0xFFFF,
            self.software_version & 0xFFFF,
            self.reserved & 0xFFFF,
            int(self.error_status) & 0xFFFF,
            min(self.good_per_minute, 0xFFFF),
            min(self.discarded_per_minute, 0xFFFF),
            self.good & 0xFFFF,
            self.discarded & 0xFFFF,
            self.framing & 0xFFFF,
            self.overrun & 0xFFFF,
            self.parity & 0xFFFF,
            self.no_stx & 0xFFFF,
            self.residual_time & 0xFFFF,
            self.bcc & 0xFFFF,
            self.bad_lge & 0xFFFF,
            self.timeout & 0xFFFF,
        )


_counters = builder(Counters)
"""`Counters` of the live counts (made at every answer a drive gives the gateway)."""


class _Rate:
    """Events per minute, kept in one-second buckets, with their running total (the rate is
    asked for at every answer a drive gives the gateway: no sum over the buckets then)."""

    __slots__ = ("_buckets", "_total")

    def __init__(self) -> None:
        self._buckets: deque[list[int]] = deque()
        self._total = 0
        """The sum of the buckets' counts."""

    def add(self, now: float) -> None:
        second = math.floor(now)
        self._total += 1
        buckets = self._buckets
        if buckets and buckets[-1][0] >= second:
            buckets[-1][1] += 1  # same second (or a clock that stepped back)
        else:
            buckets.append([second, 1])
            self._prune(second)  # the window moves on only when a new second begins

    def _prune(self, second: int) -> None:
        buckets = self._buckets
        while buckets and buckets[0][0] <= second - _WINDOW:
            self._total -= buckets.popleft()[1]

    def per_minute(self, now: float) -> int:
        second = math.floor(now)
        buckets = self._buckets
        if not buckets:
            return 0
        if buckets[0][0] <= second - _WINDOW:  # (asked at every answer: mostly nothing to drop)
            self._prune(second)
            if not buckets:
                return 0
        if buckets[-1][0] <= second:
            return self._total
        return sum(count for when, count in buckets if when <= second)

    def clear(self) -> None:
        self._buckets.clear()
        self._total = 0


class Diagnostics:
    """Live receive diagnostics of one interface (A 5.2.3); see the module text for the rules."""

    status: ErrorStatus
    good: int
    discarded: int
    framing: int
    overrun: int
    parity: int
    no_stx: int
    residual_time: int
    bcc: int
    bad_lge: int
    timeout: int

    def __init__(self, *, hardware_version: int = 0, software_version: int = 0) -> None:
        self.hardware_version = hardware_version
        self.software_version = software_version
        self._good_rate = _Rate()
        self._discarded_rate = _Rate()
        self.reset()

    def record_received(self, now: float) -> None:
        """A telegram was received without fault at time ``now``."""
        self.good += 1
        rate = self._good_rate
        buckets = rate._buckets
        if buckets and buckets[-1][0] >= math.floor(now):  # (`_Rate.add` in the same second)
            buckets[-1][1] += 1
            rate._total += 1
        else:
            rate.add(now)

    def record_fault(self, kind: FaultKind, now: float) -> None:
        """A telegram was discarded at time ``now`` because of ``kind``."""
        field_name = _KIND_FIELD.get(kind)
        if field_name is not None:
            setattr(self, field_name, getattr(self, field_name) + 1)
        self.status |= kind.status
        self.record_discarded(now)

    def record_discarded(self, now: float) -> None:
        """A telegram was discarded at time ``now`` for a reason of the caller's."""
        self.discarded += 1
        self._discarded_rate.add(now)

    def record_timeout(self, now: float) -> None:
        """Master: a slave did not answer in time; slave: the telegram failure time expired."""
        del now  # part of the signature for symmetry; timeouts have no per-minute rate
        self.timeout += 1
        self.status |= ErrorStatus.TIMEOUT

    def good_per_minute(self, now: float) -> int:
        """Telegrams received without fault within the last minute."""
        return self._good_rate.per_minute(now)

    def discarded_per_minute(self, now: float) -> int:
        """Telegrams discarded within the last minute."""
        return self._discarded_rate.per_minute(now)

    def clear_status(self) -> None:
        """Clear the latched error status bits; counters are kept."""
        self.status = ErrorStatus.NONE

    def reset(self) -> None:
        """Clear status, counters and rates (versions are kept)."""
        self.status = ErrorStatus.NONE
        for name in ("good", "discarded", *_KIND_FIELD.values(), "timeout"):
            setattr(self, name, 0)
        self._good_rate.clear()
        self._discarded_rate.clear()

    def snapshot(self, now: float) -> Counters:
        """The 16 parameters at time ``now``."""
        return _counters(  # the fields of `Counters` in their order
            self.hardware_version,
            self.software_version,
            0,  # reserved
            self.status,
            self._good_rate.per_minute(now),
            self._discarded_rate.per_minute(now),
            self.good,
            self.discarded,
            self.framing,
            self.overrun,
            self.parity,
            self.no_stx,
            self.residual_time,
            self.bcc,
            self.bad_lge,
            self.timeout,
        )
