"""Multiplexer modules and the data caches of the bus coupler (KS VARIO interface description 3.3 -
3.5).

The coupler keeps a read cache and a write cache of up to 1080 16-bit data each, filled per
the selection made in BlueControl (3.2, 3.3). A multiplexer module moves a window of them:

* variable multiplexer A.2 (3.4): 4 bytes each way, IndexOUT = (Index_Read, Index_Write) from
  the master, IndexIN = the same two words mirrored by the coupler; the data travel in the
  I/O modules after it (input words carry read data, output words write data);
* fixed multiplexers A.3..A.6 (3.5): Index_Read, Index_Write and 1, 4, 8 or 14 data words in
  one consistent module each way. The interface description's table lists "Read Value" under
  IndexOUT and
  "Write value" under IndexIN; the data flow makes the master's words the values to write and
  the coupler's words the values read, which is how they are used here.

Indices are 1..1080; index 0 means "no valid data" (3.4.1): a master that cannot send data and
index consistently sets Index_Write to 0 first, and the coupler answers 0 for an index whose
block would not lie inside the 1080 data ("keine Bestätigung ... eine 0 zurückgegeben").
While an index stays the same the coupler keeps taking (writes) and refreshing (reads) the
block every cycle.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from pyuss.errors import ConfigError, ProtocolError

#: Entries of each cache (3.2: "maximal 1080 Schreib- und 1080 Lesedaten").
CACHE_SIZE = 1080
#: Values carried by the fixed multiplexer modules A.3..A.6 (3.5).
FIXED_SIZES = (1, 4, 8, 14)


def block_in_range(index: int, count: int, size: int = CACHE_SIZE) -> bool:
    """True when the block index..index+count-1 lies inside the cache (1..size)."""
    return index >= 1 and index + max(count, 1) - 1 <= size


class CacheAccess(Protocol):
    """The coupler's caches as a multiplexer sees them (words 0..65535)."""

    def read_cache(self, index: int, count: int) -> list[int]:
        """``count`` words of the read cache from ``index`` (1-based) on."""
        ...

    def write_cache(self, index: int, words: Sequence[int]) -> None:
        """Store words into the write cache from ``index`` (1-based) on."""
        ...


class Cache:
    """A plain cache of words, 1-based, for library users and tests."""

    def __init__(self, size: int = CACHE_SIZE) -> None:
        self.words = [0] * size

    def read(self, index: int, count: int) -> list[int]:
        return self.words[index - 1 : index - 1 + count]

    def write(self, index: int, words: Sequence[int]) -> None:
        self.words[index - 1 : index - 1 + len(words)] = [w & 0xFFFF for w in words]


class CachePair:
    """A read cache and a write cache satisfying `CacheAccess`."""

    def __init__(self, size: int = CACHE_SIZE) -> None:
        self.read = Cache(size)
        self.write = Cache(size)

    def read_cache(self, index: int, count: int) -> list[int]:
        return self.read.read(index, count)

    def write_cache(self, index: int, words: Sequence[int]) -> None:
        self.write.write(index, words)


def words_to_bytes(words: Sequence[int]) -> bytes:
    """16-bit words, high byte first (the PROFIBUS order of word modules)."""
    return b"".join((w & 0xFFFF).to_bytes(2, "big") for w in words)


def bytes_to_words(data: bytes) -> list[int]:
    if len(data) % 2:
        raise ProtocolError(f"odd number of bytes ({len(data)}) for a word area")
    return [int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2)]


@dataclass(frozen=True, slots=True)
class MuxOut:
    """What the master sends: IndexOUT and the data words to write."""

    index_read: int
    index_write: int
    data: tuple[int, ...] = ()


@dataclass(frozen=True, slots=True)
class MuxIn:
    """What the coupler answers: IndexIN and the data words read."""

    index_read: int
    index_write: int
    data: tuple[int, ...] = ()


class MuxServer:
    """The coupler's side of one multiplexer (variable or fixed): ``read_count`` words of read
    data and ``write_count`` words of write data travel with each exchange.

    ``consistent=False`` plays a coupler that cannot put data and Index_Read on the bus
    consistently (3.4.2): when the master asks for a new block, the first answer carries the
    new data with Index_Read 0 ("Daten momentan nicht übernehmen"), the next ones the index.
    """

    def __init__(
        self, access: CacheAccess, read_count: int, write_count: int, *, consistent: bool = True
    ) -> None:
        self.access = access
        self.read_count = read_count
        self.write_count = write_count
        self.consistent = consistent
        self._read_shown = 0

    def exchange(self, out: MuxOut) -> MuxIn:
        if len(out.data) != self.write_count:
            raise ProtocolError(f"expected {self.write_count} write words, got {len(out.data)}")
        in_write = 0
        if (
            out.index_write
            and self.write_count
            and block_in_range(out.index_write, self.write_count)
        ):
            self.access.write_cache(out.index_write, out.data)
            in_write = out.index_write
        in_read = 0
        data = [0] * self.read_count
        if out.index_read and block_in_range(out.index_read, self.read_count):
            data = self.access.read_cache(out.index_read, self.read_count)
            if self.consistent or self._read_shown == out.index_read:
                in_read = out.index_read
            self._read_shown = out.index_read
        else:
            self._read_shown = 0
        return MuxIn(in_read, in_write, tuple(data))


def encode_indices(index_read: int, index_write: int) -> bytes:
    for name, value in (("index_read", index_read), ("index_write", index_write)):
        if not 0 <= value <= 0xFFFF:
            raise ConfigError(f"{name} {value} is not a 16-bit word")
    return words_to_bytes((index_read, index_write))


def encode_fixed(index_read: int, index_write: int, data: Sequence[int]) -> bytes:
    """The bytes of a fixed multiplexer module: two index words and the data words."""
    return encode_indices(index_read, index_write) + words_to_bytes(data)


def decode_fixed(data: bytes) -> tuple[int, int, tuple[int, ...]]:
    words = bytes_to_words(data)
    if len(words) < 2:
        raise ProtocolError("a multiplexer module has at least two index words")
    return words[0], words[1], tuple(words[2:])


# --------------------------------------------------------------------------- master side


class _Phase(enum.Enum):
    RUN = "run"
    DONE = "done"


def _block_starts(first: int, last: int, per: int) -> list[int]:
    """Start indices covering first..last with blocks of ``per``; the last block is moved back
    so that it stays full (it overlaps the one before instead of running past ``last``)."""
    if per <= 0 or last < first:
        return []
    if last - first + 1 < per:
        raise ConfigError(
            f"range {first}..{last} is shorter than the {per} data each message carries"
        )
    starts = list(range(first, last + 1, per))
    if starts[-1] + per - 1 > last:
        starts[-1] = last - per + 1
    return starts


class MuxClient:
    """The master's side of a multiplexer (like FB108, KS VARIO interface description 8.2), pure
    and one-shot:
    read the read-cache range ``read_range`` and write ``write_words`` into the write cache from
    ``write_first`` on, ``read_per``/``write_per`` words per message.

    Each cycle: `request()` gives the MuxOut to send, `feed()` takes the MuxIn received.
    With ``consistent=False`` the client first sends Index_Write 0 with the new data and only
    then the index (3.4.1), for masters that cannot send both at once.
    """

    def __init__(
        self,
        *,
        read_per: int,
        write_per: int,
        read_range: tuple[int, int] | None = None,
        write_first: int = 1,
        write_words: Sequence[int] = (),
        consistent: bool = True,
    ) -> None:
        self.read_per = read_per
        self.write_per = write_per
        self.consistent = consistent
        first, last = read_range if read_range else (1, 0)
        if read_range and not (block_in_range(first, last - first + 1) and last >= first):
            raise ConfigError(f"read range {first}..{last} is outside 1..{CACHE_SIZE}")
        self._read_first = first
        self._read_starts = _block_starts(first, last, read_per) if read_range else []
        self._read_values: dict[int, int] = {}
        words = [w & 0xFFFF for w in write_words]
        wlast = write_first + len(words) - 1
        if words and not block_in_range(write_first, len(words)):
            raise ConfigError(f"write range {write_first}..{wlast} is outside 1..{CACHE_SIZE}")
        self._write_first = write_first
        self._write_words = words
        self._write_starts = _block_starts(write_first, wlast, write_per) if words else []
        self._ri = 0
        self._wi = 0
        self._w_armed = consistent
        self.cycles = 0

    @property
    def done(self) -> bool:
        return self._ri >= len(self._read_starts) and self._wi >= len(self._write_starts)

    @property
    def read_words(self) -> list[int]:
        """The words read so far, in range order (complete when `done`)."""
        return [self._read_values[i] for i in sorted(self._read_values)]

    def _write_block(self) -> tuple[int, tuple[int, ...]]:
        start = self._write_starts[self._wi]
        off = start - self._write_first
        return start, tuple(self._write_words[off : off + self.write_per])

    def request(self) -> MuxOut:
        ir = self._read_starts[self._ri] if self._ri < len(self._read_starts) else 0
        if self._wi < len(self._write_starts):
            iw, data = self._write_block()
            if not self._w_armed:
                iw = 0
        else:
            iw, data = 0, tuple([0] * self.write_per) if self.write_per else ()
            if self._write_starts and self.write_per:
                # keep the last block in the image; index 0 stops the coupler taking it
                data = self._write_block_last()
        if len(data) < self.write_per:
            data = data + (0,) * (self.write_per - len(data))
        return MuxOut(ir, iw, data)

    def _write_block_last(self) -> tuple[int, ...]:
        start = self._write_starts[-1]
        off = start - self._write_first
        return tuple(self._write_words[off : off + self.write_per])

    def feed(self, answer: MuxIn) -> None:
        self.cycles += 1
        if self._ri < len(self._read_starts):
            start = self._read_starts[self._ri]
            if answer.index_read == start:
                for k, word in enumerate(answer.data[: self.read_per]):
                    self._read_values[start + k] = word
                self._ri += 1
        if self._wi < len(self._write_starts):
            start = self._write_starts[self._wi]
            if not self._w_armed:
                self._w_armed = True  # the 0 index went out with the data; now the index
            elif answer.index_write == start:
                self._wi += 1
                self._w_armed = self.consistent
