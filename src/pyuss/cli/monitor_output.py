"""What ``uss monitor`` prints beside its lines: an exchange as a JSON object (``--json``,
the keys docs/monitor.md lists) and the values of a line's drives as their profile types them
(`ProfileValues`, the monitor itself knowing no profile)."""

from __future__ import annotations

from typing import Any

from pyuss.cli._output import iso_time
from pyuss.cli.decode import describe
from pyuss.errors import TelegramError
from pyuss.monitor.model import Direction, Exchange, Frame
from pyuss.monitor.render import ValueText, exchange_line
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import AddressMode


def frame_json(
    frame: Frame, layout: Layout | None, origin: float = 0.0, page_size: int | None = None
) -> dict[str, Any]:
    """A frame as a JSON-ready dict, times less ``origin``; ``telegram`` is what
    ``uss decode --json`` gives for its bytes with ``layout`` (None when they hold no whole
    telegram, there is no layout for them or they do not fit it)."""
    telegram = None
    if frame.telegram is not None and layout is not None:
        direction = "response" if frame.direction is Direction.RESPONSE else "request"
        try:
            telegram = describe(frame.raw, layout, direction, page_size=page_size)
        except TelegramError:
            telegram = None
    return {
        "start": round(frame.start - origin, 9),
        "end": round(frame.end - origin, 9),
        "hex": frame.raw.hex(" ").upper(),
        "direction": frame.direction.label,
        "guessed": frame.guessed,
        "port": frame.port,
        "address": frame.address,
        "mode": None if frame.mode is None else frame.mode.label,
        "fault": None if frame.fault is None else frame.fault.name.lower(),
        "detail": frame.detail,
        "telegram": telegram,
    }


def exchange_json(
    ex: Exchange,
    *,
    origin: float = 0.0,
    epoch: float | None = None,
    page_size: int | None = None,
    known: ValueText | None = None,
) -> dict[str, Any]:
    """An exchange as a JSON-ready dict (the keys are listed in docs/monitor.md): ``time`` is
    the ISO 8601 wall-clock time of ``epoch + ex.time`` (null when ``epoch`` is None: the
    wall clock is not known), ``t`` and the frames' times are seconds after ``origin``."""
    decodable = ex.mode in (AddressMode.NORMAL, AddressMode.BROADCAST)
    layout = ex.layout if decodable else None
    return {
        "index": ex.index,
        "time": None if epoch is None else iso_time(epoch + ex.time),
        "t": round(ex.time - origin, 9),
        "kind": ex.kind,
        "address": ex.address,
        "mode": None if ex.mode is None else ex.mode.label,
        "layout": None if ex.layout is None else str(ex.layout),
        "layout_source": None if ex.layout_source is None else ex.layout_source.value,
        "request": None
        if ex.request is None
        else frame_json(ex.request, layout, origin, page_size),
        "answer": None if ex.answer is None else frame_json(ex.answer, layout, origin, page_size),
        "delay_ms": None if ex.delay is None else round(ex.delay * 1000, 6),
        "problems": [
            {"problem": i.problem.value, "where": i.where, "text": i.text} for i in ex.issues
        ],
        "unsure": ex.unsure or None,
        "notes": list(ex.notes),
        "summary": exchange_line(ex, origin=origin, page_size=page_size, known=known),
        "error": None,
    }


class ProfileValues:
    """The values of a line's devices as their profile types them (`ValueText`): parameters
    through the profile's parameter file (type, scaling, unit, value texts), PZD3 and up
    through the parameters its ``[process]`` table maps them to."""

    def __init__(self, name: str) -> None:
        from pyuss.params import ParamBook
        from pyuss.profiles import get_profile

        profile = get_profile(name)
        db = profile.database()
        self.profile = profile
        self.book = ParamBook.for_profile(profile)
        self.setpoints = db.process_setpoints
        self.actuals = db.process_actuals

    def parameter(self, pnu: int, index: int | None, words: tuple[int, ...]) -> str | None:
        from pyuss.params import decode, format_value

        info = self.book.get(pnu)
        if info is None:
            return None
        try:
            return format_value(info, decode(info, words, index))
        except TelegramError:  # words that do not fit its type: shown as they are
            return None

    def name(self, pnu: int) -> str:
        return self.book.label(pnu)

    def bits(self, request: bool, word: int, before: int | None) -> str:
        from pyuss.params.words import WordKind, changed_bits, describe_word

        kind = WordKind.CONTROL if request else WordKind.STATUS
        if before is None:
            return ", ".join(describe_word(word, kind, self.profile).names)
        return changed_bits(before, word, kind, self.profile)

    def process(self, request: bool, number: int, word: int) -> str | None:
        pnus = self.setpoints if request else self.actuals
        pnu = pnus[number - 3] if 0 <= number - 3 < len(pnus) else 0
        info = self.book.get(pnu) if pnu else None
        if info is None or info.words != 1:
            return None
        return self.parameter(pnu, None, (word,))
