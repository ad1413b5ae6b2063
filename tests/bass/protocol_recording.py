"""pyserial URL handler ``recording://DEVICE?record=FILE``: the serial port DEVICE, opened like
any other, which appends its settings to FILE each time they are applied to the line.

A pty cannot show a character frame (its driver forces 8 data bits and no parity), so tests
that check what a program sets open the line through this handler: register the package with
``serial.protocol_handler_packages.append("bass")`` (``tests`` on the import path), then give the
program ``recording:///dev/pts/N?record=FILE``. Each line of FILE is a JSON list
``[baud, data bits, parity, stop bits]``.
"""

from __future__ import annotations

import json
import urllib.parse
from typing import Any

import serial


def serial_class_for_url(url: str) -> tuple[str, type[serial.Serial]]:
    parts = urllib.parse.urlsplit(url)
    (record,) = urllib.parse.parse_qs(parts.query)["record"]

    class Recording(serial.Serial):
        def _reconfigure_port(self, *args: Any, **kwargs: Any) -> None:
            super()._reconfigure_port(*args, **kwargs)  # type: ignore[misc]
            settings = [self.baudrate, self.bytesize, self.parity, self.stopbits]
            with open(record, "a", encoding="utf-8") as file:
                file.write(json.dumps(settings) + "\n")

    return parts.path, Recording


def recorded(path: str) -> list[list[Any]]:
    """The settings FILE holds, oldest first."""
    with open(path, encoding="utf-8") as file:
        return [json.loads(line) for line in file]
