"""A simulated drive that limits what is written to one of its parameters."""

from __future__ import annotations

from pyuss.drive.simulated import SimulatedDrive


def limit_writes(drive: SimulatedDrive, pnu: int, highest: int) -> None:
    """``drive`` holds at most ``highest`` in P``pnu`` (one word) and answers a write with
    what it holds, as drives that limit or round a value do."""
    original = drive.write_words

    def write_words(number: int, words: tuple[int, ...], *a: object, **k: object) -> object:
        if number == pnu:
            words = (min(words[0], highest), *words[1:])
        return original(number, words, *a, **k)

    drive.write_words = write_words  # type: ignore[method-assign,assignment]
