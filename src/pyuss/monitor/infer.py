"""Which layout (PKW and PZD word counts, C 3.1) each address uses: given, or inferred.

A monitor that is not told the layouts finds them from the traffic. For every exchange of
good telegrams with an address, each possible layout (PKW 0, 3, 4 or variable; PZD 0..16) is
scored:

- Lengths rule out most layouts: a fixed layout has ``PKW + PZD`` words in both directions
  (C 4.1.1, C 7); the variable one keeps the PZD count and needs at least PKE, IND, one PWE
  (C 4.1.2).
- The answer must fit the request (C Table 4.3): its response ID must be one that answers the
  request ID (or a spontaneous message, C 4.2.1.2), with the same PNU. A reserved ID (request
  10, responses 13 and 14) counts against a layout, as do IND bits 0..9 set for a job that
  takes no index (C 4.2.2) and a "no job" with values (C 4.2.1.1: unused fields are 0).
- The PWE count must fit the ID: a double word needs PKW 4 or the variable layout; with PKW 4 a
  word travels in PWE2 with PWE1 = 0 (reading 6); with the variable layout the number of PWE
  words must match a word or a double word.
- A master sets bit 10 of the control word ("control by PLC", C Table 5.4) to make its process
  data count, so a PZD1 with bit 10 set counts for a layout.

The scores add up over the exchanges seen. The best layout is *inferred* when the lengths
rule out every layout that would split the words differently, or when it leads all of them
by a clear margin after at least two exchanges; otherwise it is a *guess* and says so
(`LayoutSource.GUESSED`). While an address has only a guess, a layout clearly inferred for
another address is preferred if its telegrams allow it: devices on one bus mostly share a
layout. Ties go to the common layouts first (PKW 3, then 4, 0, variable; PZD 2 first).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from pyuss.errors import ConfigError
from pyuss.monitor.model import LayoutSource
from pyuss.protocol.layout import MAX_PZD, MAX_WORDS, PKW_VARIABLE, Layout
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId, expected_responses
from pyuss.protocol.telegram import MAX_ADDRESS

__all__ = ["CANDIDATES", "LayoutBook", "LayoutChoice", "score_exchange"]

_PZD_ORDER = (2, 0, 1, 3, 4, 5, 6, *range(7, MAX_PZD + 1))
CANDIDATES: tuple[Layout, ...] = tuple(
    Layout(pkw, pzd) for pkw in (3, 4, 0, PKW_VARIABLE) for pzd in _PZD_ORDER
)
"""Every layout, most common first (the order breaks ties)."""

_MARGIN = 3.0
_MIN_EXCHANGES = 2
_CONTROL_BY_PLC = 0x0400

# How many PWE words each response ID carries with the variable layout (None: any number).
_R = ResponseId
_ANSWER_PWE: dict[int, int | None] = {
    _R.NO_RESPONSE: None,
    _R.VALUE_WORD: 1,
    _R.VALUE_DWORD: 2,
    _R.PBE_ELEMENT: None,
    _R.ARRAY_WORD: 1,
    _R.ARRAY_DWORD: 2,
    _R.ARRAY_COUNT: 1,
    _R.REFUSED: 1,
    _R.NO_AUTHORITY: 1,
    _R.SPONTANEOUS_WORD: 1,
    _R.SPONTANEOUS_DWORD: 2,
    _R.SPONTANEOUS_ARRAY_WORD: 1,
    _R.SPONTANEOUS_ARRAY_DWORD: 2,
    _R.TEXT: None,
}
_DWORD_ANSWERS = frozenset(k for k, v in _ANSWER_PWE.items() if v == 2)
_WORD_ANSWERS = frozenset(
    {_R.VALUE_WORD, _R.ARRAY_WORD, _R.SPONTANEOUS_WORD, _R.SPONTANEOUS_ARRAY_WORD}
)
_Q = RequestId
_DWORD_REQUESTS = frozenset(
    {_Q.WRITE_DWORD, _Q.WRITE_ARRAY_DWORD, _Q.WRITE_ARRAY_DWORD_EEPROM, _Q.WRITE_DWORD_EEPROM}
)
_WORD_REQUESTS = frozenset(
    {_Q.WRITE_WORD, _Q.WRITE_ARRAY_WORD, _Q.WRITE_ARRAY_WORD_EEPROM, _Q.WRITE_WORD_EEPROM}
)
_READ_REQUESTS = frozenset(
    {_Q.NO_JOB, _Q.READ_VALUE, _Q.READ_PBE_ELEMENT, _Q.READ_ARRAY, _Q.READ_ARRAY_COUNT}
)


def _split(layout: Layout, words: Sequence[int]) -> tuple[Pkw | None, Sequence[int]] | None:
    n = len(words)
    if layout.variable:
        if not layout.pzd + 3 <= n <= MAX_WORDS:
            return None
        cut = n - layout.pzd
    else:
        if n != layout.pkw + layout.pzd:
            return None
        cut = layout.pkw
    pkw = Pkw.from_words(words[:cut]) if cut else None
    return pkw, words[cut:]


def _score_request(layout: Layout, job: Pkw) -> float:
    score = 0.0
    rid = RequestId(job.id)
    if rid is RequestId.RESERVED_10:
        score -= 3
    if not rid.is_indexed and job.index & 0x03FF:
        score -= 1
    if rid is RequestId.NO_JOB and (job.pnu or job.index or any(job.values)):
        score -= 1
    m = len(job.values)
    if layout.pkw == 3 and rid in _DWORD_REQUESTS:
        score -= 3
    if layout.pkw == 4 and rid in _WORD_REQUESTS and job.values[0] != 0:
        score -= 1
    if layout.variable:
        want = 2 if rid in _DWORD_REQUESTS else 1 if rid in _WORD_REQUESTS | _READ_REQUESTS else 0
        if want and m != want:
            score -= 2
    return score


def _score_answer(layout: Layout, job: Pkw, answer: Pkw) -> float:
    score = 0.0
    aid = ResponseId(answer.id)
    if aid in (ResponseId.RESERVED_13, ResponseId.RESERVED_14):
        return -3
    if aid in expected_responses(job.id) or aid.is_spontaneous:
        score += 2
        if job.id != RequestId.NO_JOB and not aid.is_spontaneous:
            score += 2 if answer.pnu == job.pnu else -1
    elif aid is not ResponseId.NO_RESPONSE:
        score -= 2
    if layout.pkw == 3 and aid in _DWORD_ANSWERS:
        score -= 3
    if layout.pkw == 4 and aid in _WORD_ANSWERS and answer.values[0] != 0:
        score -= 1
    if layout.variable:
        want = _ANSWER_PWE.get(aid)
        if want is not None and len(answer.values) != want:
            score -= 2
    return score


def score_exchange(
    layout: Layout, request: Sequence[int], answer: Sequence[int] | None
) -> float | None:
    """How well ``layout`` explains a request and its answer (net data words); None when the
    lengths rule it out. See the module text for the rules."""
    req = _split(layout, request)
    if req is None:
        return None
    ans = None
    if answer is not None:
        ans = _split(layout, answer)
        if ans is None:
            return None
    score = 0.0
    job, pzd = req
    if job is not None:
        score += _score_request(layout, job)
        if ans is not None and ans[0] is not None:
            score += _score_answer(layout, job, ans[0])
    if pzd and pzd[0] & _CONTROL_BY_PLC:
        score += 1
    return score


@dataclass(frozen=True, slots=True)
class LayoutChoice:
    """The layout to decode an address with, and where it came from."""

    layout: Layout
    source: LayoutSource


class _Evidence:
    __slots__ = ("exchanges", "scores")

    def __init__(self) -> None:
        self.scores: dict[Layout, float] = {c: 0.0 for c in CANDIDATES}
        self.exchanges = 0

    def add(self, request: Sequence[int], answer: Sequence[int] | None) -> None:
        for layout in list(self.scores):
            score = score_exchange(layout, request, answer)
            if score is None:
                del self.scores[layout]
            else:
                self.scores[layout] += score
        self.exchanges += 1

    def best(self, words: int | None) -> LayoutChoice | None:
        """The best layout that can carry ``words`` words (any when None)."""
        ranked = [
            (score, -i, layout)
            for i, (layout, score) in enumerate(self.scores.items())
            if words is None or _split(layout, [0] * words) is not None
        ]
        if not ranked:
            return None
        ranked.sort(reverse=True)
        score, _, layout = ranked[0]
        rivals = [s for s, _, other in ranked[1:] if not _same_split(layout, other)]
        sure = not rivals or (self.exchanges >= _MIN_EXCHANGES and score - rivals[0] >= _MARGIN)
        return LayoutChoice(layout, LayoutSource.INFERRED if sure else LayoutSource.GUESSED)


def _same_split(a: Layout, b: Layout) -> bool:
    """Layouts that decode the telegrams seen the same way: same PZD count, one fixed and the
    other variable (PKW 3 and variable with one PWE word split 5 words alike)."""
    return a.pzd == b.pzd and a.variable != b.variable


def _guess_from_length(words: int) -> LayoutChoice | None:
    for layout in CANDIDATES:
        if _split(layout, [0] * words) is not None:
            return LayoutChoice(layout, LayoutSource.GUESSED)
    return None


class LayoutBook:
    """The layouts of a bus: ``default`` for every address and ``per_address`` overrides,
    both given by the user; inferred for the other addresses (see the module text).

    `choice` tells which layout to decode a telegram of an address with, `observe` feeds an
    exchange's net data words to the inference.
    """

    def __init__(
        self, default: Layout | None = None, per_address: Mapping[int, Layout] | None = None
    ) -> None:
        self.default = default
        self.per_address: dict[int, Layout] = {}
        for address, layout in (per_address or {}).items():
            if isinstance(address, bool) or not isinstance(address, int):
                raise ConfigError(f"layout given for address {address!r}, not 0..{MAX_ADDRESS}")
            if not 0 <= address <= MAX_ADDRESS:
                raise ConfigError(f"layout given for address {address}, not 0..{MAX_ADDRESS}")
            self.per_address[address] = layout
        self._evidence: dict[int, _Evidence] = {}

    @classmethod
    def parse(cls, texts: Sequence[str]) -> LayoutBook:
        """From ``--layout`` options: ``PKW,PZD`` for every address, ``ADR=PKW,PZD`` for one
        (``ADR`` 0..31; several addresses as ``1+2+5=3,2``)."""
        default: Layout | None = None
        per: dict[int, Layout] = {}
        for text in texts:
            left, eq, right = str(text).partition("=")
            if not eq:
                if default is not None:
                    raise ConfigError(
                        f"layout {text!r}: a layout for every address was given twice; "
                        "use ADR=PKW,PZD for single addresses"
                    )
                default = Layout.parse(text)
                continue
            layout = Layout.parse(right)
            for part in left.split("+"):
                part = part.strip()
                if not part.isdigit() or not 0 <= int(part) <= MAX_ADDRESS:
                    raise ConfigError(
                        f"layout {text!r}: {part!r} is not a slave address 0..{MAX_ADDRESS}"
                    )
                if int(part) in per:
                    raise ConfigError(f"layout {text!r}: address {part} was given a layout twice")
                per[int(part)] = layout
        return cls(default, per)

    def given(self, address: int | None) -> Layout | None:
        """The layout the user gave for ``address`` (None: infer it)."""
        if address is not None and address in self.per_address:
            return self.per_address[address]
        return self.default

    def fixed_lengths(self) -> dict[int, int]:
        """ADR address -> LGE for every address with a given fixed layout, for a receiver
        (A 4.2.2, A 5.2: a wrong LGE is a fault in fixed-length operation)."""
        out: dict[int, int] = {}
        for address in range(MAX_ADDRESS + 1):
            layout = self.given(address)
            if layout is not None and layout.lge is not None:
                out[address] = layout.lge
        return out

    def observe(self, address: int, request: Sequence[int], answer: Sequence[int] | None) -> None:
        """Learn from a good request (and its good answer) to ``address``: net data words."""
        if self.given(address) is None:
            self._evidence.setdefault(address, _Evidence()).add(request, answer)

    def choice(self, address: int | None, words: int | None = None) -> LayoutChoice | None:
        """The layout to decode a telegram of ``address`` carrying ``words`` net data words;
        None when nothing fits (odd byte count, or no evidence and no length)."""
        given = self.given(address)
        if given is not None:
            return LayoutChoice(given, LayoutSource.GIVEN)
        evidence = self._evidence.get(address) if address is not None else None
        best = evidence.best(words) if evidence is not None else None
        if best is not None and best.source is LayoutSource.INFERRED:
            return best
        # Little evidence: devices on one bus mostly share a layout, so a layout inferred for
        # another address is the better guess, if this address's telegrams allow it.
        shared = self._shared(address, words, evidence)
        if shared is not None:
            return LayoutChoice(shared, LayoutSource.GUESSED)
        if best is not None:
            return best
        return None if words is None else _guess_from_length(words)

    def _shared(
        self, address: int | None, words: int | None, evidence: _Evidence | None
    ) -> Layout | None:
        for other, theirs in sorted(self._evidence.items()):
            if other == address:
                continue
            choice = theirs.best(words)
            if choice is None or choice.source is not LayoutSource.INFERRED:
                continue
            if evidence is None or choice.layout in evidence.scores:
                return choice.layout
        return None

    def broadcast_choice(self, words: int) -> LayoutChoice | None:
        """The layout for a broadcast of ``words`` words (A 3: a broadcast needs a common
        telegram length): a given layout that carries that many words (the default first),
        else the given default (which then does not fit), else the layout inferred for an
        address whose telegrams have that length, else a guess from the length."""
        given = [self.default] if self.default is not None else []
        given += self.per_address.values()
        for layout in given:
            if _split(layout, [0] * words) is not None:
                return LayoutChoice(layout, LayoutSource.GIVEN)
        if self.default is not None:
            return LayoutChoice(self.default, LayoutSource.GIVEN)
        for evidence in self._evidence.values():
            best = evidence.best(words)
            if best is not None and best.layout.words == words:
                return best
        return _guess_from_length(words)

    def summary(self) -> dict[int, LayoutChoice]:
        """The current choice for every address with a given layout or evidence."""
        out: dict[int, LayoutChoice] = {}
        for address in sorted(set(self.per_address) | set(self._evidence)):
            choice = self.choice(address)
            if choice is not None:
                out[address] = choice
        return out
