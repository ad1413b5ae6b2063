"""Monitor throughput: telegrams per second for a large capture, against the line's own rate.

Builds a 2-wire line of N exchanges (read, write, no job, a few damaged answers and missing
answers) with exact timestamps, then times:

- live decoding: bytes through the receiver, pairing, decoding, statistics (`Monitor.feed`);
- writing the capture as pcapng;
- replaying it: reading the pcapng and decoding it again (``uss monitor --read``);
- rendering one text line per exchange.

Times are the process's CPU time, so that other load on the machine does not count. The ratio
compares with the most telegrams a line can carry: at 187500 baud, 14-byte
telegrams with a start pause before each and no response delay.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from common import Figure

from pyuss.monitor import LayoutBook, Monitor, open_writer, read_capture, replay
from pyuss.monitor.render import exchange_line
from pyuss.protocol import Layout, Pkw, Telegram
from pyuss.protocol.timing import char_time

BAUD = 187500
EXCHANGES = 20_000
LAYOUT = Layout(3, 2)


def _line(n: int) -> list[tuple[bytes, float]]:
    """Chunks (bytes, time of the last byte) of ``n`` exchanges."""
    ct = char_time(BAUD)
    t = 1.0
    out: list[tuple[bytes, float]] = []
    for i in range(n):
        address = i % 31
        job = Pkw(1 + i % 2, i % 2000, values=(i & 0xFFFF,))
        req = Telegram(address, 0, LAYOUT.pack(job, (0x047E | (i & 1), i & 0x3FFF))).encode()
        t += 0.0005 + len(req) * ct
        out.append((req, t))
        if i % 97 == 13:
            continue  # no answer
        ans = bytearray(
            Telegram(address, 0, LAYOUT.pack(Pkw(1, job.pnu, values=(i,)), (0x0237, i))).encode()
        )
        if i % 101 == 7:
            ans[-1] ^= 0x01  # wrong BCC
        t += 0.0003 + len(ans) * ct
        out.append((bytes(ans), t))
    return out


def _timed(label: str, count: int, work: Callable[[], object]) -> float:
    """Telegrams per second of CPU time (this process's: other load on the machine does not
    count, a core's worth of decoding does)."""
    start = time.process_time()
    work()
    seconds = time.process_time() - start
    rate = count / seconds
    print(f"  {label:<28} {count:>7} telegrams in {seconds:6.3f} s = {rate:>9,.0f} telegrams/s")
    return rate


def main() -> list[Figure]:
    chunks = _line(EXCHANGES)
    telegrams = len(chunks)
    line_rate = BAUD / 11 / (14 + 2)  # 14-byte telegrams plus a 2-character start pause
    print(f"monitor: {EXCHANGES} exchanges, {telegrams} telegrams at {BAUD} baud, layout 3,2")
    exchanges: list[object] = []

    def live() -> None:
        monitor = Monitor(BAUD, layouts=LayoutBook(LAYOUT))
        for data, stamp in chunks:
            exchanges.extend(monitor.feed(data, stamp))
        exchanges.extend(monitor.finish())

    rates = {"live decoding (bytes in)": _timed("live decoding (bytes in)", telegrams, live)}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "line.pcapng"

        def write() -> None:
            writer = open_writer(path, baud=BAUD)
            for ex in exchanges:
                writer.write(ex)  # type: ignore[arg-type]
            writer.close()

        rates["write pcapng"] = _timed("write pcapng", telegrams, write)
        size = path.stat().st_size

        def read_and_decode() -> None:
            capture = read_capture(path)
            for _ in replay(capture, Monitor(BAUD, layouts=LayoutBook(LAYOUT))):
                pass

        rates["read + decode pcapng"] = _timed("read + decode pcapng", telegrams, read_and_decode)
    rates["render text lines"] = _timed(
        "render text lines",
        telegrams,
        lambda: [exchange_line(ex) for ex in exchanges],  # type: ignore[arg-type]
    )
    print(f"  capture size: {size / telegrams:.1f} bytes per telegram")
    print(f"  line limit at {BAUD} baud: {line_rate:,.0f} telegrams/s")
    for label, rate in rates.items():
        print(f"  ratio {label:<28} {rate / line_rate:6.1f} x the fastest line")
    live = rates["live decoding (bytes in)"] / line_rate
    return [Figure(f"monitor live decoding: times a full {BAUD} baud line", live, 10.0, digits=1)]


if __name__ == "__main__":
    from common import table

    print(table(main()))
