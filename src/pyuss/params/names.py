"""Parameter numbers as a person writes and reads them: one formatter, one parser.

A family's parameter file says how its documents write parameter numbers (``[profile]`` key
``names``, `pyuss.drive.database.NameStyle`); `param_name` writes them so:

- `NameStyle.PROJECT` (default; the generic profile, NORD, Baumueller): ``P21``, ``P947.0``.
- `NameStyle.SIEMENS` (MICROMASTER 4, SINAMICS): ``r0021`` for a read-only parameter,
  ``P1120`` for a writable one, four digits at least, as their parameter lists and panels do.

One element of an array is written with a dot, in every style: ``P947.0``, ``r0947.0``. A
number from 2000 on is the number itself, whatever IND page carries it (``P2010.1``).

`parse_param_name` reads any of these spellings wherever a person gives a parameter (commands,
the gateway configuration, backup files, ``uss log`` values): an optional ``r``/``P`` (either
case; it says nothing of access on input), the decimal number with or without leading zeros,
and an optional index as ``.N`` or ``[N]``: ``r21``, ``R21``, ``P0021``, ``p21``, ``21``,
``21.0``, ``21[0]``, ``r0947[1]``. Anything else is refused with a `ConfigError` naming the
text (``'P21x' is not a parameter number ...``).

Machine formats keep their own stable spelling: JSON keys ``pnu``/``index`` hold numbers and the
gateway's keys (topics, registers, nodes) stay ``P21``/``P947.0`` whatever the family's style.
"""

from __future__ import annotations

import re

from pyuss.drive.database import NameStyle, param_name
from pyuss.errors import ConfigError

__all__ = ["MAX_INDEX", "MAX_PNU", "NameStyle", "param_name", "parse_param_name"]

MAX_PNU = 65535
"""The highest number a parameter reference may carry (a profile may allow fewer)."""

MAX_INDEX = 254
"""The highest element index (IND 255 means the whole array, C 4.2.2)."""

EXAMPLES = "for example r0021, P1120, 21 or 947.1"

_NAME = re.compile(r"([PpRr]?)([0-9]+)(?:\.([0-9]+)|\[([0-9]+)\])?")


def parse_param_name(text: str) -> tuple[int, int | None]:
    """(PNU, index) of the parameter ``text`` names (see the module docstring; index None:
    the parameter itself); `ConfigError` if it names none."""
    match = _NAME.fullmatch(text.strip())
    if match is None:
        raise ConfigError(f"{text!r} is not a parameter number ({EXAMPLES})")
    pnu = int(match.group(2))
    index_text = match.group(3) if match.group(3) is not None else match.group(4)
    index = None if index_text is None else int(index_text)
    if pnu > MAX_PNU:
        raise ConfigError(f"{text!r}: the parameter number must be 0..{MAX_PNU}")
    if index is not None and index > MAX_INDEX:
        raise ConfigError(f"{text!r}: the index must be 0..{MAX_INDEX}")
    return pnu, index
