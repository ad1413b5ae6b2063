"""Protocol core speed: telegram encode/decode per second and receiver throughput.

Ratios compare with the fastest USS line (187500 baud, B 2.4): how many times faster than the
line the code runs, i.e. the share of one core a fully loaded line would take.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.receiver import Receiver
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.protocol.timing import char_time

FASTEST = 187500
LAYOUT = Layout(3, 2)
RAW = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")
LONG = Telegram(5, AddressMode.NORMAL, bytes(range(252))).encode()


def rate(func: Callable[[], object], seconds: float = 0.3) -> float:
    """Calls per second of ``func``, measured for about ``seconds``."""
    count, batch = 0, 200
    start = time.perf_counter()
    while True:
        for _ in range(batch):
            func()
        count += batch
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            return count / elapsed


def receiver_rate(chunk_size: int | None, telegram: bytes, count: int) -> float:
    """Bytes per second through a receiver: ``count`` telegrams separated by start pauses,
    fed whole (``chunk_size`` None) or in chunks of ``chunk_size`` bytes."""
    ct = char_time(FASTEST)
    receiver = Receiver(FASTEST)
    feeds: list[tuple[bytes, float]] = []
    t = 0.0
    for _ in range(count):
        t += 3 * ct
        step = chunk_size or len(telegram)
        for pos in range(0, len(telegram), step):
            part = telegram[pos : pos + step]
            t += len(part) * ct
            feeds.append((part, t))
    start = time.perf_counter()
    received = 0
    for data, stamp in feeds:
        received += len(receiver.feed(data, stamp))
    elapsed = time.perf_counter() - start
    assert received == count, received
    return count * len(telegram) / elapsed


def main() -> None:
    line_bytes = FASTEST / 11
    line_telegrams = line_bytes / (len(RAW) + 2)  # 14 bytes and a 2-character start pause
    telegram = Telegram.decode(RAW)
    pkw = Pkw(1, 52)
    results = {
        "encode (Telegram.encode, 14 bytes)": rate(telegram.encode),
        "build (Layout.pack + Telegram + encode)": rate(
            lambda: Telegram(5, AddressMode.NORMAL, LAYOUT.pack(pkw, [0x047E, 0])).encode()
        ),
        "decode (Telegram.decode, 14 bytes)": rate(lambda: Telegram.decode(RAW)),
        "parse (Telegram.decode + Layout.unpack)": rate(
            lambda: LAYOUT.unpack(Telegram.decode(RAW).data)
        ),
        "decode (Telegram.decode, 256 bytes)": rate(lambda: Telegram.decode(LONG)),
    }
    for name, per_second in results.items():
        print(
            f"{name:44} {per_second:12,.0f} telegrams/s"
            f"  ({per_second / line_telegrams:,.0f} x a 187500 baud line)"
        )
    for label, chunk, telegram_bytes, count in (
        ("receiver, 14-byte telegrams, one chunk each", None, RAW, 20000),
        ("receiver, 256-byte telegrams, one chunk each", None, LONG, 2000),
        ("receiver, 14-byte telegrams, byte by byte", 1, RAW, 5000),
    ):
        per_second = receiver_rate(chunk, telegram_bytes, count)
        print(
            f"{label:44} {per_second / 1e6:12.3f} MB/s"
            f"         ({per_second / line_bytes:,.0f} x a 187500 baud line)"
        )


if __name__ == "__main__":
    main()
