"""The bus's timing: 11-bit characters back to back, gaps as the senders made them (A 6.1,
A 6.2, B 3.2)."""

from __future__ import annotations

import asyncio
import time

import pytest

from pyuss.bus import Recorder, VirtualBus
from pyuss.transport import SerialTransport
from support.paths import load_vectors
from transport.helpers import joined, read_bytes

#: Ideal times are computed, not measured: they agree with n x 11 / baud to float rounding.
EXACT = 1e-9


def _telegram(name: str) -> bytes:
    for item in load_vectors("uss")["telegrams"]:
        if item["name"] == name:
            return bytes.fromhex(item["hex"])
    raise KeyError(name)


@pytest.mark.parametrize("baud", [9600, 19200, 38400, 187500])
async def test_telegram_of_n_bytes_takes_n_times_11_over_baud(baud: int) -> None:
    telegram = _telegram("read_word_request")
    n = len(telegram)
    bus = VirtualBus(baud)
    recorder = Recorder().attach(bus)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        before = time.monotonic()
        await master.write(telegram)
        after = time.monotonic()
        chunks = await read_bytes(slave, n)
    await bus.close()
    assert joined(chunks) == telegram
    records = recorder.records
    assert [r.byte for r in records] == list(telegram)
    # On the wire: first start bit to last stop bit is n x 11 / baud.
    assert records[-1].t - records[0].start == pytest.approx(n * 11 / baud, abs=EXACT)
    # The first character started when the master wrote.
    assert before - bus.epoch <= records[0].start <= after - bus.epoch
    # What the slave read says the same: chunk stamps are ideal end times, back to back.
    first, last = chunks[0], chunks[-1]
    start = first.timestamp - len(first.data) * 11 / baud
    assert last.timestamp - start == pytest.approx(n * 11 / baud, abs=EXACT)
    ends = [c.timestamp for c in chunks]
    sizes = [len(c.data) for c in chunks]
    for i in range(1, len(chunks)):
        assert ends[i] - ends[i - 1] == pytest.approx(sizes[i] * 11 / baud, abs=EXACT)


@pytest.mark.pty
@pytest.mark.parametrize("baud", [1200, 9600])
async def test_a_program_on_a_pty_gets_a_telegram_no_sooner_than_the_wire_would(
    baud: int,
) -> None:
    # Ptys carry no timing of their own: the bus writes each character to the reader's pty
    # when it has left the line, so the last byte of n cannot arrive before n x 11 / baud.
    telegram = _telegram("read_word_request")
    bus = VirtualBus(baud)
    writer_path, reader_path = await bus.serve_pty(2)
    async with (
        SerialTransport(writer_path, baud=baud) as writer,
        SerialTransport(reader_path, baud=baud) as reader,
    ):
        before = time.monotonic()
        await writer.write(telegram)
        chunks = await read_bytes(reader, len(telegram))
    await bus.close()
    assert joined(chunks) == telegram
    assert chunks[-1].timestamp - before >= len(telegram) * 11 / baud


async def test_recorded_gaps_are_the_gaps_the_sender_made() -> None:
    # 300 baud: two characters last 73 ms, so the second write lands while the first is
    # still on the line even when this process is descheduled for a while on a loaded machine.
    baud = 300
    tc = 11 / baud
    bus = VirtualBus(baud)
    recorder = Recorder().attach(bus)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        # Two writes while the first is still on the line: queued back to back, no gap.
        await master.write(b"\x02\x0c")
        await master.write(b"\x05\x10")
        await bus.drain()
        # A pause of about 0.1 s, then the rest.
        await asyncio.sleep(0.1)
        before = time.monotonic()
        await master.write(b"\x34\x00")
        after = time.monotonic()
        chunks = await read_bytes(slave, 6)
    await bus.close()
    recording = recorder.recording()
    gaps = recording.gaps("master")
    assert gaps[:3] == pytest.approx([0.0, 0.0, 0.0], abs=EXACT)
    # The pause: from the end of the 4th character to the moment of the third write.
    end4 = recorder.records[3].t + bus.epoch
    assert before - end4 <= gaps[3] <= after - end4
    assert gaps[4] == pytest.approx(0.0, abs=EXACT)
    # The slave's chunks show the same pause: a new chunk begins after it.
    starts = [c.timestamp - len(c.data) * tc for c in chunks]
    pause = [s - e for s, e in zip(starts[1:], [c.timestamp for c in chunks], strict=False)]
    assert max(pause) == pytest.approx(gaps[3], abs=EXACT)
    assert joined(chunks) == b"\x02\x0c\x05\x10\x34\x00"


async def test_answer_follows_request_with_the_delay_the_slave_took() -> None:
    baud = 9600
    request = _telegram("read_word_request")
    response = _telegram("read_word_response")
    bus = VirtualBus(baud)
    recorder = Recorder().attach(bus)
    async with bus.attach("master") as master, bus.attach("slave") as slave:
        await master.write(request)
        got = await read_bytes(slave, len(request))
        await asyncio.sleep(0.005)  # the slave's processing time
        before = time.monotonic()
        await slave.write(response)
        after = time.monotonic()
        answer = await read_bytes(master, len(response))
    await bus.close()
    assert joined(got) == request and joined(answer) == response
    # Response delay (A 5.2.1.1): from the end of the request's BCC to the answer's STX.
    request_end = got[-1].timestamp
    answer_start = answer[0].timestamp - len(answer[0].data) * 11 / baud
    assert before - request_end <= answer_start - request_end <= after - request_end
    assert answer_start - request_end >= 0.005
    assert [r.sender for r in recorder.records] == ["master"] * 14 + ["slave"] * 14
