"""The monitor's decoding of net data: the layout a telegram is read with, its PKW and PZD,
and what an answer's PKW says of the request's job.

Pure functions over the monitor's `pyuss.monitor.infer.LayoutBook` (given or inferred
layouts, which `learn` feeds); `pyuss.monitor.Monitor` calls them as it builds each exchange.
"""

from __future__ import annotations

from pyuss.errors import TelegramError
from pyuss.monitor.infer import LayoutBook, LayoutChoice
from pyuss.monitor.model import Frame, Issue, Problem
from pyuss.protocol.layout import Layout, NetData
from pyuss.protocol.pkw import ResponseId
from pyuss.protocol.telegram import AddressMode

__all__ = ["choose", "decode", "job_notes", "learn", "net_words", "unpack"]


def choose(layouts: LayoutBook, frame: Frame, address: int | None) -> LayoutChoice | None:
    """The layout ``frame`` is read with, as for ``address`` (None: the telegram's own)."""
    tg = frame.telegram
    if tg is None or tg.mode not in (AddressMode.NORMAL, AddressMode.BROADCAST):
        return None
    if len(tg.data) % 2:
        return None
    words = len(tg.data) // 2
    if tg.mode is AddressMode.BROADCAST:
        return layouts.broadcast_choice(words)
    return layouts.choice(address if address is not None else tg.address, words)


def decode(
    layouts: LayoutBook, frame: Frame | None, address: int | None, issues: list[Issue], where: str
) -> tuple[NetData | None, LayoutChoice | None]:
    """The net data of ``frame`` (the request or answer, ``where``) and the layout it was read
    with; what keeps it from being read goes to ``issues``."""
    if frame is None or frame.telegram is None:
        return None, None
    choice = choose(layouts, frame, address)
    if choice is None:
        odd = len(frame.telegram.data) % 2
        if frame.fault is None and frame.telegram.mode is AddressMode.NORMAL and odd:
            issues.append(
                Issue(
                    Problem.LAYOUT,
                    where,
                    f"{len(frame.telegram.data)} net bytes are not whole words (A 4)",
                )
            )
        return None, None
    try:
        return choice.layout.unpack(frame.telegram.data), choice
    except TelegramError as exc:
        if frame.fault is None:  # a damaged frame has its fault already
            issues.append(Issue(Problem.LAYOUT, where, str(exc)))
        return None, choice


def learn(layouts: LayoutBook, request: Frame | None, answer: Frame | None) -> None:
    """Feed good normal telegrams to the layout inference."""
    if request is None or not request.ok or request.mode is not AddressMode.NORMAL:
        return
    assert request.telegram is not None
    rq = request.telegram.data
    if len(rq) % 2:
        return
    words = net_words(rq)
    answer_words = None
    if answer is not None and answer.ok and answer.address == request.address:
        assert answer.telegram is not None
        if len(answer.telegram.data) % 2 == 0:
            answer_words = net_words(answer.telegram.data)
    layouts.observe(request.telegram.address, words, answer_words)


def net_words(data: bytes) -> tuple[int, ...]:
    """Net data as 16-bit words, high byte first."""
    return tuple(int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2))


def unpack(layout: Layout, data: bytes) -> NetData | None:
    """Net data read with ``layout``, None where it does not fit."""
    try:
        return layout.unpack(data)
    except TelegramError:
        return None


def job_notes(request: NetData, answer: NetData) -> list[str]:
    """What the PKW of an answer says of the request's job, when not its answer (C 4.2.1)."""
    job, reply = request.pkw, answer.pkw
    if job is None or reply is None:
        return []
    rid = ResponseId(reply.id)
    if rid.is_spontaneous:
        return ["spontaneous message (C 4.2.1.2)"]
    if reply.is_answer_to(job):
        return []
    if rid is ResponseId.NO_RESPONSE:
        return ["no response yet: the slave is still working on the job (C 4.2.1.1)"]
    return ["the answer belongs to an earlier job (C 4.2.1.1)"]
