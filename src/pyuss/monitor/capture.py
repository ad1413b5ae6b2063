"""Capture files: one record per frame, written atomically, read back for replay.

Two formats carry the same information (`CaptureRecord`): pcapng (`pyuss.monitor.pcapng`,
for Wireshark and the shipped dissector) and JSON lines (`pyuss.monitor.jsonl`, for scripts).
`open_writer` picks the format by the file name's suffix; `read_capture` by the content, and
also reads the character recordings of the virtual bus (``uss bus --record``), which carry
raw characters instead of frames.

What a record holds, the pseudo-header of pcapng and how the files are written (atomically)
live in `pyuss.monitor.records`, below both formats (`Capture`, `CaptureWriter` and
`PSEUDO_HEADER` are imported from here too).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterable
from pathlib import Path

from pyuss.errors import ConfigError
from pyuss.monitor import jsonl, pcapng
from pyuss.monitor.model import Exchange
from pyuss.monitor.records import PSEUDO_HEADER, Capture, CaptureWriter, RecordWriter

__all__ = [
    "JSONL_SUFFIXES",
    "PCAPNG_SUFFIXES",
    "PSEUDO_HEADER",
    "Capture",
    "CaptureWriter",
    "open_writer",
    "read_capture",
    "write_all",
]


_PCAP_MAGICS = {
    struct.pack(order + "I", magic) for order in "<>" for magic in (0xA1B2C3D4, 0xA1B23C4D)
}
PCAPNG_SUFFIXES = (".pcapng", ".pcap", ".ntar")
JSONL_SUFFIXES = (".jsonl", ".json", ".ndjson")


def open_writer(
    path: str | os.PathLike[str],
    *,
    baud: int,
    four_wire: bool = False,
    epoch: float = 0.0,
    linktype: int | None = None,
    gap: float | None = None,
    tolerance: float = 0.0,
    profile: str | None = None,
) -> CaptureWriter:
    """A capture writer for ``path``: pcapng for ``.pcapng`` (also ``.pcap``, ``.ntar``),
    JSON lines for ``.jsonl`` (also ``.json``, ``.ndjson``). ``epoch`` is added to frame times
    to make them Unix time; ``linktype`` is the pcapng user link type (147..162); ``gap`` and
    ``tolerance`` the monitor's (seconds), kept so that a replay judges timing the same way;
    ``profile`` the device profile the monitor decodes with, so that a replay names and types
    parameters the same way."""
    suffix = Path(path).suffix.lower()
    kind: type[RecordWriter]
    if suffix in PCAPNG_SUFFIXES:
        kind = pcapng.PcapngWriter
    elif suffix in JSONL_SUFFIXES:
        if linktype is not None:
            raise ConfigError("a link type only applies to pcapng captures")
        kind = jsonl.JsonlWriter
    else:
        raise ConfigError(
            f"capture file {str(path)!r}: name it *.pcapng (Wireshark) or *.jsonl (JSON lines)"
        )
    return kind(
        path,
        baud=baud,
        four_wire=four_wire,
        epoch=epoch,
        gap=gap,
        tolerance=tolerance,
        profile=profile,
        linktype=linktype,
    )


def read_capture(path: str | os.PathLike[str]) -> Capture:
    """Read a pcapng or JSON-lines capture of the monitor, or a recording of the virtual bus;
    `ConfigError` naming the file and what is wrong otherwise."""
    name = str(path)
    try:
        with open(path, "rb") as file:
            head = file.read(4)
    except OSError as exc:
        raise ConfigError(f"cannot read capture {name}: {exc.strerror or exc}") from None
    if head == pcapng.SHB_TYPE_BYTES:
        return pcapng.read_pcapng(path)
    if head[:1] == b"{":
        return jsonl.read_jsonl(path)
    if head in _PCAP_MAGICS:
        raise ConfigError(
            f"{name}: a classic pcap file, not pcapng: the monitor reads the pcapng captures it "
            "writes (they carry the baud rate)"
        )
    raise ConfigError(
        f"{name}: not a capture (neither pcapng nor JSON lines of the monitor or the bus)"
    )


def write_all(writer: CaptureWriter, exchanges: Iterable[Exchange]) -> None:
    """Write ``exchanges`` and close; on any error the partial file is discarded."""
    try:
        for exchange in exchanges:
            writer.write(exchange)
    except BaseException:
        writer.discard()
        raise
    writer.close()
