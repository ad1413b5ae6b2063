"""Codec of the BASS service protocol (Baumueller manual 1.1, 1.2; reading 12). Pure: no I/O, no
clock.

A BASS line is ASCII::

    '#'  address  word  ident  data  checksum  CR LF
         2 hex    4 hex 4 hex  0..n  2 hex

- ``address``: the drive's DIP address 0..255 (Baumueller manual 1.1).
- ``word``: in a request the command (`BassCommand`: 003C reads, 003E writes one element of
  operating data on first transmission; bit 1 = write), in an answer the status (`BassStatus`:
  bit 2 = error in the service channel, Baumueller manual 1.2).
- ``ident``: the parameter ID number.
- ``data``: hex digits, high nibble first. A read request has none; an answer carries the
  element, or with status bit 2 the error number of table 1.3. Texts start with two length
  words (4 hex digits each, both the number of characters).
- ``checksum``: the sum of the ASCII codes from the first address digit to the last data digit;
  carries above 8 bits are added back in until the sum fits a byte (234h -> 36h).

Readings this module takes where the Baumueller manual is silent (also in ``docs/bass.md``):

- Element values travel as 4 hex digits (a word) or 8 (a double word); negative values as two's
  complement of that width. Error numbers travel as 4 hex digits.
- Text characters travel as two hex digits each (Latin-1 code), so a text line stays within the
  hex alphabet and the reader can check it like any other line.
- Lower-case hex digits are accepted on input (the checksum covers the characters as sent);
  output is always upper case.
- Commands other than 003C/003E are device data (the figure listing them was lost): pass them
  as plain numbers.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from pyuss.bass.errors import BassRefusal, BassTelegramError, FaultKind

BOF = b"#"
EOF = b"\r\n"
HEX_DIGITS = frozenset(b"0123456789ABCDEFabcdef")
ADDRESS_DIGITS = 2
WORD_DIGITS = 4
IDENT_DIGITS = 4
CHECKSUM_DIGITS = 2
HEADER_DIGITS = ADDRESS_DIGITS + WORD_DIGITS + IDENT_DIGITS
MIN_BODY = HEADER_DIGITS + CHECKSUM_DIGITS
MAX_LINE = 1024
"""Default longest line the reader accepts, '#' and CR LF included (the Baumueller manual gives no
limit)."""
SHOWN = 64
"""Bytes of a malformed line an error message shows (an overlong one is cut there)."""
BAUD = 9600
"""Baumueller manual 1: 8 data bits, no parity, 1 stop bit, 9600 baud, full duplex."""


class BassCommand(enum.IntEnum):
    """Commands the Baumueller manual names (Baumueller manual 1.1 examples; reading 12). Others:
    plain numbers."""

    READ_ELEMENT = 0x003C
    """Read operating data, one element, first transmission."""
    WRITE_ELEMENT = 0x003E
    """Write operating data, one element, first transmission."""


COMMAND_WRITE_BIT = 0x0002
"""Bit 1 of the command distinguishes write (1) from read (0) (reading 12)."""


class BassStatus(enum.IntFlag):
    """The status word of an answer (Baumueller manual 1.2). Only bit 2 is documented."""

    OK = 0
    SERVICE_CHANNEL_ERROR = 0x0004


def checksum(body: bytes) -> int:
    """Sum of the character codes with end-around carry (Baumueller manual 1.1: 234h -> 36h)."""
    total = sum(body)
    while total > 0xFF:
        total = (total & 0xFF) + (total >> 8)
    return total


def _check_range(name: str, value: int, digits: int) -> None:
    if not isinstance(value, int) or not 0 <= value < (1 << 4 * digits):
        raise BassTelegramError(
            f"{name} {value!r} does not fit {digits} hex digits (0..{(1 << 4 * digits) - 1})"
        )


def _check_data(data: str) -> None:
    if any(c not in "0123456789ABCDEF" for c in data):
        raise BassTelegramError(f"data {data!r} is not upper-case hex digits", FaultKind.BAD_HEX)


def value_digits(value: int) -> int:
    """Digits a value needs on the wire: 4 (a word) or 8 (a double word); negatives signed."""
    if -0x8000 <= value <= 0xFFFF:
        return 4
    if -0x8000_0000 <= value <= 0xFFFF_FFFF:
        return 8
    raise BassTelegramError(f"value {value} does not fit a double word")


def encode_value(value: int, digits: int | None = None) -> str:
    """A value as hex digits, high nibble first; negative values as two's complement."""
    width = value_digits(value) if digits is None else digits
    if width < 1:
        raise BassTelegramError(f"a value needs at least one hex digit, not {width}")
    limit = 1 << 4 * width
    if not -(limit // 2) <= value < limit:
        raise BassTelegramError(f"value {value} does not fit {width} hex digits")
    return f"{value % limit:0{width}X}"


def decode_value(data: str, *, signed: bool = False) -> int:
    """Hex digits as a number; ``signed`` reads them as two's complement of their width."""
    if not data:
        raise BassTelegramError("no data digits where a value was expected", FaultKind.TOO_SHORT)
    try:
        value = int(data, 16)
    except ValueError:
        raise BassTelegramError(f"data {data!r} is not hex", FaultKind.BAD_HEX) from None
    if signed and value >= 1 << (4 * len(data) - 1):
        value -= 1 << 4 * len(data)
    return value


def encode_text(text: str) -> str:
    """A text as data: two length words, then each character as two hex digits (Latin-1)."""
    try:
        raw = text.encode("latin-1")
    except UnicodeEncodeError as exc:
        raise BassTelegramError(f"text {text!r} has a character outside Latin-1") from exc
    if len(raw) > 0xFFFF:
        raise BassTelegramError(f"text of {len(raw)} characters is longer than FFFFh")
    return f"{len(raw):04X}{len(raw):04X}" + raw.hex().upper()


def decode_text(data: str) -> str:
    """Data holding a text: both length words must agree with each other and with the text."""
    if len(data) < 8:
        raise BassTelegramError(
            f"text data {data!r} lacks its two length words", FaultKind.BAD_TEXT
        )
    first, second = decode_value(data[:4]), decode_value(data[4:8])
    body = data[8:]
    if first != second or len(body) != 2 * first:
        raise BassTelegramError(
            f"text length words {first} and {second} do not match {len(body) // 2} characters",
            FaultKind.BAD_TEXT,
        )
    return bytes.fromhex(body).decode("latin-1")


@dataclass(frozen=True, slots=True)
class BassLine:
    """A well-framed line with a good checksum, as received; requests and answers alike.

    ``word`` is the command in a request and the status in an answer; ``raw`` is the line as it
    came, '#' and CR LF included.
    """

    address: int
    word: int
    ident: int
    data: str
    raw: bytes = field(repr=False)

    def as_request(self) -> BassRequest:
        return BassRequest(self.address, self.word, self.ident, self.data)

    def as_answer(self) -> BassAnswer:
        return BassAnswer(self.address, self.word, self.ident, self.data)


@dataclass(frozen=True, slots=True)
class BassFault:
    """A malformed stretch of input: what was wrong, the bytes as they came, and a detail."""

    kind: FaultKind
    raw: bytes
    detail: str = ""

    def to_error(self) -> BassTelegramError:
        """The fault as an error; its message shows at most `SHOWN` bytes of the line."""
        extra = f": {self.detail}" if self.detail else ""
        shown = repr(self.raw[:SHOWN]) + ("" if len(self.raw) <= SHOWN else "...")
        size = "" if len(self.raw) <= SHOWN else f" ({len(self.raw)} bytes)"
        return BassTelegramError(f"{self.kind.value}{extra} in {shown}{size}", self.kind)


def _frame(address: int, word: int, ident: int, data: str) -> bytes:
    _check_range("address", address, ADDRESS_DIGITS)
    _check_range("command/status word", word, WORD_DIGITS)
    _check_range("parameter ID", ident, IDENT_DIGITS)
    _check_data(data)
    body = f"{address:02X}{word:04X}{ident:04X}{data}".encode("ascii")
    return BOF + body + f"{checksum(body):02X}".encode("ascii") + EOF


@dataclass(frozen=True, slots=True)
class BassRequest:
    """PC to drive (Baumueller manual 1.1). ``data`` is upper-case hex digits (empty for a read)."""

    address: int
    command: int
    ident: int
    data: str = ""

    @classmethod
    def read(cls, address: int, ident: int) -> BassRequest:
        """Read one element of operating data (command 003C)."""
        return cls(address, BassCommand.READ_ELEMENT, ident)

    @classmethod
    def write(cls, address: int, ident: int, value: int, digits: int | None = None) -> BassRequest:
        """Write one element of operating data (command 003E); 4 or 8 digits (see module)."""
        return cls(address, BassCommand.WRITE_ELEMENT, ident, encode_value(value, digits))

    @property
    def is_write(self) -> bool:
        return bool(self.command & COMMAND_WRITE_BIT)

    def encode(self) -> bytes:
        """The whole line, '#' to CR LF."""
        return _frame(self.address, self.command, self.ident, self.data)


@dataclass(frozen=True, slots=True)
class BassAnswer:
    """Drive to PC, after the echo (Baumueller manual 1.2). ``status`` bit 2 set: ``data`` = error
    number."""

    address: int
    status: int
    ident: int
    data: str = ""

    @classmethod
    def value(cls, address: int, ident: int, value: int, digits: int | None = None) -> BassAnswer:
        return cls(address, BassStatus.OK, ident, encode_value(value, digits))

    @classmethod
    def refusal(cls, address: int, ident: int, number: int) -> BassAnswer:
        """An answer with status bit 2 and the error number of table 1.3 in 4 hex digits."""
        return cls(address, BassStatus.SERVICE_CHANNEL_ERROR, ident, encode_value(number, 4))

    @property
    def is_error(self) -> bool:
        return bool(self.status & BassStatus.SERVICE_CHANNEL_ERROR)

    @property
    def error_number(self) -> int | None:
        """The error number (table 1.3) when status bit 2 is set and data is present."""
        if not self.is_error or not self.data:
            return None
        return decode_value(self.data)

    def raise_for_status(self) -> None:
        """Raise `BassRefusal` when status bit 2 is set (or `BassTelegramError` if no number)."""
        if not self.is_error:
            return
        number = self.error_number
        if number is None:
            raise BassTelegramError(
                f"answer from drive {self.address} for ID {self.ident} has status bit 2 but no "
                "error number"
            )
        raise BassRefusal(number, ident=self.ident, address=self.address)

    def to_int(self, *, signed: bool = False) -> int:
        """The element as a number (raises for an error answer)."""
        self.raise_for_status()
        return decode_value(self.data, signed=signed)

    def to_text(self) -> str:
        """The element as a text with its two length words (raises for an error answer)."""
        self.raise_for_status()
        return decode_text(self.data)

    def encode(self) -> bytes:
        return _frame(self.address, self.status, self.ident, self.data)


def parse_line(raw: bytes) -> BassLine | BassFault:
    """Check one complete line ('#' ... CR LF) and split it; a fault names what was wrong."""
    if not raw.startswith(BOF):
        return BassFault(FaultKind.MISSING_BOF, raw)
    if not raw.endswith(EOF):
        return BassFault(FaultKind.MISSING_EOF, raw)
    body = raw[1:-2]
    for pos, char in enumerate(body):
        if char not in HEX_DIGITS:
            return BassFault(FaultKind.BAD_HEX, raw, f"character {char:#04x} at {pos + 1}")
    if len(body) < MIN_BODY:
        return BassFault(
            FaultKind.TOO_SHORT, raw, f"{len(body)} digits, at least {MIN_BODY} needed"
        )
    content, sent = body[:-CHECKSUM_DIGITS], int(body[-CHECKSUM_DIGITS:], 16)
    expected = checksum(content)
    if sent != expected:
        return BassFault(FaultKind.BAD_CHECKSUM, raw, f"sent {sent:02X}, computed {expected:02X}")
    text = content.decode("ascii")
    return BassLine(
        address=int(text[0:2], 16),
        word=int(text[2:6], 16),
        ident=int(text[6:10], 16),
        data=text[10:].upper(),
        raw=raw,
    )


def decode_line(raw: bytes) -> BassLine:
    """Like `parse_line` but raises `BassTelegramError` (with ``.fault``) for a malformed line."""
    item = parse_line(raw)
    if isinstance(item, BassFault):
        raise item.to_error()
    return item


def decode_request(raw: bytes) -> BassRequest:
    return decode_line(raw).as_request()


def decode_answer(raw: bytes) -> BassAnswer:
    return decode_line(raw).as_answer()


class BassLineReader:
    """Streaming splitter: feed bytes as they come, get `BassLine`s and `BassFault`s.

    Never raises on input. Every byte fed comes out again in exactly one item's ``raw`` (in
    order), or stays pending until its line ends, so a station can pass on what it does not
    understand unchanged. Rules:

    - A line starts at '#' and ends at LF; it must end in CR LF (else ``MISSING_EOF``). A '#'
      inside a line ends the unfinished line as ``MISSING_EOF`` and starts a new one.
    - Bytes outside a line up to the next LF or '#' are one ``MISSING_BOF`` fault.
    - A line longer than ``max_line`` bytes is reported as ``OVERLONG`` as soon as it passes
      the limit, and so is each further ``max_line + 1`` bytes of it; the rest, up to its end,
      is a last ``OVERLONG``. Bytes outside a line are cut the same way (``MISSING_BOF``), so
      the reader never holds more than ``max_line`` bytes.
    """

    def __init__(self, max_line: int = MAX_LINE) -> None:
        if max_line < MIN_BODY + 3:
            raise ValueError(f"max_line {max_line} is shorter than the shortest line")
        self.max_line = max_line
        self._buf = bytearray()
        self._in_line = False
        self._overlong = False

    @property
    def pending(self) -> bytes:
        """Bytes held back because their line has not ended yet."""
        return bytes(self._buf)

    def reset(self) -> None:
        """Forget anything pending."""
        self._buf.clear()
        self._in_line = False
        self._overlong = False

    def _close(self, out: list[BassLine | BassFault]) -> None:
        """End the current stretch (line, garbage or overlong tail) and report it."""
        raw = bytes(self._buf)
        self._buf.clear()
        if raw:
            if self._overlong:
                out.append(BassFault(FaultKind.OVERLONG, raw, "rest of an overlong line"))
            elif not self._in_line:
                out.append(BassFault(FaultKind.MISSING_BOF, raw))
            elif raw.endswith(b"\n"):
                out.append(parse_line(raw))
            else:
                out.append(BassFault(FaultKind.MISSING_EOF, raw))
        self._in_line = False
        self._overlong = False

    def feed(self, data: bytes) -> list[BassLine | BassFault]:
        """Take more bytes; return every line and fault they complete, in order."""
        out: list[BassLine | BassFault] = []
        for byte in data:
            if byte == 0x23:  # '#'
                self._close(out)
                self._in_line = True
                self._buf.append(byte)
                continue
            self._buf.append(byte)
            if byte == 0x0A:  # LF
                self._close(out)
            elif len(self._buf) > self.max_line:
                raw = bytes(self._buf)
                self._buf.clear()
                if self._in_line:
                    out.append(BassFault(FaultKind.OVERLONG, raw, f"over {self.max_line} bytes"))
                    self._overlong = True
                else:
                    out.append(BassFault(FaultKind.MISSING_BOF, raw))
        return out

    def flush(self) -> list[BassLine | BassFault]:
        """Report whatever is pending as unfinished (call when the line has gone quiet)."""
        out: list[BassLine | BassFault] = []
        self._close(out)
        return out
