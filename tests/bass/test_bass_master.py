"""BassMaster against scripted drives: echo first, then answer (Baumueller manual 1.2), errors of
1.3.

The scripted drive sits behind an in-process port: the byte pipe is not what is tested here, the
master's handling of what comes back is.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.bass.codec import (
    BassAnswer,
    BassLine,
    BassLineReader,
    BassRequest,
    BassStatus,
    encode_text,
)
from pyuss.bass.errors import (
    BassEchoError,
    BassError,
    BassErrorNumber,
    BassProtocolError,
    BassRefusal,
    BassTelegramError,
    BassTimeout,
    FaultKind,
)
from pyuss.bass.inprocess import InProcessPort
from pyuss.bass.master import BassMaster, SyncBassMaster
from pyuss.errors import ConfigError, DriveRefusal, TransportError

Script = Callable[[BassRequest, bytes, int], list[bytes]]
"""(request, the request line as received, attempt number from 1) -> chunks sent back."""


class ScriptedDrive:
    """Answers each request line with whatever the script returns, counting requests."""

    def __init__(self, script: Script) -> None:
        self.script = script
        self.requests: list[bytes] = []
        self._reader = BassLineReader()
        self.port = InProcessPort(on_write=self._receive)

    def _receive(self, data: bytes) -> None:
        for item in self._reader.feed(data):
            assert isinstance(item, BassLine)
            self.requests.append(item.raw)
            for chunk in self.script(item.as_request(), item.raw, len(self.requests)):
                self.port.deliver(chunk)


def good(value: int = 0x1D3E) -> Script:
    def script(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        return [raw, BassAnswer.value(request.address, request.ident, value).encode()]

    return script


async def test_read_consumes_echo_then_answer() -> None:
    drive = ScriptedDrive(good(0x1D3E))
    async with drive.port:
        master = BassMaster(drive.port, timeout=0.5)
        assert await master.read(0, 51) == 7486
        exchange = await master.exchange(BassRequest.read(0, 51))
    assert drive.requests[0] == b"#00003C0033FD\r\n"
    assert exchange.echo == b"#00003C0033FD\r\n"
    assert exchange.answer.to_int() == 0x1D3E
    assert exchange.attempts == 1


async def test_answer_in_single_bytes_and_both_lines_in_one_chunk() -> None:
    def trickle(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        both = raw + BassAnswer.value(request.address, request.ident, 0xFFFE).encode()
        if attempt == 1:
            return [bytes([b]) for b in both]
        return [both]

    drive = ScriptedDrive(trickle)
    async with drive.port:
        master = BassMaster(drive.port, timeout=0.5)
        assert await master.read(4, 9, signed=True) == -2
        assert await master.read(4, 9) == 0xFFFE


async def test_write_sends_the_document_line() -> None:
    drive = ScriptedDrive(good(7500))
    async with drive.port:
        await BassMaster(drive.port).write(0, 2, 7500)
    assert drive.requests == [b"#00003E00021D4CE8\r\n"]


async def test_wrong_echo_is_a_typed_error() -> None:
    def bad_echo(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        other = BassRequest.read(request.address, request.ident + 1).encode()
        return [other, BassAnswer.value(request.address, request.ident, 1).encode()]

    drive = ScriptedDrive(bad_echo)
    async with drive.port:
        with pytest.raises(BassEchoError) as info:
            await BassMaster(drive.port, timeout=0.3, retries=0).read(1, 170)
    assert info.value.sent == BassRequest.read(1, 170).encode()
    assert info.value.received == BassRequest.read(1, 171).encode()
    assert isinstance(info.value, BassProtocolError)


async def test_missing_echo_is_a_wrong_echo_not_an_answer() -> None:
    """The answer alone is not accepted: without its echo it is out of order."""

    def no_echo(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        return [BassAnswer.value(request.address, request.ident + 1, 1).encode()]

    drive = ScriptedDrive(no_echo)
    async with drive.port:
        with pytest.raises(BassEchoError):
            await BassMaster(drive.port, timeout=0.3, retries=0).read(1, 170)


async def test_retry_after_wrong_echo_succeeds() -> None:
    def flaky(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        if attempt == 1:
            return [raw.replace(b"#01", b"#02")]
        return good(42)(request, raw, attempt)

    drive = ScriptedDrive(flaky)
    async with drive.port:
        master = BassMaster(drive.port, timeout=0.3, retries=1)
        exchange = await master.exchange(BassRequest.read(1, 170))
    assert exchange.attempts == 2
    assert exchange.answer.to_int() == 42
    assert len(drive.requests) == 2


@pytest.mark.parametrize("number", list(range(10)))
async def test_every_error_number_is_a_typed_refusal_and_not_retried(number: int) -> None:
    def refuse(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        return [raw, BassAnswer.refusal(request.address, request.ident, number).encode()]

    drive = ScriptedDrive(refuse)
    async with drive.port:
        with pytest.raises(BassRefusal) as info:
            await BassMaster(drive.port, timeout=0.3, retries=3).write(5, 2, 1)
    assert info.value.number == number
    assert info.value.code is BassErrorNumber(number)
    assert info.value.meaning == BassErrorNumber(number).meaning
    assert (info.value.address, info.value.ident) == (5, 2)
    assert isinstance(info.value, DriveRefusal)
    assert len(drive.requests) == 1


async def test_status_without_bit_2_is_success() -> None:
    def status(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        answer = BassAnswer(request.address, 0x00F3, request.ident, "0007")
        return [raw, answer.encode()]

    drive = ScriptedDrive(status)
    async with drive.port:
        assert await BassMaster(drive.port).read(1, 1) == 7


async def test_error_bit_without_number_is_malformed() -> None:
    def bare(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        answer = BassAnswer(request.address, BassStatus.SERVICE_CHANNEL_ERROR, request.ident)
        return [raw, answer.encode()]

    drive = ScriptedDrive(bare)
    async with drive.port:
        with pytest.raises(BassTelegramError):
            await BassMaster(drive.port, retries=0).read(1, 1)


async def test_no_echo_times_out() -> None:
    drive = ScriptedDrive(lambda request, raw, attempt: [])
    async with drive.port:
        with pytest.raises(BassTimeout, match="no echo"):
            await BassMaster(drive.port, timeout=0.05, retries=2).read(1, 1)
    assert len(drive.requests) == 3


async def test_echo_without_answer_times_out() -> None:
    drive = ScriptedDrive(lambda request, raw, attempt: [raw])
    async with drive.port:
        with pytest.raises(BassTimeout, match="no answer"):
            await BassMaster(drive.port, timeout=0.05, retries=0).read(1, 1)


async def test_damaged_answer_is_retried_then_reported() -> None:
    def damaged(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        answer = bytearray(BassAnswer.value(request.address, request.ident, 5).encode())
        answer[-3] ^= 0x01  # last checksum digit
        return [raw, bytes(answer)]

    drive = ScriptedDrive(damaged)
    async with drive.port:
        with pytest.raises(BassTelegramError) as info:
            await BassMaster(drive.port, timeout=0.3, retries=1).read(1, 1)
    assert info.value.fault is FaultKind.BAD_CHECKSUM
    assert len(drive.requests) == 2


async def test_unfinished_answer_is_reported_as_missing_eof() -> None:
    def cut(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        return [raw, BassAnswer.value(request.address, request.ident, 5).encode()[:-2]]

    drive = ScriptedDrive(cut)
    async with drive.port:
        with pytest.raises(BassTelegramError) as info:
            await BassMaster(drive.port, timeout=0.05, retries=0).read(1, 1)
    assert info.value.fault is FaultKind.MISSING_EOF


async def test_answer_from_another_drive_is_a_protocol_error() -> None:
    def other(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        return [raw, BassAnswer.value(request.address + 1, request.ident, 5).encode()]

    drive = ScriptedDrive(other)
    async with drive.port:
        with pytest.raises(BassProtocolError, match="answer from drive 2"):
            await BassMaster(drive.port, retries=0).read(1, 1)


async def test_late_answer_before_echo_and_repeated_echo_are_skipped() -> None:
    def late(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        stale = BassAnswer.value(request.address, request.ident, 1).encode()
        fresh = BassAnswer.value(request.address, request.ident, 2).encode()
        return [stale, raw, raw, fresh]

    drive = ScriptedDrive(late)
    async with drive.port:
        assert await BassMaster(drive.port, retries=0).read(1, 170) == 2


async def test_closed_port_raises_transport_error() -> None:
    drive = ScriptedDrive(good())
    with pytest.raises(TransportError):
        await BassMaster(drive.port).read(1, 1)


def test_bad_settings_are_config_errors() -> None:
    port = InProcessPort()
    with pytest.raises(ConfigError):
        BassMaster(port, timeout=0)
    with pytest.raises(ConfigError):
        BassMaster(port, retries=-1)


def test_sync_facade() -> None:
    drive = ScriptedDrive(good(0x0102))
    with SyncBassMaster(drive.port, timeout=0.5) as master:
        assert master.read(3, 51) == 0x0102
        master.write(3, 2, -1)
    assert drive.requests[1] == BassRequest.write(3, 2, -1).encode()
    assert BassRequest.write(3, 2, -1).data == "FFFF"


def text(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
    """ID 90 is a good text, any other one whose two length words disagree."""
    data = encode_text("Drive 1") if request.ident == 90 else "00020003414243"
    return [raw, BassAnswer(request.address, 0, request.ident, data).encode()]


async def test_read_text_with_a_device_command() -> None:
    """Texts come with two length words (Baumueller manual 1.1, 1.2); the command is the device's
    own."""
    drive = ScriptedDrive(text)
    async with drive.port:
        master = BassMaster(drive.port, timeout=0.5, retries=0)
        assert await master.read_text(1, 90, 0x0040) == "Drive 1"
        with pytest.raises(BassTelegramError) as info:
            await master.read_text(1, 91, 0x0040)
    assert info.value.fault is FaultKind.BAD_TEXT
    assert drive.requests[0] == BassRequest(1, 0x0040, 90).encode()


def test_sync_read_text() -> None:
    with SyncBassMaster(ScriptedDrive(text).port, timeout=0.5) as master:
        assert master.read_text(1, 90, 0x0040) == "Drive 1"


replies = st.lists(
    st.binary(max_size=40)
    | st.sampled_from(
        [
            BassAnswer.value(1, 170, 0x11).encode(),
            BassAnswer.value(2, 170, 0x21).encode(),
            BassAnswer.refusal(1, 170, 4).encode(),
            b"#01000000AA\r\n",
            b"#0100",
            b"\r\n",
        ]
    ),
    max_size=6,
)


@given(st.booleans(), replies)
@settings(max_examples=60, deadline=None)
def test_whatever_comes_back_the_master_answers_or_raises_a_bass_error(
    echo: bool, reply: list[bytes]
) -> None:
    """Malformed lines, garbage, stray answers, nothing at all: a value, or a `BassError`."""

    def script(request: BassRequest, raw: bytes, attempt: int) -> list[bytes]:
        return [raw, *reply] if echo else reply

    async def run() -> None:
        drive = ScriptedDrive(script)
        async with drive.port:
            with contextlib.suppress(BassError):
                assert isinstance(
                    await BassMaster(drive.port, timeout=0.01, retries=1).read(1, 170), int
                )

    asyncio.run(run())
