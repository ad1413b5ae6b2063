"""The parameter channel (PKW: Parameter-Kennung-Wert) of the net data (C 4).

The PKW area is ``PKE, IND, PWE1 .. PWEm`` (C 4.1):

- PKE (C 4.2.1, reading 8): bits 15..12 request or response ID, bit 11 the spontaneous-message
  toggle (C 4.2.1.2), bits 10..0 the parameter number PNU (0..2047).
- IND (C 4.2.2): low byte the subindex (array element or description element; 255 = the whole
  array or description), bits 8 and 9 select the text field and reading or writing for request
  15 (Tables 4.5, 4.6), bits 10..15 are device-specific (Table 4.7) and left to profiles.
- PWE (C 4.2.3, C 6, reading 6/7): words, high byte first; a double word as PWE1 = high word,
  PWE2 = low word; byte strings and text characters in storage order, the first displayed
  character first.

`Pkw` keeps the PWE words exactly as they travel (``values``); the ``pwe_*`` helpers build
them from numbers, text or bytes and `Pkw.word`, `Pkw.dword` and friends read them back.
Where a 16-bit value sits in a 4-word PKW area (PWE2) is the layout's business
(`pyuss.protocol.layout`).

Request and response IDs carry English names; each member's ``german`` property gives the
name in C Tables 4.1 and 4.2, and ``text`` a sentence for people.
"""

from __future__ import annotations

import enum
import struct
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from pyuss.errors import ConfigError, TelegramError
from pyuss.protocol.frozen import builder

__all__ = [
    "INDEX_ALL",
    "MAX_PNU",
    "NO_AUTHORITY_HINT",
    "SPONTANEOUS_IDS",
    "ErrorNumber",
    "Pkw",
    "RequestId",
    "ResponseId",
    "TextIndex",
    "bytes_to_words",
    "error_hint",
    "error_meaning",
    "expected_responses",
    "make_index",
    "page_of",
    "parameter_number",
    "positive_responses",
    "pwe_dword",
    "pwe_dwords",
    "pwe_float",
    "pwe_text",
    "pwe_word",
    "pwe_words",
    "unpacked_pkw",
    "words_to_bytes",
    "words_to_text",
]

MAX_PNU = 0x7FF
"""PNU is 11 bits: 0..2047 (C 4.2.1.3, reading 8)."""
INDEX_ALL = 255
"""IND low byte 255: the whole array or the whole parameter description (C 4.2.2)."""

_TOGGLE = 0x0800

PAGE_BITS = (15, 12, 13, 14)
"""IND bits carrying a parameter page number, lowest weight first: MICROMASTER 4 and SINAMICS
reach parameters from 2000 on as PNU + page x 2000, bit 15 weighing 1 (device-specific IND
bits of C Table 4.7; the profile says whether a device pages and how many numbers a page has)."""


def page_of(index: int) -> int:
    """The page number carried in IND bits 12..15 (bit 15 weighs 1, 12 two, 13 four, 14 eight)."""
    return sum(1 << weight for weight, bit in enumerate(PAGE_BITS) if index >> bit & 1)


def parameter_number(pnu: int, index: int, page_size: int | None) -> int:
    """The parameter number a job addresses with PKE bits 0..10 and the IND word, for a device
    with ``page_size`` numbers per page (None: no paging, the PNU itself)."""
    return pnu if page_size is None else pnu + page_size * page_of(index)


class RequestId(enum.IntEnum):
    """Request IDs, master to slave (C Table 4.1, "Auftragskennung")."""

    NO_JOB = 0
    READ_VALUE = 1
    WRITE_WORD = 2
    WRITE_DWORD = 3
    READ_PBE_ELEMENT = 4
    WRITE_PBE_ELEMENT = 5
    READ_ARRAY = 6
    WRITE_ARRAY_WORD = 7
    WRITE_ARRAY_DWORD = 8
    READ_ARRAY_COUNT = 9
    RESERVED_10 = 10
    WRITE_ARRAY_DWORD_EEPROM = 11
    WRITE_ARRAY_WORD_EEPROM = 12
    WRITE_DWORD_EEPROM = 13
    WRITE_WORD_EEPROM = 14
    TEXT = 15

    @property
    def german(self) -> str:
        """The function's name in C Table 4.1."""
        return _REQUEST_TEXT[self][0]

    @property
    def text(self) -> str:
        """What the request asks for, in English."""
        return _REQUEST_TEXT[self][1]

    @property
    def is_indexed(self) -> bool:
        """IND belongs to the request (footnote 1 of Table 4.1): PBE, array and text jobs."""
        return self in _INDEXED_REQUESTS

    @property
    def is_change(self) -> bool:
        """The request may change something (a slave without PKW authority answers 8).
        `TEXT` counts as one: it reads or writes depending on IND bit 8."""
        return self in _CHANGE_REQUESTS


class ResponseId(enum.IntEnum):
    """Response IDs, slave to master (C Table 4.2, "Antwortkennung")."""

    NO_RESPONSE = 0
    VALUE_WORD = 1
    VALUE_DWORD = 2
    PBE_ELEMENT = 3
    ARRAY_WORD = 4
    ARRAY_DWORD = 5
    ARRAY_COUNT = 6
    REFUSED = 7
    NO_AUTHORITY = 8
    SPONTANEOUS_WORD = 9
    SPONTANEOUS_DWORD = 10
    SPONTANEOUS_ARRAY_WORD = 11
    SPONTANEOUS_ARRAY_DWORD = 12
    RESERVED_13 = 13
    RESERVED_14 = 14
    TEXT = 15

    @property
    def german(self) -> str:
        """The function's name in C Table 4.2."""
        return _RESPONSE_TEXT[self][0]

    @property
    def text(self) -> str:
        """What the response carries, in English."""
        return _RESPONSE_TEXT[self][1]

    @property
    def is_indexed(self) -> bool:
        """IND belongs to the response (footnote 1 of Table 4.2)."""
        return self in _INDEXED_RESPONSES

    @property
    def is_spontaneous(self) -> bool:
        """A spontaneous message (9..12, C 4.2.1.2): not an answer to the current request."""
        return self in SPONTANEOUS_IDS

    @property
    def is_negative(self) -> bool:
        """7 (refused, with an error number) or 8 (no PKW authority)."""
        return self in (ResponseId.REFUSED, ResponseId.NO_AUTHORITY)


SPONTANEOUS_IDS = range(ResponseId.SPONTANEOUS_WORD, ResponseId.SPONTANEOUS_ARRAY_DWORD + 1)
"""The response IDs of spontaneous messages (9..12, C 4.2.1.2), as plain numbers: a PKW
area's ``id`` is looked up here at every answer, without making a `ResponseId` of it."""


_REQUEST_TEXT: dict[RequestId, tuple[str, str]] = {
    RequestId.NO_JOB: ("Kein Auftrag", "no job"),
    RequestId.READ_VALUE: ("PWE anfordern", "read parameter value"),
    RequestId.WRITE_WORD: ("PWE ändern (Wort)", "write parameter value (word)"),
    RequestId.WRITE_DWORD: ("PWE ändern (Doppelwort)", "write parameter value (double word)"),
    RequestId.READ_PBE_ELEMENT: ("PBE-Element anfordern", "read description element"),
    RequestId.WRITE_PBE_ELEMENT: ("PBE-Element ändern", "write description element"),
    RequestId.READ_ARRAY: ("PWE anfordern (Array)", "read array element"),
    RequestId.WRITE_ARRAY_WORD: ("PWE ändern (Array Wort)", "write array element (word)"),
    RequestId.WRITE_ARRAY_DWORD: (
        "PWE ändern (Array Doppelwort)",
        "write array element (double word)",
    ),
    RequestId.READ_ARRAY_COUNT: ("Anzahl der Array-Elemente anfordern", "read array length"),
    RequestId.RESERVED_10: ("Reserve", "reserved"),
    RequestId.WRITE_ARRAY_DWORD_EEPROM: (
        "PWE (Array Doppelwort) ändern und ins EEPROM abspeichern",
        "write array element (double word) and store in EEPROM",
    ),
    RequestId.WRITE_ARRAY_WORD_EEPROM: (
        "PWE (Array Wort) ändern und ins EEPROM abspeichern",
        "write array element (word) and store in EEPROM",
    ),
    RequestId.WRITE_DWORD_EEPROM: (
        "PWE (Doppelwort) ändern und ins EEPROM abspeichern",
        "write parameter value (double word) and store in EEPROM",
    ),
    RequestId.WRITE_WORD_EEPROM: (
        "PWE (Wort) ändern und ins EEPROM abspeichern",
        "write parameter value (word) and store in EEPROM",
    ),
    RequestId.TEXT: ("Text anfordern oder ändern", "read or write text"),
}

_RESPONSE_TEXT: dict[ResponseId, tuple[str, str]] = {
    ResponseId.NO_RESPONSE: ("Keine Antwort", "no response"),
    ResponseId.VALUE_WORD: ("PWE übertragen (Wort)", "parameter value (word)"),
    ResponseId.VALUE_DWORD: ("PWE übertragen (Doppelwort)", "parameter value (double word)"),
    ResponseId.PBE_ELEMENT: ("PBE-Element übertragen", "description element"),
    ResponseId.ARRAY_WORD: ("PWE übertragen (Array Wort)", "array element (word)"),
    ResponseId.ARRAY_DWORD: ("PWE übertragen (Array Doppelwort)", "array element (double word)"),
    ResponseId.ARRAY_COUNT: ("Anzahl der Array-Elemente übertragen", "array length"),
    ResponseId.REFUSED: (
        "Auftrag nicht ausführbar (mit Fehlernummer)",
        "job refused (error number in PWE)",
    ),
    ResponseId.NO_AUTHORITY: ("keine PKW-Bedienhoheit", "no parameter change rights"),
    ResponseId.SPONTANEOUS_WORD: ("Spontanmeldung (Wort)", "spontaneous message (word)"),
    ResponseId.SPONTANEOUS_DWORD: (
        "Spontanmeldung (Doppelwort)",
        "spontaneous message (double word)",
    ),
    ResponseId.SPONTANEOUS_ARRAY_WORD: (
        "Spontanmeldung (Array Wort)",
        "spontaneous message (array word)",
    ),
    ResponseId.SPONTANEOUS_ARRAY_DWORD: (
        "Spontanmeldung (Array Doppelwort)",
        "spontaneous message (array double word)",
    ),
    ResponseId.RESERVED_13: ("Reserve", "reserved"),
    ResponseId.RESERVED_14: ("Reserve", "reserved"),
    ResponseId.TEXT: ("Text übertragen", "text"),
}

_INDEXED_REQUESTS = frozenset(
    {
        RequestId.READ_PBE_ELEMENT,
        RequestId.WRITE_PBE_ELEMENT,
        RequestId.READ_ARRAY,
        RequestId.WRITE_ARRAY_WORD,
        RequestId.WRITE_ARRAY_DWORD,
        RequestId.WRITE_ARRAY_DWORD_EEPROM,
        RequestId.WRITE_ARRAY_WORD_EEPROM,
        RequestId.TEXT,
    }
)
_INDEXED_RESPONSES = frozenset(
    {
        ResponseId.PBE_ELEMENT,
        ResponseId.ARRAY_WORD,
        ResponseId.ARRAY_DWORD,
        ResponseId.SPONTANEOUS_ARRAY_WORD,
        ResponseId.SPONTANEOUS_ARRAY_DWORD,
        ResponseId.TEXT,
    }
)
_CHANGE_REQUESTS = frozenset(
    {
        RequestId.WRITE_WORD,
        RequestId.WRITE_DWORD,
        RequestId.WRITE_PBE_ELEMENT,
        RequestId.WRITE_ARRAY_WORD,
        RequestId.WRITE_ARRAY_DWORD,
        RequestId.WRITE_ARRAY_DWORD_EEPROM,
        RequestId.WRITE_ARRAY_WORD_EEPROM,
        RequestId.WRITE_DWORD_EEPROM,
        RequestId.WRITE_WORD_EEPROM,
        RequestId.TEXT,
    }
)

_R = ResponseId
_POSITIVE: dict[RequestId, frozenset[ResponseId]] = {
    RequestId.NO_JOB: frozenset({_R.NO_RESPONSE}),
    RequestId.READ_VALUE: frozenset({_R.VALUE_WORD, _R.VALUE_DWORD}),
    RequestId.WRITE_WORD: frozenset({_R.VALUE_WORD}),
    RequestId.WRITE_DWORD: frozenset({_R.VALUE_DWORD}),
    RequestId.READ_PBE_ELEMENT: frozenset({_R.PBE_ELEMENT}),
    RequestId.WRITE_PBE_ELEMENT: frozenset({_R.PBE_ELEMENT}),
    RequestId.READ_ARRAY: frozenset({_R.ARRAY_WORD, _R.ARRAY_DWORD}),
    RequestId.WRITE_ARRAY_WORD: frozenset({_R.ARRAY_WORD}),
    RequestId.WRITE_ARRAY_DWORD: frozenset({_R.ARRAY_DWORD}),
    RequestId.READ_ARRAY_COUNT: frozenset({_R.ARRAY_COUNT}),
    RequestId.RESERVED_10: frozenset(),
    RequestId.WRITE_ARRAY_DWORD_EEPROM: frozenset({_R.ARRAY_DWORD}),
    RequestId.WRITE_ARRAY_WORD_EEPROM: frozenset({_R.ARRAY_WORD}),
    RequestId.WRITE_DWORD_EEPROM: frozenset({_R.VALUE_DWORD}),
    RequestId.WRITE_WORD_EEPROM: frozenset({_R.VALUE_WORD}),
    RequestId.TEXT: frozenset({_R.TEXT}),
}


def positive_responses(request: RequestId | int) -> frozenset[ResponseId]:
    """The positive response IDs for ``request`` (C Table 4.3); empty for reserved 10."""
    return _POSITIVE[RequestId(request)]


def expected_responses(request: RequestId | int) -> frozenset[ResponseId]:
    """Every response ID that answers ``request``: the positive ones of C Table 4.3, 7 (refused,
    with an error number) for every job, and 8 (no PKW authority) for change jobs (C 4.2.1.1).
    "No job" is answered by "no response" only.
    """
    req = RequestId(request)
    if req is RequestId.NO_JOB:
        return _POSITIVE[req]
    extra = {_R.REFUSED, _R.NO_AUTHORITY} if req.is_change else {_R.REFUSED}
    return _POSITIVE[req] | extra


class ErrorNumber(enum.IntEnum):
    """Error numbers in PWE of response 7 (C Table 4.3; identical with the PROFIBUS drive profile
    for 0..100; numbers above 100 are device-specific and come from profiles)."""

    ILLEGAL_PNU = 0
    """unzulässige PNU: no such parameter."""
    NOT_CHANGEABLE = 1
    """Parameter nicht änderbar: the value cannot be changed."""
    LIMIT_EXCEEDED = 2
    """Untere oder obere Wertgrenze überschritten: lower or upper limit exceeded."""
    BAD_INDEX = 3
    """fehlerhafter IND: wrong subindex."""
    NOT_ARRAY = 4
    """kein Array: the parameter is not an array."""
    WRONG_TYPE = 5
    """falscher Datentyp: wrong data type."""
    SET_NOT_ALLOWED = 6
    """kein Setzen erlaubt: setting not allowed (only resetting)."""
    DESCRIPTION_NOT_CHANGEABLE = 7
    """Beschreibungselement nicht änderbar: the description element cannot be changed."""

    @property
    def text(self) -> str:
        """The meaning in English."""
        return _ERROR_TEXT[self]


_ERROR_TEXT = {
    ErrorNumber.ILLEGAL_PNU: "illegal parameter number",
    ErrorNumber.NOT_CHANGEABLE: "parameter cannot be changed",
    ErrorNumber.LIMIT_EXCEEDED: "lower or upper limit exceeded",
    ErrorNumber.BAD_INDEX: "wrong index",
    ErrorNumber.NOT_ARRAY: "parameter is not an array",
    ErrorNumber.WRONG_TYPE: "wrong data type",
    ErrorNumber.SET_NOT_ALLOWED: "setting not allowed",
    ErrorNumber.DESCRIPTION_NOT_CHANGEABLE: "description element cannot be changed",
}


def error_meaning(number: int, extra: Mapping[int, str] | None = None) -> str:
    """The meaning of error ``number`` from a response 7.

    0..7 come from C Table 4.3; ``extra`` holds a device profile's own numbers (above 100,
    for example Baumueller's 101..104). Unknown numbers still get a text saying where they
    belong: 8..100 are defined by the PROFIBUS drive profile, above 100 by the device.
    """
    try:
        return ErrorNumber(number).text
    except ValueError:
        pass
    if extra is not None and number in extra:
        return extra[number]
    if 0 <= number <= 100:
        return f"error {number} (PROFIBUS drive profile number, not in the USS spec)"
    return f"device-specific error {number}"


_ERROR_HINT = {
    ErrorNumber.ILLEGAL_PNU: "check the parameter number and the drive's profile: this drive "
    "has no such parameter",
    ErrorNumber.NOT_CHANGEABLE: "the drive does not take a value for it (a display or a fixed "
    "value): read it, or change the parameter that sets it",
    ErrorNumber.LIMIT_EXCEEDED: "give a value within the parameter's limits (a limit may "
    "depend on another parameter)",
    ErrorNumber.BAD_INDEX: "give an index the array has",
    ErrorNumber.NOT_ARRAY: "leave out the index: the parameter is a single value",
    ErrorNumber.WRONG_TYPE: "write the value in the parameter's own data type (the drive's "
    "profile or parameter file names it)",
    ErrorNumber.SET_NOT_ALLOWED: "the parameter may only be reset (written 0), not set",
    ErrorNumber.DESCRIPTION_NOT_CHANGEABLE: "the description element is fixed in the drive: "
    "nothing to change over USS",
}

NO_AUTHORITY_HINT = (
    "the drive gives the right to change parameters to another interface (its panel or "
    "another master): give it to this USS interface at the drive, then write again"
)
"""What to do on response 8 (C Table 4.2), where the family's file says nothing more."""


def error_hint(number: int, extra: Mapping[int, str] | None = None) -> str:
    """What to do after error ``number`` of a response 7, in an engineer's words: ``extra``
    (a family's own hints, from its parameter file) first, then the family-neutral ones of
    C Table 4.3's numbers 0..7; "" where nothing useful is known."""
    if extra is not None and number in extra:
        return extra[number]
    try:
        return _ERROR_HINT[ErrorNumber(number)]
    except ValueError:
        return ""


class TextIndex(enum.IntFlag):
    """IND bits 8 and 9 of a text request (ID 15, C Tables 4.5 and 4.6)."""

    READ = 0
    WRITE = 0x0100
    """Bit 8: write the text element (0: read it)."""
    VALUE_TEXTS = 0x0200
    """Bit 9: the second text field of an array parameter, one text per parameter value
    (subindex = value + 1); 0: the text field of the parameter's indices or values."""


def make_index(subindex: int = 0, *, text: TextIndex | int = 0, device: int = 0) -> int:
    """Build IND: ``subindex`` 0..255 in the low byte (255 = whole array or description),
    ``text`` bits 8/9 (`TextIndex`), ``device`` bits 10..15 as a number 0..63 (C 4.2.2)."""
    if not 0 <= subindex <= 0xFF:
        raise ConfigError(f"IND subindex must be 0..255, got {subindex}")
    if int(text) & ~0x0300:
        raise ConfigError(f"IND text bits must be bits 8 and 9 (0300h), got {int(text):04X}h")
    if not 0 <= device <= 0x3F:
        raise ConfigError(f"IND device bits (10..15) take 0..63, got {device}")
    return subindex | int(text) | (device << 10)


def _check_range(value: int, low: int, high: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(f"{what} must be an integer {low}..{high}, got {value!r}")
    return value


def pwe_word(value: int) -> tuple[int]:
    """A 16-bit value as PWE words; negative values (down to -32768) as two's complement."""
    return (_check_range(value, -0x8000, 0xFFFF, "word value") & 0xFFFF,)


def pwe_dword(value: int) -> tuple[int, int]:
    """A 32-bit value as PWE1 = high word, PWE2 = low word (C 4.2.3, C 6)."""
    v = _check_range(value, -0x8000_0000, 0xFFFF_FFFF, "double word value") & 0xFFFF_FFFF
    return (v >> 16, v & 0xFFFF)


def pwe_float(value: float) -> tuple[int, int]:
    """A 32-bit IEEE 754 floating point value, high word first (C 6)."""
    try:
        high, low = struct.unpack(">HH", struct.pack(">f", value))
    except (OverflowError, struct.error) as exc:
        raise ConfigError(f"{value!r} is not a 32-bit floating point value: {exc}") from None
    return (high, low)


def pwe_words(values: Iterable[int]) -> tuple[int, ...]:
    """An array of 16-bit values (for IND 255 or variable-length jobs)."""
    return tuple(pwe_word(v)[0] for v in values)


def pwe_dwords(values: Iterable[int]) -> tuple[int, ...]:
    """An array of 32-bit values, each high word first."""
    return tuple(w for v in values for w in pwe_dword(v))


def bytes_to_words(data: bytes) -> tuple[int, ...]:
    """A byte string in storage order as words, the first byte high (C 6); an odd length is
    padded with one 0 byte."""
    if len(data) % 2:
        data += b"\x00"
    return tuple(struct.unpack(f">{len(data) // 2}H", data))


def words_to_bytes(words: Sequence[int]) -> bytes:
    """Words back to the byte string, high byte first."""
    for w in words:
        _check_range(w, 0, 0xFFFF, "PWE word")
    return struct.pack(f">{len(words)}H", *words)


def pwe_text(text: str, length: int | None = None) -> tuple[int, ...]:
    """Text as PWE words, the first displayed character first (C 6, reading 7), padded with
    blanks to ``length`` characters (default: to an even number). Characters must be Latin-1."""
    try:
        data = text.encode("latin-1")
    except UnicodeEncodeError as exc:
        raise ConfigError(f"text {text!r} has a character outside Latin-1: {exc.reason}") from None
    if length is not None:
        if len(data) > length:
            raise ConfigError(f"text {text!r} is longer than {length} characters")
        data = data.ljust(length, b" ")
    if len(data) % 2:
        data += b" "
    return bytes_to_words(data)


def words_to_text(words: Sequence[int], *, strip: bool = True) -> str:
    """PWE words back to text; trailing blanks and NULs removed unless ``strip`` is false."""
    text = words_to_bytes(words).decode("latin-1")
    return text.rstrip(" \x00") if strip else text


@dataclass(frozen=True, slots=True)
class Pkw:
    """One PKW area: ``id`` (request or response ID, 0..15), ``pnu`` (0..2047), ``index`` (the
    whole IND word), ``spm_toggle`` (PKE bit 11) and ``values`` (the PWE words as they travel).
    """

    id: int
    pnu: int = 0
    index: int = 0
    spm_toggle: bool = False
    values: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        # Every PKW area of every telegram passes here: the usual case (plain integers in
        # range, a tuple of words) is recognised first; anything else is checked one by one.
        id_, pnu, index, values = self.id, self.pnu, self.index, self.values
        if not (
            type(id_) is type(pnu) is type(index) is int
            and 0 <= id_ <= 15
            and 0 <= pnu <= MAX_PNU
            and 0 <= index <= 0xFFFF
        ):
            _check_range(id_, 0, 15, "request/response ID")
            object.__setattr__(self, "id", int(id_))  # a RequestId/ResponseId is kept as int
            _check_range(pnu, 0, MAX_PNU, "PNU")
            _check_range(index, 0, 0xFFFF, "IND")
        if not isinstance(values, tuple):
            values = tuple(values)
            object.__setattr__(self, "values", values)
        for word in values:
            if type(word) is not int or not 0 <= word <= 0xFFFF:
                _check_range(word, 0, 0xFFFF, "PWE word")

    # -- words ----------------------------------------------------------------------------

    @property
    def pke(self) -> int:
        """The PKE word: ID in bits 15..12, toggle in bit 11, PNU in bits 10..0."""
        return (self.id << 12) | (_TOGGLE if self.spm_toggle else 0) | self.pnu

    def words(self) -> tuple[int, ...]:
        """PKE, IND and the PWE words."""
        return (self.pke, self.index, *self.values)

    @classmethod
    def from_words(cls, words: Sequence[int]) -> Pkw:
        """Split PKE, IND, PWE... back into a `Pkw` (at least PKE and IND)."""
        if len(words) < 2:
            raise TelegramError(f"a PKW area needs at least PKE and IND, got {len(words)} words")
        pke = words[0]
        return cls(pke >> 12, pke & MAX_PNU, words[1], bool(pke & _TOGGLE), tuple(words[2:]))

    # -- reading --------------------------------------------------------------------------

    @property
    def request_id(self) -> RequestId:
        """``id`` read as a request ID."""
        return RequestId(self.id)

    @property
    def response_id(self) -> ResponseId:
        """``id`` read as a response ID."""
        return ResponseId(self.id)

    @property
    def subindex(self) -> int:
        """IND low byte (255 = whole array or description)."""
        return self.index & 0xFF

    @property
    def text_bits(self) -> TextIndex:
        """IND bits 8 and 9."""
        return TextIndex(self.index & 0x0300)

    @property
    def device_bits(self) -> int:
        """IND bits 10..15 as a number 0..63 (device-specific, C Table 4.7)."""
        return self.index >> 10

    def word(self, *, signed: bool = False) -> int:
        """The 16-bit value: PWE1 with one PWE word, PWE2 with two (a 4-word PKW area carries a
        word in PWE2, C 4.2.3)."""
        if not self.values or len(self.values) > 2:
            raise TelegramError(f"a word value needs 1 or 2 PWE words, got {len(self.values)}")
        value = self.values[-1]
        return value - 0x10000 if signed and value & 0x8000 else value

    def dword(self, *, signed: bool = False) -> int:
        """The 32-bit value in PWE1 (high word) and PWE2 (low word)."""
        if len(self.values) != 2:
            raise TelegramError(f"a double word needs 2 PWE words, got {len(self.values)}")
        value = (self.values[0] << 16) | self.values[1]
        return value - 0x1_0000_0000 if signed and value & 0x8000_0000 else value

    def float32(self) -> float:
        """PWE1/PWE2 read as a 32-bit IEEE 754 floating point value."""
        value: float = struct.unpack(">f", struct.pack(">I", self.dword()))[0]
        return value

    def text(self) -> str:
        """The PWE words read as text (trailing blanks removed)."""
        return words_to_text(self.values)

    @property
    def error_number(self) -> int | None:
        """The error number of a response 7 (refused), else None.

        It is a word value, placed as words are (C 4.2.3): PWE2 of a 4-word PKW area, PWE1
        otherwise. More than two PWE words only occur with the variable layout, where a word
        travels in PWE1, so the number is read from there (a slave may pad its answer).
        """
        if self.id != ResponseId.REFUSED or not self.values:
            return None
        return self.word() if len(self.values) <= 2 else self.values[0]

    # -- matching -------------------------------------------------------------------------

    def is_answer_to(self, request: Pkw) -> bool:
        """True when this response answers ``request`` and is not a leftover of an older job
        (C 4.2.1.1): the response ID is one `expected_responses` allows, the PNU is the same,
        and for indexed jobs (array, description, text) so is the IND low byte (for texts also
        bits 8 and 9). Device bits 10..15 are not compared; a spontaneous message never
        answers a request.
        """
        req = RequestId(request.id)
        if self.id not in expected_responses(req):
            return False
        if req is RequestId.NO_JOB:
            return True
        if self.pnu != request.pnu:
            return False
        if req.is_indexed:
            mask = 0x03FF if req is RequestId.TEXT else 0x00FF
            return (self.index & mask) == (request.index & mask)
        return True


_pkw = builder(Pkw)


def unpacked_pkw(words: tuple[int, ...]) -> Pkw:
    """`Pkw.from_words` of PKE, IND and PWE words unpacked from a telegram: 16-bit words
    make every field valid, so the checks of `Pkw` are skipped (it is made for every answer
    with a PKW area, `pyuss.protocol.frozen.builder`)."""
    pke = words[0]
    return _pkw(pke >> 12, pke & MAX_PNU, words[1], bool(pke & _TOGGLE), words[2:])
