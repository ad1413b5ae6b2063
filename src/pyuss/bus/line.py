"""The line as its receivers see it: the levels of a character's frame, what a UART reads
from them, and `WireChar`, one character as read.

A character is 11 line levels (B 3.2): start bit 0, 8 data bits LSB first, even parity, stop
bit 1 (`frame_bits`). The line is dominant-low: where frames of several stations overlap, a 0
from any of them wins, and a receiver samples the resulting level in the middle of each bit of
the frame that began with the first start bit (`sample`); a frame alone on the line reads as
its own levels (`read_levels`). Pure: no clock, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

from pyuss.transport.base import LineError


@dataclass(frozen=True, slots=True)
class WireChar:
    """One character as the receivers saw it on the line.

    ``start``/``end`` are monotonic seconds; ``sender`` is the station's name, or the names of
    the colliding stations joined by ``+``; ``notes`` lists faults applied and "collision".
    """

    start: float
    end: float
    byte: int
    flags: LineError
    sender: str
    notes: tuple[str, ...] = ()


def frame_bits(byte: int) -> int:
    """The 11 line levels of ``byte`` as an int, bit k = level of frame bit k (B 3.2): start
    bit 0, data bits LSB first, even parity, stop bit 1."""
    parity = byte.bit_count() & 1
    return (byte << 1) | (parity << 9) | (1 << 10)


FRAMES = tuple(frame_bits(b) for b in range(256))
"""The line levels of every byte, sent without a fault."""


def sample(frames: list[tuple[float, int]], start: float, bit: float) -> tuple[int, LineError]:
    """What a UART that saw a start bit at ``start`` reads while ``frames`` (start time, 11
    line levels) drive the line, dominant low. Returns the byte and its error flags."""
    levels = 0
    for k in range(11):
        at = start + (k + 0.5) * bit
        level = 1
        for begin, frame in frames:
            index = int((at - begin) // bit)
            if 0 <= index < 11 and not (frame >> index) & 1:
                level = 0
                break
        levels |= level << k
    return read_levels(levels)


def read_levels(levels: int) -> tuple[int, LineError]:
    """The byte and error flags of the 11 line levels a UART sampled."""
    byte = (levels >> 1) & 0xFF
    flags = LineError.NONE
    if (byte.bit_count() + ((levels >> 9) & 1)) & 1:
        flags |= LineError.PARITY
    if not (levels >> 10) & 1:
        flags |= LineError.FRAMING
    return byte, flags
