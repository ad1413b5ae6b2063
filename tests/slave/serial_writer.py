"""A master in a process of its own, on pyserial: one stray character, a pause, then a request
one character at a time, then the answer: ``python serial_writer.py DEVICE BAUD STRAY_HEX
PAUSE_CHARS REQUEST_HEX``.

The pause is ``PAUSE_CHARS`` character times (11 bits, A 6.1) after the stray character ended;
the request's characters follow one character time apart, as a UART sends them. It prints one
JSON line: ``answer`` in hex (empty when none came within 2 s).
"""

from __future__ import annotations

import json
import sys
import time

import serial


def _at(moment: float) -> None:
    """Wait until ``moment``: sleep while far, then watch the clock (a UART does not sleep)."""
    while (left := moment - time.monotonic()) > 0:
        if left > 0.002:
            time.sleep(left - 0.0015)


def main(device: str, baud: int, stray: bytes, pause: float, request: bytes) -> None:
    char = 11 / baud
    port = serial.Serial(device, baud, timeout=2.0)
    try:
        port.reset_input_buffer()
        moment = time.monotonic()
        port.write(stray)
        moment += (len(stray) + pause) * char
        for byte in request:
            _at(moment)
            port.write(bytes((byte,)))
            moment += char
        head = port.read(2)
        rest = port.read(head[1]) if len(head) == 2 else b""
    finally:
        port.close()
    print(json.dumps({"answer": (head + rest).hex()}))


if __name__ == "__main__":
    device, baud, stray, pause, request = sys.argv[1:6]
    main(device, int(baud), bytes.fromhex(stray), float(pause), bytes.fromhex(request))
