"""Cost of the simulated drive per process data exchange and per parameter job.

Prints microseconds per call and how the cost compares with the time a telegram takes on the
wire (a 14-byte telegram, PKW 3 + PZD 2, at 187500 baud): the ratio says how many simulated
drives one process can compute in the time of one telegram.
"""

from __future__ import annotations

import time

from pyuss.drive import SimulatedDrive

BAUD = 187_500
TELEGRAM_BYTES = 14
BITS_PER_CHARACTER = 11


def _per_call(label: str, calls: int, work: object) -> float:
    assert callable(work)
    start = time.perf_counter()
    for i in range(calls):
        work(i)
    seconds = (time.perf_counter() - start) / calls
    print(f"{label:44} {seconds * 1e6:9.1f} us/call")
    return seconds


def main() -> None:
    drive = SimulatedDrive.from_profile("generic")
    drive.exchange([0x047E, 0], 0.0)
    calls = 20_000

    def exchange(i: int) -> None:
        drive.exchange([0x047F, 0x2000], i * 0.001)

    def read(i: int) -> None:
        drive.read_words(52)

    def write(i: int) -> None:
        drive.write_words(18, [i & 0x7FFF], interface="uss")

    def text(i: int) -> None:
        drive.text_words(7, 3)

    def description(i: int) -> None:
        drive.description_words(683)

    cost = _per_call("exchange (PZD 2, ramping, displays)", calls, exchange)
    _per_call("read_words (word)", calls, read)
    _per_call("write_words (word, checked)", calls, write)
    _per_call("text_words (16 characters)", calls, text)
    _per_call("description_words (whole PBE)", calls // 4, description)
    telegram = TELEGRAM_BYTES * BITS_PER_CHARACTER / BAUD
    print(f"telegram time at {BAUD} baud ({TELEGRAM_BYTES} bytes): {telegram * 1e6:.0f} us")
    print(f"drives computed per telegram time (ratio): {telegram / cost:.1f}")


if __name__ == "__main__":
    main()
