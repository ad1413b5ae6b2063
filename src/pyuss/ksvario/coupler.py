"""A simulated KS VARIO bus coupler with up to 30 controller channels, pure (time is passed in).

Data model. Every area (0 device, 1 visualisation, 2..31 channels 1..30) holds 512 data, each a
number in engineering units (a float). The three address views of KS VARIO interface description
9.2 see the same
datum: the integer view as a rounded signed 16-bit integer, FixPoint1 as tenths (value x 10,
rounded), the float view as an IEEE 754 single. Areas of channels beyond ``channels`` do not
exist: the parameter channel answers them with result 2 (bad address), as it does for a block
that runs past datum 511. Character formats read a datum as a character code 0..255; compact
characters take four consecutive data.

Data can carry limits (`set_limits`); a write outside them, of a non-finite float or to a
read-only datum ends with result 3 (invalid value).

Caches (3.2, 3.3). `CacheSelection` is what BlueControl would load: up to 120 free entries
(channel, datum) and up to 32 data per channel for every channel; read cache index 1.. holds
the free entries, then the per-channel data of channel 1, 2, .... Entries are FixPoint1
(cyclic process data travel as FixPoint1, interface description 3). The write cache is laid out the
same way
from the write selection.

Cyclic exchange (`exchange`): the output image (master -> coupler) of a `Configuration` goes
in, the input image comes out. I/O modules that are not behind the variable multiplexer map to
the caches from index 1 on, in order (3.1); the variable multiplexer serves the I/O modules
behind it; fixed multiplexers carry their own data. Values from the write cache reach the
controllers only when they change (interface description 3: "Vorgabewerte werden vom Gerät nur bei
einer
Wertänderung übernommen"), and, if module A.7 is configured, only while its byte is 1 or on
its 0 -> 1 edge (3.1).

Forcing and fail-safe (2.3, 2.4): `force` marks a datum as a forced analogue input, digital
input or output, written from the bus. A physical input is read-only to the bus (declare it with
``set_limits(..., writable=False)``) until it is forced: then the bus writes it, through the
parameter channel as through the write cache. `bus_failure` applies the user parameters'
fail-safe: forced analogue inputs go to FAIL (diagnosis byte 15 bit 0); with fail-safe "zero"
forced digital inputs and forced outputs also go to 0.

``consistent_mux=False`` makes the multiplexers answer a new read index with Index_Read 0 for
one cycle first, as a coupler that cannot send data and index consistently does (3.4.2).
"""

from __future__ import annotations

import enum
import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass

from pyuss.errors import ConfigError
from pyuss.ksvario.address import CHANNELS, DATA_PER_AREA, Address, View, channel_area
from pyuss.ksvario.channel import CHANNEL_BYTES, ChannelServer, DataFormat, Result, Value
from pyuss.ksvario.diag import DeviceDiagnosis, InputFlags
from pyuss.ksvario.modules import Configuration, Slot
from pyuss.ksvario.mux import (
    CACHE_SIZE,
    MuxOut,
    MuxServer,
    bytes_to_words,
    decode_fixed,
    encode_fixed,
    words_to_bytes,
)
from pyuss.ksvario.userprm import FailSafe, UserParameters

MAX_FREE = 120
MAX_PER_CHANNEL = 32

#: Data named in the interface description's examples (4.5), by datum number in a channel area.
KNOWN_DATA: dict[int, str] = {
    0x69: "SPLo",
    0x6A: "SPHi",
    0x6B: "SP2",
    0x6C: "rSP",
    0x84: "L",
    0x85: "H",
    0x86: "HYS",
    0x96: "Pb1",
    0x9A: "td1",
}


class ForceKind(enum.Enum):
    ANALOG_INPUT = "analog input"
    DIGITAL_INPUT = "digital input"
    OUTPUT = "output"


@dataclass(frozen=True, slots=True)
class CacheSelection:
    """A BlueControl selection: free entries (channel, datum) and per-channel data."""

    free_read: tuple[tuple[int, int], ...] = ()
    free_write: tuple[tuple[int, int], ...] = ()
    per_channel_read: tuple[int, ...] = ()
    per_channel_write: tuple[int, ...] = ()
    channels: int = CHANNELS

    def __post_init__(self) -> None:
        for name in ("free_read", "free_write"):
            if len(getattr(self, name)) > MAX_FREE:
                raise ConfigError(f"{name}: at most {MAX_FREE} free entries")
        for name in ("per_channel_read", "per_channel_write"):
            if len(getattr(self, name)) > MAX_PER_CHANNEL:
                raise ConfigError(f"{name}: at most {MAX_PER_CHANNEL} data per channel")

    def _entries(self, free: Sequence[tuple[int, int]], per: Sequence[int]) -> list[Address]:
        out = [Address.channel(c, d, View.FIXPOINT1) for c, d in free]
        for ch in range(1, self.channels + 1):
            out += [Address.channel(ch, d, View.FIXPOINT1) for d in per]
        if len(out) > CACHE_SIZE:
            raise ConfigError(f"the selection needs {len(out)} cache entries, {CACHE_SIZE} exist")
        return out

    def read_entries(self) -> list[Address]:
        return self._entries(self.free_read, self.per_channel_read)

    def write_entries(self) -> list[Address]:
        return self._entries(self.free_write, self.per_channel_write)

    @classmethod
    def example(cls) -> CacheSelection:
        """The selection shown in KS VARIO interface description 3.2: X.Eff, Ypid, Pb1, Pb2, ti1,
        td1 of channels 1
        and 2 as free entries (datum numbers besides Pb1 and td1 are the simulator's)."""
        per = (0x01, 0x02, 0x96, 0x97, 0x98, 0x9A)
        free = tuple((ch, d) for ch in (1, 2) for d in per)
        return cls(free_read=free, free_write=free)


def _to_int16(value: float) -> int:
    n = round(value) if math.isfinite(value) else 0
    return max(-0x8000, min(0x7FFF, n))


@dataclass(slots=True)
class _Limits:
    low: float = -math.inf
    high: float = math.inf
    writable: bool = True


class Coupler:
    """The simulated bus coupler (see module docstring)."""

    def __init__(
        self,
        *,
        channels: int = CHANNELS,
        selection: CacheSelection | None = None,
        user: UserParameters | None = None,
        max_block: int = 128,
        consistent_mux: bool = True,
    ) -> None:
        if not 1 <= channels <= CHANNELS:
            raise ConfigError(f"a coupler serves 1..{CHANNELS} channels, not {channels}")
        self.channels = channels
        self.consistent_mux = consistent_mux
        self.data: dict[int, list[float]] = {
            area: [0.0] * DATA_PER_AREA for area in range(channels + 2)
        }
        self._limits: dict[tuple[int, int], _Limits] = {}
        self.forced: dict[tuple[int, int], ForceKind] = {}
        self.failed: set[tuple[int, int]] = set()
        self.device = DeviceDiagnosis()
        self.user = user or UserParameters()
        self.channel = ChannelServer(self, byte_order=self.user.byte_order, max_block=max_block)
        self.selection = selection or CacheSelection(channels=channels)
        self.read_entries = self.selection.read_entries()
        self.write_entries = self.selection.write_entries()
        self.write_words = [0] * CACHE_SIZE
        self._applied: dict[int, int] = {}
        self.configuration: Configuration | None = None
        self._mux: list[MuxServer] = []
        self._activate_last = 0
        self._var_io: list[Slot] = []
        self._var_mux: MuxServer | None = None
        self._direct_io: list[Slot] = []
        self._fixed: dict[int, MuxServer] = {}
        for ch in range(1, channels + 1):
            area = channel_area(ch)
            for datum, default in ((0x96, 100.0), (0x9A, 30.0), (0x69, 0.0), (0x6A, 900.0)):
                self.data[area][datum] = default

    # ------------------------------------------------------------------ data access
    def _exists(self, area: int, datum: int) -> bool:
        return area in self.data and 0 <= datum < DATA_PER_AREA

    def get(self, address: Address) -> float:
        """The value of a datum in engineering units."""
        if not self._exists(address.area, address.datum):
            raise ConfigError(f"no datum at {address}")
        return self.data[address.area][address.datum]

    def set(self, address: Address, value: float) -> None:
        """Set a datum (simulation side: no limits, no read-only check)."""
        if not self._exists(address.area, address.datum):
            raise ConfigError(f"no datum at {address}")
        self.data[address.area][address.datum] = float(value)

    def set_limits(
        self,
        address: Address,
        low: float = -math.inf,
        high: float = math.inf,
        writable: bool = True,
    ) -> None:
        self._limits[(address.area, address.datum)] = _Limits(low, high, writable)

    def view_word(self, address: Address) -> int:
        """A datum as a 16-bit word in the integer or FixPoint1 view of ``address``."""
        v = self.get(address)
        n = _to_int16(v * 10 if address.view is View.FIXPOINT1 else v)
        return n & 0xFFFF

    def read_values(self, address: Address, fmt: DataFormat, count: int) -> list[Value] | Result:
        step = 4 if fmt is DataFormat.COMPACT_CHAR else 1
        last = address.datum + count * step - 1
        if not (self._exists(address.area, address.datum) and last < DATA_PER_AREA):
            return Result.BAD_ADDRESS
        row = self.data[address.area]
        out: list[Value] = []
        for k in range(count):
            d = address.datum + k * step
            v = row[d]
            if fmt.is_real:
                out.append(struct.unpack(">f", struct.pack(">f", v))[0])
            elif fmt is DataFormat.INTEGER:
                out.append(_to_int16(v * 10 if address.view is View.FIXPOINT1 else v))
            elif fmt is DataFormat.CHAR:
                out.append(_to_int16(v) & 0xFF)
            else:
                out.append(bytes(_to_int16(row[d + i]) & 0xFF for i in range(4)))
        return out

    def write_values(self, address: Address, fmt: DataFormat, values: Sequence[Value]) -> Result:
        step = 4 if fmt is DataFormat.COMPACT_CHAR else 1
        last = address.datum + len(values) * step - 1
        if not (self._exists(address.area, address.datum) and last < DATA_PER_AREA):
            return Result.BAD_ADDRESS
        new: list[tuple[int, float]] = []
        for k, value in enumerate(values):
            d = address.datum + k * step
            if isinstance(value, bytes):
                new += [(d + i, float(b)) for i, b in enumerate(value.ljust(4, b"\x00")[:4])]
                continue
            number = float(value)
            if fmt is DataFormat.INTEGER and address.view is View.FIXPOINT1:
                number = value / 10
            new.append((d, number))
        for d, number in new:
            lim = self._limits.get((address.area, d), _Limits())
            writable = lim.writable or (address.area, d) in self.forced
            if not math.isfinite(number) or not writable or not lim.low <= number <= lim.high:
                return Result.INVALID_VALUE
        for d, number in new:
            self.data[address.area][d] = number
            self.failed.discard((address.area, d))
        return Result.OK

    # ------------------------------------------------------------------ caches
    def read_cache(self, index: int, count: int) -> list[int]:
        out = []
        for i in range(index, index + count):
            entry = self.read_entries[i - 1] if i - 1 < len(self.read_entries) else None
            out.append(self.view_word(entry) if entry is not None else 0)
        return out

    def write_cache(self, index: int, words: Sequence[int]) -> None:
        for k, word in enumerate(words):
            self.write_words[index - 1 + k] = word & 0xFFFF

    def _transfer_outputs(self) -> None:
        """Push changed write-cache entries to the controllers."""
        for i, entry in enumerate(self.write_entries, 1):
            word = self.write_words[i - 1]
            if self._applied.get(i) == word:
                continue
            self._applied[i] = word
            signed = word - 0x10000 if word & 0x8000 else word
            self.write_values(entry, DataFormat.INTEGER, [signed])

    # ------------------------------------------------------------------ configuration
    def set_user_parameters(self, user: UserParameters) -> None:
        self.user = user
        self.channel.byte_order = user.byte_order

    def configure(self, configuration: Configuration) -> None:
        """Take a (validated) module configuration, as Chk_Cfg does."""
        self.configuration = configuration
        self.channel.reset()
        # the write cache starts as the controllers' present values: only changes are taken
        self.write_words = [0] * CACHE_SIZE
        for i, entry in enumerate(self.write_entries):
            self.write_words[i] = self.view_word(entry)
        self._applied = {i: w for i, w in enumerate(self.write_words[: len(self.write_entries)], 1)}
        self._activate_last = 0
        self._mux = []
        keys = [m.key for m in configuration.modules]
        var_pos = keys.index("A.2") if "A.2" in keys else None
        behind = configuration.slots[var_pos + 1 :] if var_pos is not None else ()
        self._var_io = [s for s in behind if s.module.is_io]
        self._var_mux = None
        if var_pos is not None:
            r = sum(s.module.inputs for s in self._var_io) // 2
            w = sum(s.module.outputs for s in self._var_io) // 2
            self._var_mux = MuxServer(self, r, w, consistent=self.consistent_mux)
        self._direct_io = [
            s for s in configuration.slots if s.module.is_io and s not in self._var_io
        ]
        self._fixed = {
            s.position: MuxServer(
                self, s.module.mux_size, s.module.mux_size, consistent=self.consistent_mux
            )
            for s in configuration.slots
            if s.module.is_fixed_mux
        }

    def exchange(self, outputs: bytes, now: float) -> bytes:
        """One bus cycle: the master's output image in, the input image out."""
        conf = self.configuration
        if conf is None:
            raise ConfigError("the coupler has no module configuration yet")
        if len(outputs) != conf.output_bytes:
            raise ConfigError(f"output image is {conf.output_bytes} bytes, got {len(outputs)}")
        inputs = bytearray(conf.input_bytes)
        activate: int | None = None
        # direct I/O modules: caches from index 1 on
        rd = wr = 1
        for s in self._direct_io:
            m = s.module
            if m.outputs:
                words = bytes_to_words(outputs[s.out_offset : s.out_offset + m.outputs])
                self.write_cache(wr, words)
                wr += len(words)
            if m.inputs:
                n = m.inputs // 2
                inputs[s.in_offset : s.in_offset + m.inputs] = words_to_bytes(
                    self.read_cache(rd, n)
                )
                rd += n
        for s in conf.slots:
            m = s.module
            out = outputs[s.out_offset : s.out_offset + m.outputs]
            if m.key == "A.1":
                inputs[s.in_offset : s.in_offset + CHANNEL_BYTES] = self.channel.exchange(out, now)
            elif m.key == "A.7":
                activate = out[0]
            elif m.key == "A.2":
                self._exchange_variable(outputs, inputs, s.in_offset, out)
            elif m.is_fixed_mux:
                ir, iw, data = decode_fixed(out)
                answer = self._fixed[s.position].exchange(MuxOut(ir, iw, data))
                inputs[s.in_offset : s.in_offset + m.inputs] = encode_fixed(
                    answer.index_read, answer.index_write, answer.data
                )
        if activate is None:
            self._transfer_outputs()
        else:
            if activate:
                self._transfer_outputs()
            self._activate_last = activate
        return bytes(inputs)

    def _exchange_variable(
        self, outputs: bytes, inputs: bytearray, in_offset: int, out: bytes
    ) -> None:
        ir, iw = bytes_to_words(out)
        data: list[int] = []
        for s in self._var_io:
            data += bytes_to_words(outputs[s.out_offset : s.out_offset + s.module.outputs])
        assert self._var_mux is not None
        answer = self._var_mux.exchange(MuxOut(ir, iw, tuple(data)))
        inputs[in_offset : in_offset + 4] = words_to_bytes((answer.index_read, answer.index_write))
        pos = 0
        for s in self._var_io:
            n = s.module.inputs // 2
            if n:
                block = answer.data[pos : pos + n]
                inputs[s.in_offset : s.in_offset + s.module.inputs] = words_to_bytes(block)
                pos += n

    # ------------------------------------------------------------------ forcing, fail-safe
    def force(self, address: Address, kind: ForceKind = ForceKind.ANALOG_INPUT) -> None:
        """Mark a datum as forced from the bus (2.3): the bus may write it even if it is
        read-only (a physical input), and the fail-safe applies to it."""
        if not self._exists(address.area, address.datum):
            raise ConfigError(f"no datum at {address}")
        self.forced[(address.area, address.datum)] = kind

    def bus_failure(self) -> None:
        """Bus failure or master stop: apply the fail-safe behaviour (2.4)."""
        self.channel.reset()
        for (area, datum), kind in self.forced.items():
            if kind is ForceKind.ANALOG_INPUT:
                self.failed.add((area, datum))
            elif self.user.fail_safe is FailSafe.ZERO:
                self.data[area][datum] = 0.0

    def device_diagnosis(self) -> DeviceDiagnosis:
        flags = self.device.inputs | (InputFlags.FAIL if self.failed else InputFlags.NONE)
        return DeviceDiagnosis(
            self.device.revision,
            self.device.firmware,
            self.device.errors,
            self.device.alarms,
            flags,
        )
