"""A small scripted slave for master tests: a station on a virtual bus that answers by simple,
configurable rules, including misbehaviour a real drive simulator does not show on request
(answers that lag behind the job by several telegrams, answering a broadcast, answering with
the wrong address or late).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field

from pyuss.bus import VirtualBus
from pyuss.bus.core import Station
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId
from pyuss.protocol.receiver import Received, Receiver
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.protocol.timing import start_pause

_WRITE_WORD = {RequestId.WRITE_WORD, RequestId.WRITE_WORD_EEPROM}
_WRITE_DWORD = {RequestId.WRITE_DWORD, RequestId.WRITE_DWORD_EEPROM}
_WRITE_ARRAY_WORD = {RequestId.WRITE_ARRAY_WORD, RequestId.WRITE_ARRAY_WORD_EEPROM}
_WRITE_ARRAY_DWORD = {RequestId.WRITE_ARRAY_DWORD, RequestId.WRITE_ARRAY_DWORD_EEPROM}


@dataclass
class SlaveLog:
    requests: list[Telegram] = field(default_factory=list)
    answered: int = 0


class ScriptedSlave:
    """Answers telegrams to ``address`` on ``bus`` with parameters from ``params``.

    ``lag``: a new job is answered only after it was received this many times; until then
    the answer to the previous job is repeated (with the current value, C 4.2.1.1).
    ``delay``: seconds from the end of a request to the answer (at least the start pause).
    ``silent``: answer nothing. ``answer_broadcast``: answer broadcasts (which A 3 forbids).
    ``address_out``: the address put into answers (a wrong one to test A 5.2).
    """

    def __init__(
        self, bus: VirtualBus, address: int, layout: Layout, *, delay: float = 0.0
    ) -> None:
        self.bus = bus
        self.address = address
        self.layout = layout
        self.delay = delay
        self.lag = 0
        self.silent = False
        self.answer_broadcast = False
        self.address_out = address
        self.params: dict[int, int] = {52: 0x4000, 18: 0, 53: 7}
        self.dwords: dict[int, int] = {60: 0x0001_0000}
        self.arrays: dict[int, list[int]] = {4: [1, 2, 3]}
        self.read_only: set[int] = {53}
        self.no_authority = False
        self.status = 0x0231
        self.actual = 0
        self.log = SlaveLog()
        self.broadcasts: list[Telegram] = []
        self.spontaneous: list[Pkw] = []
        self._toggle = False
        self._pending: Pkw | None = None
        self._last_job: Pkw | None = None
        self._answer: Pkw = Pkw(ResponseId.NO_RESPONSE)
        self._seen = 0
        self._station: Station | None = None
        self._task: asyncio.Task[None] | None = None
        self.on_request: Callable[[Telegram], None] | None = None

    async def start(self) -> ScriptedSlave:
        self._station = self.bus.attach(f"slave{self.address}")
        await self._station.open()
        self._task = asyncio.create_task(self._serve())
        return self

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        if self._station is not None:
            await self._station.close()

    def push_spontaneous(self, pnu: int, value: int) -> None:
        """Report a change of ``pnu`` made elsewhere (C 4.2.1.2)."""
        self.spontaneous.append(Pkw(ResponseId.SPONTANEOUS_WORD, pnu, values=(value,)))

    async def _serve(self) -> None:
        assert self._station is not None
        receiver = Receiver(self.bus.baud, fixed_lengths=self._fixed())
        while True:
            chunk = await self._station.read()
            if chunk is None:
                continue
            for event in receiver.feed(chunk.data, chunk.timestamp, chunk.errors):
                if isinstance(event, Received):
                    answer = self._handle(event.telegram)
                    if answer is not None:
                        wait = max(self.delay, start_pause(self.bus.baud) * 1.5)
                        await asyncio.sleep(max(0.0, event.end + wait - self._station.clock()))
                        await self._station.write(answer.encode())
                        self.log.answered += 1

    def _fixed(self) -> dict[int, int]:
        return {} if self.layout.lge is None else {self.address: self.layout.lge}

    def _handle(self, telegram: Telegram) -> Telegram | None:
        if telegram.mode is AddressMode.BROADCAST:
            self.broadcasts.append(telegram)
            if self.answer_broadcast:
                return Telegram(self.address, AddressMode.NORMAL, telegram.data)
            return None
        if telegram.address != self.address:
            return None
        self.log.requests.append(telegram)
        if self.on_request is not None:
            self.on_request(telegram)
        if self.silent:
            return None
        if telegram.mode is AddressMode.MIRROR:
            return telegram
        net = self.layout.unpack(telegram.data)
        pkw = self._parameter(net.pkw) if net.pkw is not None else None
        pzd = [self.status, self.actual, *([0] * max(0, self.layout.pzd - 2))][: self.layout.pzd]
        return Telegram(self.address_out, AddressMode.NORMAL, self.layout.pack(pkw, pzd))

    def _parameter(self, request: Pkw) -> Pkw:
        # A spontaneous message is repeated until the master's bit 11 equals ours (C 4.2.1.2).
        if self._pending is not None and request.spm_toggle == self._toggle:
            self._pending = None
        if self._pending is None and self.spontaneous:
            self._pending = self.spontaneous.pop(0)
            self._toggle = not self._toggle
        if self._pending is not None:
            head = self._pending
            return Pkw(head.id, head.pnu, head.index, self._toggle, head.values)
        job = Pkw(request.id, request.pnu, request.index, False, request.values)
        if job != self._last_job:
            self._seen += 1
            if self._seen <= self.lag:
                return self._refresh(self._answer)
            self._last_job = job
            self._seen = 0
            self._answer = self._execute(job)
        return self._refresh(self._answer)

    def _refresh(self, answer: Pkw) -> Pkw:
        """Repeated answers carry the current value (C 4.2.1.1)."""
        value = answer.values
        if answer.id == ResponseId.VALUE_WORD and answer.pnu in self.params:
            value = self._word(self.params[answer.pnu])
        return Pkw(answer.id, answer.pnu, answer.index, self._toggle, value)

    def _word(self, value: int) -> tuple[int, ...]:
        return (0, value) if self.layout.pkw == 4 else (value,)

    def _execute(self, job: Pkw) -> Pkw:
        rid = RequestId(job.id)
        pnu = job.pnu
        refused = ResponseId.REFUSED
        if rid is RequestId.NO_JOB:
            return Pkw(ResponseId.NO_RESPONSE)
        if rid.is_change and self.no_authority:
            return Pkw(ResponseId.NO_AUTHORITY, pnu, job.index)
        if rid is RequestId.READ_VALUE:
            if pnu in self.params:
                return Pkw(ResponseId.VALUE_WORD, pnu, values=self._word(self.params[pnu]))
            if pnu in self.dwords:
                v = self.dwords[pnu]
                return Pkw(ResponseId.VALUE_DWORD, pnu, values=(v >> 16, v & 0xFFFF))
            return Pkw(refused, pnu, values=self._word(0))
        if rid in _WRITE_WORD:
            if pnu in self.read_only:
                return Pkw(refused, pnu, values=self._word(1))
            self.params[pnu] = job.values[-1]
            return Pkw(ResponseId.VALUE_WORD, pnu, values=self._word(self.params[pnu]))
        if rid in _WRITE_DWORD:
            self.dwords[pnu] = (job.values[0] << 16) | job.values[1]
            return Pkw(ResponseId.VALUE_DWORD, pnu, values=job.values)
        if rid is RequestId.READ_ARRAY_COUNT and pnu in self.arrays:
            return Pkw(ResponseId.ARRAY_COUNT, pnu, values=self._word(len(self.arrays[pnu])))
        if rid is RequestId.READ_ARRAY and pnu in self.arrays:
            sub = job.subindex
            if sub == 255 and self.layout.variable:
                return Pkw(ResponseId.ARRAY_WORD, pnu, job.index, values=tuple(self.arrays[pnu]))
            if 1 <= sub <= len(self.arrays[pnu]):
                return Pkw(
                    ResponseId.ARRAY_WORD,
                    pnu,
                    job.index,
                    values=self._word(self.arrays[pnu][sub - 1]),
                )
            return Pkw(refused, pnu, job.index, values=self._word(3))
        if rid in _WRITE_ARRAY_WORD and pnu in self.arrays:
            sub = job.subindex
            self.arrays[pnu][sub - 1] = job.values[-1]
            return Pkw(ResponseId.ARRAY_WORD, pnu, job.index, values=self._word(job.values[-1]))
        if rid in _WRITE_ARRAY_DWORD:
            return Pkw(ResponseId.ARRAY_DWORD, pnu, job.index, values=job.values)
        return Pkw(refused, pnu, job.index, values=self._word(101))
