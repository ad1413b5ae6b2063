"""``uss demo``: the examples of the USS specification, built with the protocol API and decoded.

Each example is built from its meaning (IDs, parameter numbers, control words, percentages)
with `pyuss.protocol`, encoded to bytes and decoded again as ``uss decode`` shows it; then a
receiver is fed a line carrying garbage, a telegram with a wrong BCC and good telegrams, and
prints what it finds. Everything runs in memory; nothing needs hardware.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pyuss.cli.decode import describe, render
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pkw import (
    INDEX_ALL,
    Pkw,
    RequestId,
    ResponseId,
    make_index,
    pwe_dword,
    pwe_text,
    pwe_word,
)
from pyuss.protocol.pzd import ControlWord, StatusWord, percent_to_raw16
from pyuss.protocol.receiver import Received, Receiver
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.protocol.timing import char_time

__all__ = ["EXAMPLES", "Example", "register", "run"]

#: Control word 047Eh: OFF1 with control by PLC (clears "switch-on inhibited").
READY = (
    ControlWord.NO_OFF2
    | ControlWord.NO_OFF3
    | ControlWord.ENABLE_OPERATION
    | ControlWord.ENABLE_RAMP_GENERATOR
    | ControlWord.START_RAMP_GENERATOR
    | ControlWord.ENABLE_SETPOINT
    | ControlWord.CONTROL_BY_PLC
)
#: Control word 047Fh: ON.
RUN = READY | ControlWord.ON
#: Status word 0231h: ready to switch on, no OFF2, no OFF3, control requested.
STANDBY = (
    StatusWord.READY_TO_SWITCH_ON
    | StatusWord.NO_OFF2
    | StatusWord.NO_OFF3
    | StatusWord.CONTROL_REQUESTED
)
#: Status word 0337h: running in tolerance.
RUNNING = STANDBY | StatusWord.READY | StatusWord.OPERATION_ENABLED | StatusWord.IN_TOLERANCE


@dataclass(frozen=True)
class Example:
    """One example of the specification: ``name`` matches the shared vectors."""

    name: str
    title: str
    layout: Layout
    direction: str
    build: Callable[[], Telegram]


def _normal(address: int, layout: Layout, pkw: Pkw | None, pzd: list[int]) -> Telegram:
    return Telegram(address, AddressMode.NORMAL, layout.pack(pkw, pzd))


L32 = Layout(3, 2)
L40 = Layout(4, 0)
L42 = Layout(4, 2)
LV0 = Layout(PKW_VARIABLE, 0)
L02 = Layout(0, 2)

EXAMPLES: tuple[Example, ...] = (
    Example(
        "pzd_only_request",
        "C 8.1 example 1: process data only - ON, setpoint 50 %",
        L02,
        "request",
        lambda: _normal(5, L02, None, [RUN, percent_to_raw16(50.0)]),
    ),
    Example(
        "pzd_only_response",
        "C 8.1 example 1: the drive runs, actual value 50 %",
        L02,
        "response",
        lambda: _normal(5, L02, None, [RUNNING, percent_to_raw16(50.0)]),
    ),
    Example(
        "read_word_request",
        "C 8.1 example 2: read parameter 52",
        L32,
        "request",
        lambda: _normal(5, L32, Pkw(RequestId.READ_VALUE, 52), [READY, 0]),
    ),
    Example(
        "read_word_response",
        "C 8.1 example 2: parameter 52 = 4000h",
        L32,
        "response",
        lambda: _normal(
            5, L32, Pkw(ResponseId.VALUE_WORD, 52, values=pwe_word(0x4000)), [STANDBY, 0]
        ),
    ),
    Example(
        "read_whole_pbe_request",
        "C 8.1 example 3: read the whole description of parameter 52 (fixed length)",
        L32,
        "request",
        lambda: _normal(5, L32, Pkw(RequestId.READ_PBE_ELEMENT, 52, INDEX_ALL), [READY, 0]),
    ),
    Example(
        "read_whole_pbe_refused",
        "C 8.1 example 3: refused, device error 103 (does not fit the PKW area)",
        L32,
        "response",
        lambda: _normal(
            5,
            L32,
            Pkw(ResponseId.REFUSED, 52, INDEX_ALL, values=pwe_word(103)),
            [STANDBY, 0],
        ),
    ),
    Example(
        "read_pbe_element_request",
        "C 8.1 example 4: read description element 7 (lower limit) of parameter 52",
        L32,
        "request",
        lambda: _normal(5, L32, Pkw(RequestId.READ_PBE_ELEMENT, 52, 7), [READY, 0]),
    ),
    Example(
        "read_pbe_element_response",
        "C 8.1 example 4: lower limit = 5FFFh",
        L32,
        "response",
        lambda: _normal(
            5, L32, Pkw(ResponseId.PBE_ELEMENT, 52, 7, values=pwe_word(0x5FFF)), [STANDBY, 0]
        ),
    ),
    Example(
        "write_array_dword_request",
        "C 8.1 example 5: write 4000 0000h to element 2 of array parameter 4",
        L40,
        "request",
        lambda: _normal(
            5, L40, Pkw(RequestId.WRITE_ARRAY_DWORD, 4, 2, values=pwe_dword(0x4000_0000)), []
        ),
    ),
    Example(
        "write_word_pkw4_request",
        "C 8.1 example 6: write 7000h to parameter 18 - a word travels in PWE2 with PKW 4",
        L40,
        "request",
        lambda: _normal(5, L40, Pkw(RequestId.WRITE_WORD, 18, values=pwe_word(0x7000)), []),
    ),
    Example(
        "read_text_request",
        "C 8.2 example 7: read text element 3 of parameter 7 (variable length)",
        LV0,
        "request",
        lambda: _normal(5, LV0, Pkw(RequestId.TEXT, 7, make_index(3)), []),
    ),
    Example(
        "read_text_response",
        "C 8.2 example 7: the text '300 BAUD', 16 characters",
        LV0,
        "response",
        lambda: _normal(5, LV0, Pkw(ResponseId.TEXT, 7, 3, values=pwe_text("300 BAUD", 16)), []),
    ),
    Example(
        "broadcast_ramp_enable",
        "Appendix example 2: broadcast - every ramp generator starts (control bit 5 only)",
        L42,
        "request",
        lambda: Telegram(
            0,
            AddressMode.BROADCAST,
            L42.pack(
                BroadcastEnableArray.from_selection(bits={1: 0x0020}).to_pkw(),
                [ControlWord.START_RAMP_GENERATOR, 0],
            ),
        ),
    ),
    Example(
        "mirror_request",
        "A 5.3: mirror telegram to slave 7 - the slave returns it unchanged",
        L32,
        "request",
        lambda: Telegram(
            7,
            AddressMode.MIRROR,
            L32.pack(Pkw(RequestId.READ_VALUE, 1), [READY, 0x1234]),
        ),
    ),
)


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="show the protocol at work on the examples of the specification",
        description="Build the examples of the USS specification, decode them, and run a "
        "receiver over a line with garbage and errors.",
    )
    parser.set_defaults(func=run)


def _receiver_demo() -> list[str]:
    baud = 9600
    ct = char_time(baud)
    receiver = Receiver(baud)
    good = EXAMPLES[2].build().encode()
    bad = good[:-1] + bytes((good[-1] ^ 0xFF,))
    line: list[tuple[str, bytes, float]] = [
        ("noise", b"\x41\x02\x17", 0.0),
        ("telegram after a start pause", good, 3.0),
        ("telegram with a wrong BCC", bad, 3.0),
        ("telegram 1.5 characters after the last one (no start pause)", good, 1.5),
        ("telegram after a start pause", good, 2.0),
    ]
    lines = [f"Receiver at {baud} baud, start pause {2 * ct * 1000:.3f} ms:"]
    t = 100.0
    for label, data, gap in line:
        t += (gap + len(data)) * ct
        lines.append(f"  sent {label}: {data.hex(' ').upper()}")
        for event in receiver.feed(data, t):
            lines.append(_event_line(event))
    for event in receiver.poll(t + 3 * ct):
        lines.append(_event_line(event))
    return lines


def _event_line(event: Any) -> str:
    if isinstance(event, Received):
        return f"    -> received telegram for address {event.telegram.address}"
    return f"    -> fault {event.kind.name}: {event.detail} [{event.raw.hex(' ').upper()}]"


def run(args: argparse.Namespace) -> int:
    del args
    print("USS specification examples, built with pyuss.protocol and decoded:\n")
    for example in EXAMPLES:
        raw = example.build().encode()
        print(f"== {example.title}  [--layout {example.layout} --direction {example.direction}]")
        print(render(describe(raw, example.layout, example.direction)))
        print()
    print("\n".join(_receiver_demo()))
    return 0
