"""The PC side of BASS: read and write one element of operating data (Baumueller manual 1.1, 1.2).

An exchange, as the Baumueller manual describes it: the PC sends a request line; the drive first
sends the
whole request back ("le télégramme est renvoyé en écho", Baumueller manual 1.2), then its answer
line.
`BassMaster` sends the request, consumes the echo and checks it byte for byte, then checks the
answer's address and ID and its status (bit 2: `BassRefusal` with the number of table 1.3).

Choices where the Baumueller manual is silent (also in ``docs/bass.md``):

- Each attempt has ``timeout`` seconds for echo and answer together. Timeouts, malformed lines,
  a wrong echo and an answer that does not fit are retried ``retries`` more times; a refusal
  (status bit 2) is an answer and is never retried.
- Before the echo, a well-formed answer to the same address and ID is taken as the late answer
  of an earlier attempt and skipped; any other line there is a wrong echo (`BassEchoError`).
  After the echo, a second copy of the request line is skipped too (note that command 003C has
  bit 2 set: read as an answer it would look like an error).
- A write succeeds on an answer without bit 2; its data are not checked.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from types import TracebackType

from pyuss.bass.codec import (
    BassAnswer,
    BassFault,
    BassLine,
    BassLineReader,
    BassRequest,
)
from pyuss.bass.errors import (
    BassEchoError,
    BassError,
    BassProtocolError,
    BassRefusal,
    BassTimeout,
)
from pyuss.errors import ConfigError
from pyuss.log import log_frame
from pyuss.transport.base import Transport

DEFAULT_TIMEOUT = 1.0
DEFAULT_RETRIES = 2


@dataclass(frozen=True, slots=True)
class BassExchange:
    """One finished exchange: the request, its echo and the answer as they travelled."""

    request: BassRequest
    echo: bytes
    answer: BassAnswer
    answer_raw: bytes
    attempts: int


class BassMaster:
    """Async BASS master on any `Transport` (8N1, 9600 baud on a real port, Baumueller manual 1)."""

    def __init__(
        self,
        transport: Transport,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        retries: int = DEFAULT_RETRIES,
    ) -> None:
        if not timeout > 0:
            raise ConfigError(f"timeout must be positive, not {timeout!r}")
        if retries < 0:
            raise ConfigError(f"retries must be 0 or more, not {retries!r}")
        self.transport = transport
        self.timeout = timeout
        self.retries = retries
        self._reader = BassLineReader()
        self._lock: asyncio.Lock | None = None

    async def read(self, address: int, ident: int, *, signed: bool = False) -> int:
        """Read one element of operating data (command 003C)."""
        exchange = await self.exchange(BassRequest.read(address, ident))
        return exchange.answer.to_int(signed=signed)

    async def read_text(self, address: int, ident: int, command: int) -> str:
        """Send ``command`` (a device-specific number) and decode the answer as a text."""
        exchange = await self.exchange(BassRequest(address, command, ident))
        return exchange.answer.to_text()

    async def write(
        self, address: int, ident: int, value: int, *, digits: int | None = None
    ) -> None:
        """Write one element of operating data (command 003E); ``digits`` 4 or 8 (default: fit)."""
        await self.exchange(BassRequest.write(address, ident, value, digits))

    async def exchange(self, request: BassRequest) -> BassExchange:
        """Send ``request``, check echo and answer, retry; raise `BassRefusal` for status bit 2."""
        line = request.encode()
        if self._lock is None:
            self._lock = asyncio.Lock()
        async with self._lock:
            last: BassError | None = None
            for attempt in range(1, self.retries + 2):
                try:
                    echo, answer_line = await self._attempt(request, line)
                except BassRefusal:
                    raise
                except BassError as exc:
                    last = exc
                    continue
                answer = answer_line.as_answer()
                answer.raise_for_status()
                return BassExchange(request, echo, answer, answer_line.raw, attempt)
            assert last is not None
            raise last

    async def _attempt(self, request: BassRequest, line: bytes) -> tuple[bytes, BassLine]:
        transport = self.transport
        transport.flush_input()
        self._reader.reset()
        await transport.write(line)
        log_frame("tx", line, transport.clock(), "bass request")
        deadline = transport.clock() + self.timeout
        echo: bytes | None = None
        while True:
            remaining = deadline - transport.clock()
            if remaining <= 0:
                break
            chunk = await transport.read(remaining)
            if chunk is None:
                break
            for item in self._reader.feed(chunk.data):
                if isinstance(item, BassFault):
                    log_frame("rx", item.raw, chunk.timestamp, f"bass fault: {item.kind.value}")
                    raise item.to_error()
                if echo is None:
                    if item.raw == line:
                        echo = item.raw
                        log_frame("rx", item.raw, chunk.timestamp, "bass echo")
                        continue
                    if item.address == request.address and item.ident == request.ident:
                        log_frame("rx", item.raw, chunk.timestamp, "bass stale answer, skipped")
                        continue
                    raise BassEchoError(line, item.raw)
                if item.raw == line:
                    log_frame("rx", item.raw, chunk.timestamp, "bass repeated echo, skipped")
                    continue
                log_frame("rx", item.raw, chunk.timestamp, "bass answer")
                if item.address != request.address or item.ident != request.ident:
                    raise BassProtocolError(
                        f"answer from drive {item.address} for ID {item.ident} to a request to "
                        f"drive {request.address} for ID {request.ident}"
                    )
                return echo, item
        for item in self._reader.flush():
            if isinstance(item, BassFault):
                raise item.to_error()
        if echo is None:
            raise BassTimeout(
                f"no echo of the request to drive {request.address} (ID {request.ident}) within "
                f"{self.timeout:g} s: is the line or the ring closed?"
            )
        raise BassTimeout(
            f"echo but no answer from drive {request.address} (ID {request.ident}) within "
            f"{self.timeout:g} s: is there a drive with that DIP address?"
        )


class SyncBassMaster:
    """Blocking facade over `BassMaster`: one private event loop, opened by `open()`."""

    def __init__(
        self,
        transport: Transport,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        retries: int = DEFAULT_RETRIES,
    ) -> None:
        self.master = BassMaster(transport, timeout=timeout, retries=retries)
        self._runner: asyncio.Runner | None = None

    def open(self) -> None:
        if self._runner is None:
            self._runner = asyncio.Runner()
            self._runner.run(self.master.transport.open())

    def close(self) -> None:
        if self._runner is not None:
            try:
                self._runner.run(self.master.transport.close())
            finally:
                self._runner.close()
                self._runner = None

    def _run_runner(self) -> asyncio.Runner:
        if self._runner is None:
            raise BassError("SyncBassMaster is not open: call open() or use it in a with block")
        return self._runner

    def read(self, address: int, ident: int, *, signed: bool = False) -> int:
        return self._run_runner().run(self.master.read(address, ident, signed=signed))

    def write(self, address: int, ident: int, value: int, *, digits: int | None = None) -> None:
        self._run_runner().run(self.master.write(address, ident, value, digits=digits))

    def read_text(self, address: int, ident: int, command: int) -> str:
        return self._run_runner().run(self.master.read_text(address, ident, command))

    def exchange(self, request: BassRequest) -> BassExchange:
        return self._run_runner().run(self.master.exchange(request))

    def __enter__(self) -> SyncBassMaster:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


__all__ = [
    "DEFAULT_RETRIES",
    "DEFAULT_TIMEOUT",
    "BassExchange",
    "BassMaster",
    "SyncBassMaster",
]
