"""Character-level line errors (A 5.2.2): what a serial backend can flag on a character.

Defined here, in the pure protocol layer, because the receiver classifies telegrams by them;
`pyuss.transport` re-exports it for the backends that report them.
"""

from __future__ import annotations

import enum

__all__ = ["LineError"]


class LineError(enum.IntFlag):
    """Character-level errors a backend can report (A 5.2.2: parity, framing, overrun)."""

    NONE = 0
    PARITY = 1
    FRAMING = 2
    OVERRUN = 4
    BREAK = 8
