"""A master in a process of its own that writes a request to a pty as a UART would, then waits
for the answer: ``python uart_writer.py DEVICE BAUD REQUEST_HEX LOW HIGH SEED``.

The first character is written at once; every next one ``LOW`` to ``HIGH`` character times
(11 bits, A 6.1) after the one before (drawn with ``random.Random(SEED)``); ``LOW`` = ``HIGH`` =
0 writes the whole request at once. It prints one JSON line: ``end``, when the request's last
character ended (its write plus one character time; the whole request's time when written at
once), ``first``, when the first byte of the answer arrived (``time.monotonic()``, the clock
of every process on the machine), and ``answer`` in hex (empty when none came within 5 s).
"""

from __future__ import annotations

import json
import os
import random
import select
import sys
import termios
import time
import tty


def _at(moment: float) -> None:
    """Wait until ``moment``: sleep while far, then watch the clock (a UART does not sleep)."""
    while (left := moment - time.monotonic()) > 0:
        if left > 0.002:
            time.sleep(left - 0.0015)


def main(device: str, baud: int, request: bytes, low: float, high: float, seed: int) -> None:
    char = 11 / baud
    fd = os.open(device, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    termios.tcflush(fd, termios.TCIOFLUSH)
    draw = random.Random(seed)
    try:
        moment = time.monotonic()
        if high == 0:
            os.write(fd, request)
            end = moment + len(request) * char
        else:
            for i, byte in enumerate(request):
                if i:
                    moment += draw.uniform(low, high) * char
                    _at(moment)
                os.write(fd, bytes((byte,)))
            end = moment + char
        answer = b""
        first = None
        deadline = time.monotonic() + 5.0
        while len(answer) < 2 or len(answer) < answer[1] + 2:
            ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                break
            if first is None:
                first = time.monotonic()
            answer += os.read(fd, 512)
    finally:
        os.close(fd)
    print(json.dumps({"end": end, "first": first, "answer": answer.hex()}))


if __name__ == "__main__":
    device, baud, request, low, high, seed = sys.argv[1:7]
    main(device, int(baud), bytes.fromhex(request), float(low), float(high), int(seed))
