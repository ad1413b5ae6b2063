"""Exchanges and summaries for people: one line per exchange, and a table.

The line of an exchange reads, left to right::

    TIME  ADR  LAYOUT  JOB -> ANSWER  CW .. SP ..  SW .. AV ..  DELAY  !! PROBLEMS  (unsure: ..)

- TIME: seconds since the first frame (or absolute, wall clock, with ``absolute=True``).
- ADR: ``adr 5``; ``adr 7 mirror``, ``adr 3 special``, ``broadcast``.
- LAYOUT: ``3,2``; a trailing ``?`` when the layout is a guess (`LayoutSource.GUESSED`).
- JOB -> ANSWER: the parameter job and the answer in words (C 4, Tables 4.1..4.3).
- CW/SW: control and status word (PZD1, C 5.2.1) with the bits that changed since the last
  telegram of that address (``+ON -NO_OFF2``; the first time the bits that are set);
  SP/AV: setpoint and actual value (PZD2) in percent of 4000h (C 5.2.2); more PZD in hex.
- With a `ValueText` (the device profile is known: ``uss monitor --profile``), parameter
  values and PZD3 and up that the profile maps to parameters show typed and scaled, in their
  unit, the words in hex after them (``P1120 = 10.00 s (41200000h)``), and the bits of
  control and status words by the names a person reads (`pyuss.params.words`: ``SW
  EA31h(+ready to switch on, +no OFF2, +no OFF3, -switch-on inhibited)``; the first time
  the bits that are set, with the family's names of bits 11..15).
- DELAY: the response delay (A 5.2.1.1).
- ``!!`` then every problem as ``name: what`` (receive faults, no answer, late answer, wrong
  address, ...); ``(unsure: ...)`` when the pairing on a 2-wire line is a guess.

With colours (a terminal), problems are red and guesses yellow.
"""

from __future__ import annotations

import datetime as _dt
from typing import Protocol

from pyuss.errors import TelegramError
from pyuss.monitor.model import Exchange, LayoutSource
from pyuss.monitor.stats import Summary
from pyuss.protocol.layout import NetData
from pyuss.protocol.pkw import (
    INDEX_ALL,
    Pkw,
    RequestId,
    ResponseId,
    error_meaning,
    page_of,
    parameter_number,
)
from pyuss.protocol.pzd import ControlWord, StatusWord, raw16_to_percent
from pyuss.protocol.telegram import AddressMode

__all__ = ["ValueText", "answer_text", "exchange_line", "job_text", "summary_table"]

_RED, _YELLOW, _RESET = "\x1b[31m", "\x1b[33m", "\x1b[0m"
_STANDARD_BITS = 11
_MAX_VALUES = 8
_NOISE_BYTES = 16
_NS = 1_000_000_000


class ValueText(Protocol):
    """What the device profile tells of values (the monitor itself knows no profile: the
    command that runs it gives one). Each returns None where it knows nothing."""

    def parameter(self, pnu: int, index: int | None, words: tuple[int, ...]) -> str | None:
        """The value ``words`` carry for parameter ``pnu`` (element ``index``), with unit."""
        ...

    def process(self, request: bool, number: int, word: int) -> str | None:
        """PZD``number`` (3 and up) of a request (a setpoint) or an answer (an actual value)."""
        ...

    def name(self, pnu: int) -> str | None:
        """Parameter ``pnu`` as the device family's documents write it (``r0021``)."""
        ...

    def bits(self, request: bool, word: int, before: int | None) -> str | None:
        """The bits of a control word (``request``) or status word that changed since
        ``before`` (``+name, -name``), or with ``before`` None the bits that are set, named
        as the device family names them; "" when none changed."""
        ...


def _name(param: int, known: ValueText | None) -> str:
    """``P21``, or the family's spelling where the profile gives one."""
    named = None if known is None else known.name(param)
    return named if named is not None else f"P{param}"


def _value(
    pkw: Pkw, double: bool, pnu: int = 0, index: int | None = None, known: ValueText | None = None
) -> str:
    words: tuple[int, ...]
    try:
        if double:
            value = pkw.dword()
            raw, words = f"{value:08X}h", (value >> 16, value & 0xFFFF)
        else:
            value = pkw.word()
            raw, words = f"{value:04X}h", (value,)
    except TelegramError:
        return _words(pkw.values)
    typed = None if known is None else known.parameter(pnu, index, words)
    return f"{typed if typed is not None else value} ({raw})"


def _words(values: tuple[int, ...]) -> str:
    shown = " ".join(f"{w:04X}h" for w in values[:_MAX_VALUES])
    return shown + (f" .. ({len(values)} words)" if len(values) > _MAX_VALUES else "")


def _sub(pkw: Pkw) -> str:
    return "all" if pkw.subindex == INDEX_ALL else str(pkw.subindex)


_DWORD_JOBS = {
    RequestId.WRITE_DWORD,
    RequestId.WRITE_ARRAY_DWORD,
    RequestId.WRITE_ARRAY_DWORD_EEPROM,
    RequestId.WRITE_DWORD_EEPROM,
}
_EEPROM_JOBS = {
    RequestId.WRITE_ARRAY_DWORD_EEPROM,
    RequestId.WRITE_ARRAY_WORD_EEPROM,
    RequestId.WRITE_DWORD_EEPROM,
    RequestId.WRITE_WORD_EEPROM,
}


def job_text(pkw: Pkw, page_size: int | None = None, known: ValueText | None = None) -> str:
    """A parameter job (request, C Table 4.1) in words; ``page_size``: parameter numbers per
    IND page of the device (2000 for MICROMASTER 4: PNU 10 on page 1 shows as P2010);
    ``known``: the values typed by the device profile."""
    rid = RequestId(pkw.id)
    param = parameter_number(pkw.pnu, pkw.index, page_size)
    p, sub = _name(param, known), _sub(pkw)
    if rid is RequestId.NO_JOB:
        return "no job"
    if rid is RequestId.READ_VALUE:
        return f"read {p}"
    if rid is RequestId.READ_PBE_ELEMENT:
        return f"read {p} description[{sub}]"
    if rid is RequestId.WRITE_PBE_ELEMENT:
        return f"write {p} description[{sub}] = {_words(pkw.values)}"
    if rid is RequestId.READ_ARRAY:
        return f"read {p}[{sub}]"
    if rid is RequestId.READ_ARRAY_COUNT:
        return f"read {p} array length"
    if rid is RequestId.RESERVED_10:
        return f"reserved request 10 {p}"
    if rid is RequestId.TEXT:
        write = bool(pkw.index & 0x0100)
        field = " value texts" if pkw.index & 0x0200 else ""
        if write:
            return f"write text {p}[{sub}]{field} = {pkw.text()!r}"
        return f"read text {p}[{sub}]{field}"
    verb = "write+store" if rid in _EEPROM_JOBS else "write"
    target = f"{p}[{sub}]" if rid.is_indexed else p
    index = pkw.subindex if rid.is_indexed else None
    return f"{verb} {target} = {_value(pkw, rid in _DWORD_JOBS, param, index, known)}"


def answer_text(pkw: Pkw, page_size: int | None = None, known: ValueText | None = None) -> str:
    """An answer (response, C Table 4.2) in words (``page_size`` and ``known`` as for
    `job_text`)."""
    aid = ResponseId(pkw.id)
    param = parameter_number(pkw.pnu, pkw.index, page_size)
    p, sub = _name(param, known), _sub(pkw)
    double = aid in (
        ResponseId.VALUE_DWORD,
        ResponseId.ARRAY_DWORD,
        ResponseId.SPONTANEOUS_DWORD,
        ResponseId.SPONTANEOUS_ARRAY_DWORD,
    )
    if aid is ResponseId.NO_RESPONSE:
        return "no response"
    if aid is ResponseId.REFUSED:
        number = pkw.error_number
        if number is None:
            return "REFUSED (no error number)"
        return f"REFUSED error {number}: {error_meaning(number)}"
    if aid is ResponseId.NO_AUTHORITY:
        return "NO AUTHORITY: no parameter change rights"
    if aid in (ResponseId.RESERVED_13, ResponseId.RESERVED_14):
        return f"reserved response {aid.value} {p}"
    if aid is ResponseId.PBE_ELEMENT:
        return f"{p} description[{sub}] = {_words(pkw.values)}"
    if aid is ResponseId.ARRAY_COUNT:
        return f"{p} array length {_value(pkw, False)}"
    if aid is ResponseId.TEXT:
        return f"text {p}[{sub}] = {pkw.text()!r}"
    spont = "spontaneous " if aid.is_spontaneous else ""
    target = f"{p}[{sub}]" if aid.is_indexed else p
    if pkw.subindex == INDEX_ALL and aid.is_indexed:
        return f"{spont}{target} = {_words(pkw.values)}"
    index = pkw.subindex if aid.is_indexed else None
    return f"{spont}{target} = {_value(pkw, double, param, index, known)}"


def _bits(word: int, before: int | None, flags: type[ControlWord] | type[StatusWord]) -> str:
    if before is None:
        names = [f.name for f in flags(word) if f.name and f.value < 1 << _STANDARD_BITS]
        return "(" + " ".join(names) + ")" if names else ""
    changed = word ^ before
    parts = []
    for bit in range(16):
        if changed >> bit & 1:
            parts.append(("+" if word >> bit & 1 else "-") + str(flags(1 << bit).name))
    return "(" + " ".join(parts) + ")" if parts else ""


def _pzd_text(
    data: NetData, before: int | None, request: bool, known: ValueText | None = None
) -> str:
    if not data.pzd:
        return ""
    word = data.pzd[0]
    first, value = ("CW", "SP") if request else ("SW", "AV")
    flags = ControlWord if request else StatusWord
    named = None if known is None else known.bits(request, word, before)
    bits = _bits(word, before, flags) if named is None else f"({named})" if named else ""
    parts = [f"{first} {word:04X}h{bits}"]
    if len(data.pzd) > 1:
        parts.append(f"{value} {raw16_to_percent(data.pzd[1]):.2f}%")
    for i, w in enumerate(data.pzd[2:], 3):
        typed = None if known is None else known.process(request, i, w)
        parts.append(f"PZD{i} {w:04X}h" if typed is None else f"PZD{i} {typed} ({w:04X}h)")
    return " ".join(parts)


def _where(ex: Exchange) -> str:
    mode = ex.mode
    if mode is not None and mode.is_broadcast:
        return "broadcast" if mode is AddressMode.BROADCAST else "special broadcast"
    if ex.address is None:
        return "adr ?"
    suffix = {AddressMode.MIRROR: " mirror", AddressMode.SPECIAL: " special"}.get(mode, "")  # type: ignore[arg-type]
    return f"adr {ex.address}{suffix}"


def _layout(ex: Exchange) -> str:
    if ex.layout is None:
        return "-"
    return f"{ex.layout}{'?' if ex.layout_source is LayoutSource.GUESSED else ''}"


def _net_text(
    ex: Exchange, page_size: int | None = None, known: ValueText | None = None
) -> list[str]:
    """Job -> answer and the PZD texts."""
    mode = ex.mode
    if mode in (AddressMode.MIRROR, AddressMode.SPECIAL, AddressMode.SPECIAL_BROADCAST):
        text = _data_text(ex)
        if text and mode is AddressMode.MIRROR and ex.answer is not None and ex.request is not None:
            text += " mirrored" if ex.answer.raw == ex.request.raw else " NOT mirrored"
        return [text] if text else []
    parts: list[str] = []
    rq, an = ex.request_data, ex.answer_data
    job = rq.pkw if rq is not None else None
    reply = an.pkw if an is not None else None
    if job is not None or reply is not None:
        left = job_text(job, page_size, known) if job is not None else "?"
        if ex.answer is None:
            parts.append(left)
        else:
            right = answer_text(reply, page_size, known) if reply is not None else "?"
            parts.append(f"{left} -> {right}")
        paged = next((p for p in (job, reply) if p is not None and page_of(p.index)), None)
        if page_size is None and paged is not None:
            # the number is not the PNU alone on a family that counts IND pages in: say so
            parts.append(f"(IND page {page_of(paged.index)}: --profile counts it in)")
    if rq is not None and (text := _pzd_text(rq, ex.control_before, True, known)):
        parts.append(text)
    if an is not None and (text := _pzd_text(an, ex.status_before, False, known)):
        parts.append(text)
    if not parts and (text := _data_text(ex)):
        parts.append(text)  # net data that fit no layout: the bytes
    return parts


def _data_text(ex: Exchange) -> str:
    """The net data of the first telegram of ``ex`` in hex ("" when there is none)."""
    first = next((f.telegram for f in ex.frames if f.telegram is not None), None)
    if first is None:
        return ""
    data = first.data
    shown = data[:_NOISE_BYTES].hex(" ").upper() + (" .." if len(data) > _NOISE_BYTES else "")
    return f"data {shown or '-'}"


def _time(seconds: float, origin: float, absolute: bool) -> str:
    if absolute:
        stamp = _dt.datetime.fromtimestamp(seconds + origin)
        return stamp.strftime("%H:%M:%S.%f")
    # in whole nanoseconds, as captures keep them: a replay prints the same times
    return f"{(round(seconds * _NS) - round(origin * _NS)) / _NS:12.6f}"


def _delay(ex: Exchange) -> str | None:
    """The response delay in ms, from the frames' times in whole nanoseconds (as captures keep
    them, so that a replay prints the same)."""
    if ex.delay is None or ex.request is None or ex.answer is None:
        return None
    nanos = max(0, round(ex.answer.start * _NS) - round(ex.request.end * _NS))
    return f"{nanos / 1e6:.3f} ms"


def exchange_line(
    ex: Exchange,
    *,
    origin: float = 0.0,
    absolute: bool = False,
    color: bool = False,
    page_size: int | None = None,
    known: ValueText | None = None,
) -> str:
    """One line for ``ex`` (see the module text). ``origin`` is subtracted from times (or,
    with ``absolute``, added to make them Unix time); ``page_size``: parameter numbers per IND
    page of the devices (P2010 rather than PNU 10 for MICROMASTER 4); ``known``: values typed
    by the devices' profile."""
    parts = [_time(ex.time, origin, absolute), f"{_where(ex):<8}", f"{_layout(ex):<5}"]
    if ex.kind == "noise" and ex.request is not None:
        raw = ex.request.raw
        shown = raw[:_NOISE_BYTES].hex(" ").upper() + (" .." if len(raw) > _NOISE_BYTES else "")
        parts.append(f"{len(raw)} bytes: {shown}")
    parts += _net_text(ex, page_size, known)
    delay = _delay(ex)
    if delay is not None:
        parts.append(delay)
    parts += list(ex.notes)
    line = "  ".join(parts)
    if ex.issues:
        problems = "!! " + "; ".join(f"{i.problem.value}: {i.text}" for i in ex.issues)
        line += "  " + (f"{_RED}{problems}{_RESET}" if color else problems)
    if ex.unsure:
        unsure = f"(unsure: {ex.unsure})"
        line += "  " + (f"{_YELLOW}{unsure}{_RESET}" if color else unsure)
    return line


_COLUMNS = (
    ("adr", 5),
    ("layout", 13),
    ("req", 7),
    ("ans", 7),
    ("noans", 6),
    ("late", 5),
    ("wrong", 6),
    ("err%", 6),
    ("rx errors", 10),
    ("good/min", 9),
    ("disc/min", 9),
    ("frame", 6),
    ("ovr", 4),
    ("par", 4),
    ("stx", 4),
    ("resid", 6),
    ("bcc", 4),
    ("lge", 4),
    ("tmo", 4),
    ("resp ms min/avg/p95/max", 0),
)


def summary_table(summary: Summary, now: float) -> str:
    """The summary as a table: one row per address and one for the whole line (A 5.2.3
    counters, error rates, response times). The column ``rx errors`` is the receive error
    status of A 5.2.3 (diagnostic parameter 4, `pyuss.protocol.diagnostics.ErrorStatus`: bit 0
    framing .. bit 7 timeout, latched) in hex - not the drive's status word."""

    def ms(value: float | None) -> str:
        return "-" if value is None else f"{value:.2f}"

    header = " ".join(f"{name:<{width}}" if width else name for name, width in _COLUMNS)
    lines = [header.rstrip()]
    for row in summary.rows(now):
        c, r = row["counters"], row["response_time"]
        cells = (
            "line" if row["address"] is None else str(row["address"]),
            row["layout"] or "-",
            row["requests"],
            row["answers"],
            row["no_answer"],
            row["late"],
            row["wrong_address"],
            f"{row['error_rate'] * 100:.1f}",
            f"{row['error_status']:04X}h",
            c["good_per_minute"],
            c["discarded_per_minute"],
            c["framing"],
            c["overrun"],
            c["parity"],
            c["no_stx"],
            c["residual_time"],
            c["bcc"],
            c["bad_lge"],
            c["timeout"],
            "/".join(ms(r[k]) for k in ("min_ms", "mean_ms", "p95_ms", "max_ms")),
        )
        lines.append(
            " ".join(
                f"{cell!s:<{width}}" if width else str(cell)
                for cell, (_, width) in zip(cells, _COLUMNS, strict=True)
            ).rstrip()
        )
    return "\n".join(lines)
