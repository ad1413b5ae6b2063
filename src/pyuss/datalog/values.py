"""What a log records: the VALUES of ``uss log`` and their CSV columns.

- ``status``: the status word (PZD1 of every answer, C 5.2.1), in hex as everywhere (0237h);
- ``state``: the drive state the status word spells (C Tables 5.5, 5.6), as text;
- ``actual``: the actual values (PZD2 and up): PZD2 in percent of the reference (4000h = 100 %,
  C 5.2.2), or in the reference's unit when the profile's parameter file names a reference
  parameter; further words raw, or scaled by the parameter the file maps them to;
- a status bit's name (``ready``, ``fault``, ``operation_enabled``, ``in_tolerance``, ...:
  the names of `pyuss.protocol.pzd.StatusWord` in any case, or ``bit3``): 1 or 0;
- a parameter: ``P52``, ``P4.2`` (element 2 of array P4), in any spelling of
  `pyuss.params.names` (``r0052``, ``52``, ``P0004[2]``): its value,
  typed and scaled by what the drive's parameter book knows of it (`pyuss.params`: the
  profile's file, the drive's own description), in its unit; a word of bits (V2, such as the
  control and status word displays r0054 and r0052) in hex; the unsigned word the drive sent
  when nothing is known of it. Parameters are read with a parameter job for every sample.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Sequence
from dataclasses import dataclass

from pyuss.errors import ConfigError
from pyuss.params.names import parse_param_name
from pyuss.protocol.pzd import StatusWord

__all__ = ["Kind", "Quantity", "parse_values"]


class Kind(enum.Enum):
    STATUS = "status"
    STATE = "state"
    ACTUAL = "actual"
    BIT = "bit"
    PARAMETER = "parameter"


_BITS: dict[str, int] = {
    flag.name.lower(): flag.value.bit_length() - 1
    for flag in StatusWord
    if flag.name is not None and not flag.name.startswith("DEVICE")
}


@dataclass(frozen=True, slots=True)
class Quantity:
    """One VALUE: its kind and, for bits and parameters, which one."""

    kind: Kind
    text: str
    bit: int = 0
    pnu: int = 0
    index: int | None = None

    @property
    def process(self) -> bool:
        """Taken from the process data of the cyclic answers (not a parameter job)."""
        return self.kind is not Kind.PARAMETER


def _bit_names() -> str:
    return ", ".join(sorted(_BITS))


def parse_values(texts: Sequence[str]) -> list[Quantity]:
    """The VALUES given on the command line; `ConfigError` naming a value not understood."""
    if not texts:
        raise ConfigError("name at least one value to log: status, actual, a bit name or P52")
    out: list[Quantity] = []
    for text in texts:
        word = text.strip()
        low = word.lower()
        if low in ("status", "state", "actual"):
            out.append(Quantity(Kind(low), word))
            continue
        if low in _BITS:
            out.append(Quantity(Kind.BIT, word, bit=_BITS[low]))
            continue
        bit = re.fullmatch(r"bit(\d+)", low)
        if bit and int(bit.group(1)) <= 15:
            out.append(Quantity(Kind.BIT, word, bit=int(bit.group(1))))
            continue
        if word[:1].isdigit() or (word[:1] in "PpRr" and word[1:2].isdigit()):
            try:
                pnu, index = parse_param_name(word)
            except ConfigError as exc:
                raise ConfigError(f"value {exc}") from None
        else:
            raise ConfigError(
                f"value {text!r}: use status, state, actual, a status bit ({_bit_names()}, "
                "bit0..bit15) or a parameter such as P52, r0021 or P4.2"
            )
        out.append(Quantity(Kind.PARAMETER, word, pnu=pnu, index=index))
    return out
