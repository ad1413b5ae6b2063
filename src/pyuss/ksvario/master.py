"""The master side of a KS VARIO over a cyclic I/O image, for library users.

A `CyclicLink` moves one output image to the coupler and brings one input image back per bus
cycle: `LocalLink` does it in-process against a `Coupler`; the DP master of
`pyuss.ksvario.dp.master` does it over PROFIBUS-DP. `KsVarioMaster` drives the parameter
channel (module A.1) and the multiplexers through such a link:

    master = KsVarioMaster(LocalLink(coupler), Configuration(["A.1", "A.4"]))
    [pb1] = await master.read(0x4496)              # 4.5.1: FixPoint1 -> 1000 = 100.0
    await master.write(0xFD09, [1.0, 2.0, 0.5])    # 4.5.4: three reals
    words = await master.read_cache(1, 1080)       # all read-cache data through A.4

The data format follows the address unless given: float addresses use REAL, the others
INTEGER. A job that does not finish within ``timeout`` raises `pyuss.errors.UssTimeout`; a
result other than 0 raises `ChannelResultError` carrying the result number.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Protocol

from pyuss.errors import ConfigError, UssTimeout
from pyuss.ksvario.address import Address, View
from pyuss.ksvario.channel import (
    ByteOrder,
    ChannelClient,
    ChannelStatus,
    DataFormat,
    Value,
    result_meaning,
)
from pyuss.ksvario.coupler import Coupler
from pyuss.ksvario.errors import ChannelResultError
from pyuss.ksvario.modules import Configuration, Slot
from pyuss.ksvario.mux import MuxClient, MuxIn, bytes_to_words, decode_fixed, encode_fixed
from pyuss.ksvario.mux import words_to_bytes as _w2b


class CyclicLink(Protocol):
    async def exchange(self, outputs: bytes) -> bytes:
        """Send one output image, return the input image of the same cycle."""
        ...


class LocalLink:
    """An in-process link straight to a simulated `Coupler`."""

    def __init__(self, coupler: Coupler, clock: Callable[[], float] = time.monotonic) -> None:
        self.coupler = coupler
        self.clock = clock

    async def exchange(self, outputs: bytes) -> bytes:
        return self.coupler.exchange(outputs, self.clock())


def default_format(address: Address) -> DataFormat:
    return DataFormat.REAL if address.view is View.FLOAT else DataFormat.INTEGER


class KsVarioMaster:
    """Parameter channel and multiplexer jobs over a `CyclicLink` (see module docstring)."""

    def __init__(
        self,
        link: CyclicLink,
        configuration: Configuration,
        *,
        byte_order: ByteOrder = ByteOrder.MOTOROLA,
        timeout: float = 5.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.link = link
        self.configuration = configuration
        self.timeout = timeout
        self.clock = clock
        self.outputs = bytearray(configuration.output_bytes)
        self.inputs = bytes(configuration.input_bytes)
        self.client = ChannelClient(byte_order=byte_order, timeout=timeout)
        self._a1 = next((s for s in configuration.slots if s.module.key == "A.1"), None)
        self.cycles = 0

    @property
    def status(self) -> ChannelStatus:
        """The display word (ANZW) of the last parameter channel job."""
        return self.client.status

    async def cycle(self) -> bytes:
        """Run one bus cycle with the current output image."""
        self.inputs = await self.link.exchange(bytes(self.outputs))
        self.cycles += 1
        return self.inputs

    def _slot_in(self, slot: Slot) -> bytes:
        return self.inputs[slot.in_offset : slot.in_offset + slot.module.inputs]

    def _set_out(self, slot: Slot, data: bytes) -> None:
        self.outputs[slot.out_offset : slot.out_offset + len(data)] = data

    # ------------------------------------------------------------------ parameter channel
    async def _run_job(self, what: str) -> None:
        slot = self._a1
        assert slot is not None
        while self.client.busy:
            self._set_out(slot, self.client.request())
            await self.cycle()
            self.client.feed(self._slot_in(slot), self.clock())
        self._set_out(slot, self.client.request())
        result = self.client.result
        if result is None:
            raise UssTimeout(f"parameter channel {what}: no answer within {self.timeout} s")
        if result != 0:
            raise ChannelResultError(result, result_meaning(result), what)

    def _channel_job(
        self, address: int | Address, fmt: DataFormat | None
    ) -> tuple[Address, DataFormat]:
        """The address and data format of a job of the parameter channel (the address's own
        format where ``fmt`` is None); `ConfigError` without the channel module A.1."""
        if self._a1 is None:
            raise ConfigError("the configuration has no parameter channel module A.1")
        addr = address if isinstance(address, Address) else Address.decode(address)
        return addr, default_format(addr) if fmt is None else fmt

    async def read(
        self, address: int | Address, count: int = 1, fmt: DataFormat | None = None
    ) -> list[Value]:
        """Read ``count`` values from ``address`` through the parameter channel."""
        addr, fmt = self._channel_job(address, fmt)
        self.client.start_read(fmt, addr, count, self.clock())
        await self._run_job(f"read {addr.encode():04X}h")
        return self.client.values

    async def write(
        self, address: int | Address, values: Sequence[Value], fmt: DataFormat | None = None
    ) -> None:
        """Write ``values`` from ``address`` on through the parameter channel."""
        addr, fmt = self._channel_job(address, fmt)
        self.client.start_write(fmt, addr, values, self.clock())
        await self._run_job(f"write {addr.encode():04X}h")

    # ------------------------------------------------------------------ multiplexers
    def _mux_layout(self) -> tuple[Slot, list[Slot]]:
        conf = self.configuration
        keys = [m.key for m in conf.modules]
        if "A.2" in keys:
            pos = keys.index("A.2")
            return conf.slots[pos], [s for s in conf.slots[pos + 1 :] if s.module.is_io]
        fixed = [s for s in conf.slots if s.module.is_fixed_mux]
        if not fixed:
            raise ConfigError("the configuration has no multiplexer module (A.2 .. A.6)")
        return fixed[0], []

    async def _run_mux(self, client: MuxClient, mux: Slot, io: list[Slot]) -> None:
        deadline = self.clock() + self.timeout
        while not client.done:
            out = client.request()
            if mux.module.key == "A.2":
                self._set_out(mux, _w2b((out.index_read, out.index_write)))
                pos = 0
                for s in io:
                    n = s.module.outputs // 2
                    if n:
                        self._set_out(s, _w2b(out.data[pos : pos + n]))
                        pos += n
            else:
                self._set_out(mux, encode_fixed(out.index_read, out.index_write, out.data))
            await self.cycle()
            if mux.module.key == "A.2":
                ir, iw = bytes_to_words(self._slot_in(mux))
                data: list[int] = []
                for s in io:
                    data += bytes_to_words(self._slot_in(s))
                client.feed(MuxIn(ir, iw, tuple(data)))
            else:
                ir, iw, words = decode_fixed(self._slot_in(mux))
                client.feed(MuxIn(ir, iw, words))
            if self.clock() > deadline:
                raise UssTimeout(f"multiplexer transfer unfinished after {self.timeout} s")
        if mux.module.key == "A.2":
            self._set_out(mux, _w2b((0, 0)))
        else:
            self._set_out(mux, encode_fixed(0, 0, [0] * mux.module.mux_size))

    def _mux_sizes(self, mux: Slot, io: list[Slot]) -> tuple[int, int]:
        if mux.module.key == "A.2":
            return sum(s.module.inputs for s in io) // 2, sum(s.module.outputs for s in io) // 2
        return mux.module.mux_size, mux.module.mux_size

    async def read_cache(self, first: int, last: int) -> list[int]:
        """Read-cache entries first..last (1-based) through the first multiplexer module."""
        mux, io = self._mux_layout()
        r, w = self._mux_sizes(mux, io)
        client = MuxClient(read_per=r, write_per=w, read_range=(first, last))
        await self._run_mux(client, mux, io)
        return client.read_words

    async def write_cache(self, first: int, words: Sequence[int]) -> None:
        """Write ``words`` into the write cache from index ``first`` on."""
        mux, io = self._mux_layout()
        r, w = self._mux_sizes(mux, io)
        client = MuxClient(read_per=r, write_per=w, write_first=first, write_words=words)
        await self._run_mux(client, mux, io)
