"""PROFIBUS FDL telegrams (IEC 61158 type 3 / EN 50170), pure: no I/O.

Formats, each character sent 8E1 (8 data bits, even parity, 1 stop bit):

* SD1 ``10 DA SA FC FCS 16`` - no data;
* SD2 ``68 LE LEr 68 DA SA FC [DSAP] [SSAP] DU FCS 16`` - variable data, LE = bytes from DA to
  the end of DU (4..249), repeated;
* SD3 ``A2 DA SA FC DU(8) FCS 16`` - exactly 8 data bytes (SAP bytes included);
* SD4 ``DC DA SA`` - token;
* SC ``E5`` - short acknowledgement.

FCS is the arithmetic sum modulo 256 of DA, SA, FC and the data unit. Bit 7 of DA (SA) says
that a destination (source) address extension follows at the start of the data unit; its bits
0-5 are the service access point (SAP), bit 6 would mark a segment address.

FC of a request: bit 6 = 1, bits 5/4 FCB/FCV, bits 3-0 the function (SRD high 0Dh, FDL status
09h, ...). FC of a response: bit 6 = 0, bits 5-4 station type (00 slave), bits 3-0 the result
(DL 08h data low, DH 0Ah data high, RS 03h no service activated, UE 01h user error).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from pyuss.errors import ConfigError
from pyuss.ksvario.errors import FdlError
from pyuss.protocol.timing import BAUD_RATES as USS_BAUD_RATES

#: The PROFIBUS-DP baud rates the KS VARIO recognises by itself (KS VARIO interface description 1,
#: "Automatische
#: Baudratenerkennung"): 9.6, 19.2, 31.25, 45.45, 93.75, 187.5, 500 kbit/s, 1.5, 3, 6, 12 Mbit/s.
BAUD_RATES: tuple[int, ...] = (
    9600,
    19200,
    31250,
    45450,
    93750,
    187500,
    500000,
    1500000,
    3000000,
    6000000,
    12000000,
)
#: The DP rates the shared `pyuss.transport` lines carry (those that are USS rates too, B 2.4).
LINE_BAUD_RATES: tuple[int, ...] = tuple(b for b in BAUD_RATES if b in USS_BAUD_RATES)


def check_baud(baud: int) -> int:
    """Return ``baud`` if it is a PROFIBUS-DP baud rate a `pyuss.transport` line carries, else
    raise `ConfigError` saying which rates are possible."""
    lines = ", ".join(str(b) for b in LINE_BAUD_RATES)
    if isinstance(baud, bool) or baud not in BAUD_RATES:
        raise ConfigError(f"{baud!r} is not a PROFIBUS-DP baud rate (lines carry {lines})")
    if baud not in LINE_BAUD_RATES:
        raise ConfigError(
            f"{baud} is a PROFIBUS-DP baud rate the serial lines do not carry (they carry {lines})"
        )
    return baud


SD1 = 0x10
SD2 = 0x68
SD3 = 0xA2
SD4 = 0xDC
SC = 0xE5
ED = 0x16
BROADCAST = 127


class FC(enum.IntEnum):
    REQ = 0x40
    FCB = 0x20
    FCV = 0x10
    # request functions
    SDA_LO = 0x03
    SDN_LO = 0x04
    SDA_HI = 0x05
    SDN_HI = 0x06
    FDL_STATUS = 0x09
    SRD_LO = 0x0C
    SRD_HI = 0x0D
    IDENT = 0x0E
    LSAP = 0x0F
    # response results
    OK = 0x00
    UE = 0x01
    RR = 0x02
    RS = 0x03
    DL = 0x08
    NR = 0x09
    DH = 0x0A


class SAP(enum.IntEnum):
    """DP service access points (slave side, and the master's 62)."""

    SET_SLAVE_ADDRESS = 55
    READ_INPUTS = 56
    READ_OUTPUTS = 57
    GLOBAL_CONTROL = 58
    GET_CFG = 59
    SLAVE_DIAG = 60
    SET_PRM = 61
    CHK_CFG = 62
    MASTER = 62


def fcs(data: bytes) -> int:
    return sum(data) & 0xFF


@dataclass(frozen=True, slots=True)
class Frame:
    """One FDL telegram. ``sd`` is SD1..SD4 or SC; the SAPs are None when absent."""

    sd: int
    da: int = 0
    sa: int = 0
    fc: int = 0
    du: bytes = b""
    dsap: int | None = None
    ssap: int | None = None

    @property
    def is_request(self) -> bool:
        return bool(self.fc & FC.REQ)

    @property
    def function(self) -> int:
        return self.fc & 0x0F

    def encode(self) -> bytes:
        return encode_frame(self)


def encode_frame(frame: Frame) -> bytes:
    """Bytes of a frame. SD1 is used when there is neither data nor SAP, SD3 when data unit and
    SAP bytes make exactly 8, SD2 otherwise (unless ``frame.sd`` is SD4 or SC)."""
    if frame.sd == SC:
        return bytes((SC,))
    if frame.sd == SD4:
        return bytes((SD4, frame.da & 0x7F, frame.sa & 0x7F))
    for name, v in (("DA", frame.da), ("SA", frame.sa)):
        if not 0 <= v <= 127:
            raise FdlError(f"{name} {v} is not an address 0..127")
    ext = b""
    da, sa = frame.da, frame.sa
    if frame.dsap is not None or frame.ssap is not None:
        if frame.dsap is None or frame.ssap is None:
            raise FdlError("a DP telegram has both SAPs or none")
        da |= 0x80
        sa |= 0x80
        ext = bytes((frame.dsap & 0x3F, frame.ssap & 0x3F))
    unit = ext + frame.du
    body = bytes((da, sa, frame.fc)) + unit
    if not unit:
        return bytes((SD1,)) + body + bytes((fcs(body), ED))
    if len(unit) == 8:
        return bytes((SD3,)) + body + bytes((fcs(body), ED))
    le = len(body)
    if le > 249:
        raise FdlError(f"data unit of {len(unit)} bytes is too long for SD2 (max 246)")
    return bytes((SD2, le, le, SD2)) + body + bytes((fcs(body), ED))


def _split(body: bytes, sd: int) -> Frame:
    da, sa, fc = body[0], body[1], body[2]
    unit = body[3:]
    dsap = ssap = None
    if da & 0x80:
        dsap, unit = _extension(unit, "destination")
    if sa & 0x80:
        ssap, unit = _extension(unit, "source")
    return Frame(sd, da & 0x7F, sa & 0x7F, fc, bytes(unit), dsap, ssap)


def _extension(unit: bytes, which: str) -> tuple[int, bytes]:
    """The SAP of the address extension that starts ``unit``, and the rest of ``unit``."""
    if not unit:
        raise FdlError(f"{which} address extension missing")
    return unit[0] & 0x3F, unit[1:]


def frame_length(data: bytes) -> int | None:
    """Total length of the frame starting at data[0]; None if more bytes are needed.
    Raises `FdlError` for a byte that cannot start a frame or a bad SD2 length header."""
    sd = data[0]
    fixed = {SD1: 6, SD3: 14, SD4: 3, SC: 1}
    if sd in fixed:
        return fixed[sd]
    if sd != SD2:
        raise FdlError(f"{sd:02X}h is not a start delimiter")
    if len(data) < 4:
        return None
    le = data[1]
    if data[2] != le or data[3] != SD2 or not 3 <= le <= 249:
        raise FdlError(f"bad SD2 header {data[:4].hex(' ')}")
    return le + 6


def decode_frame(data: bytes) -> Frame:
    """Decode exactly one complete frame."""
    if not data:
        raise FdlError("empty frame")
    n = frame_length(data)
    if n is None or len(data) != n:
        raise FdlError(f"frame of {len(data)} bytes, expected {n}")
    sd = data[0]
    if sd == SC:
        return Frame(SC)
    if sd == SD4:
        return Frame(SD4, data[1] & 0x7F, data[2] & 0x7F)
    body = data[4:-2] if sd == SD2 else data[1:-2]
    if data[-1] != ED:
        raise FdlError(f"end delimiter is {data[-1]:02X}h, not 16h")
    if fcs(body) != data[-2]:
        raise FdlError(f"FCS {data[-2]:02X}h does not match {fcs(body):02X}h")
    return _split(body, sd)


class FrameReceiver:
    """Incremental receiver: `feed` bytes, get complete frames. A byte that cannot start a
    frame, or a frame with a bad FCS or end delimiter, is skipped (one byte at a time), so the
    receiver finds the next telegram after line noise. `errors` counts what was skipped."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.errors = 0

    def reset(self) -> None:
        self._buf.clear()

    def feed(self, data: bytes) -> list[Frame]:
        self._buf += data
        frames: list[Frame] = []
        while self._buf:
            try:
                n = frame_length(bytes(self._buf[:4]))
            except FdlError:
                del self._buf[0]
                self.errors += 1
                continue
            if n is None or len(self._buf) < n:
                break
            raw = bytes(self._buf[:n])
            try:
                frames.append(decode_frame(raw))
            except FdlError:
                del self._buf[0]
                self.errors += 1
                continue
            del self._buf[:n]
        return frames
