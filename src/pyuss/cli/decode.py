"""Take a USS telegram apart: frame, BCC, parameter job and process data, in words or as JSON.

    uss decode 02 0C 05 10 34 00 00 00 00 04 7E 00 00 55 --layout 3,2
    uss decode 020C0510340000000 ... --layout v,0 --direction response --json

The hex may be given as one string or several arguments, with or without blanks, colons or
``0x`` prefixes. ``--layout PKW,PZD`` says how the net data are split (PKW 0, 3, 4 or ``v``;
PZD 0..16); ``--direction`` whether the telegram is a request (master to slave, the default)
or a response, which decides the names of IDs and of the bits of PZD1; ``--profile NAME`` says
how the device numbers parameters from 2000 on (micromaster4: PNU 10 with IND bit 15 is P2010)
and names the parameter as the family's documents write it (``r0052 (Status word 1)``).

A telegram with a wrong BCC is still decoded (``bcc_ok`` false) and exits with 0. Bad hex, a
missing or bad layout, a bad direction, bytes that are no telegram (no STX, LGE not matching
the length, undefined ADR) or net data that do not fit the layout give one line on stderr and
exit code 2; with ``--json`` that line is the JSON error object of every command on stdout,
``{"error": {"type": ..., "message": ..., "exit_code": 2}}``.

The JSON object is a stable interface; its keys are documented in docs/protocol.md:
``hex``, ``address``, ``mode``, ``adr``, ``lge``, ``bcc``, ``bcc_expected``, ``bcc_ok``,
``layout``, ``direction``, ``pkw`` (``id``, ``id_name``, ``id_text``, ``pnu``, ``parameter``
(the parameter number with the IND page bits of ``--profile`` counted in), ``index``,
``subindex``, ``spm_toggle``, ``values``, ``error_number``, ``error_text``; or null),
``broadcast_enable`` (or null), ``pzd`` (list of integers) and ``pzd1`` (or null).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from typing import TYPE_CHECKING, Any

from pyuss.cli._help import subcommand
from pyuss.cli._output import EXIT_OK, EXIT_USAGE, print_error
from pyuss.errors import ConfigError, TelegramError
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import (
    Pkw,
    RequestId,
    ResponseId,
    error_meaning,
    page_of,
    parameter_number,
)
from pyuss.protocol.pzd import (
    CONTROL_BITS,
    STATUS_BITS,
    ControlWord,
    StatusWord,
    describe_bits,
    raw16_to_percent,
)
from pyuss.protocol.telegram import AddressMode, Telegram, bcc

if TYPE_CHECKING:
    from pyuss.profiles import Profile

__all__ = ["describe", "parse_hex", "register", "render", "run"]

DIRECTIONS = ("request", "response")


def register(subparsers: Any) -> None:
    parser = subcommand(subparsers, "decode", "decode a telegram given in hex", __doc__)
    parser.add_argument(
        "hex",
        nargs="+",
        help="the telegram's bytes in hex, from STX to BCC, e.g. 02 0C 05 10 34 ... (blanks, "
        "colons and 0x optional)",
    )
    parser.add_argument(
        "-l",
        "--layout",
        metavar="PKW,PZD",
        help="how the net data are split (required): number of PKW words (0, 3, 4, or v for "
        "variable length) and of PZD words (0..16), e.g. 3,2 (USS specification C 7)",
    )
    parser.add_argument(
        "-d",
        "--direction",
        default="request",
        metavar="{request,response}",
        help="request: master to drive (default); response: drive to master - names the IDs "
        "and the bits of PZD1 (USS specification C Tables 4.1, 4.2, 5.4, 5.5)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object for scripts (keys in docs/protocol.md)",
    )
    parser.add_argument(
        "--profile",
        metavar="NAME",
        help="the drive family, for parameter numbers from 2000 on in the IND page bits "
        "(micromaster4: P2010 is PNU 10 with IND bit 15)",
    )
    parser.set_defaults(func=run)


def parse_hex(parts: list[str] | str) -> bytes:
    """Bytes from hex text: blanks, colons, commas, dashes and ``0x`` prefixes allowed; a token
    of one digit is one byte (``2`` = 02h)."""
    text = " ".join(parts) if isinstance(parts, list) else parts
    tokens = [t for t in re.split(r"[\s:,;-]+", text) if t]
    if not tokens:
        raise ConfigError("no hex bytes given")
    digits = []
    for given in tokens:
        token = given[2:] if given[:2] in ("0x", "0X") else given
        if len(token) == 1:
            token = "0" + token
        if not re.fullmatch(r"[0-9A-Fa-f]+", token):
            raise ConfigError(f"bad hex {given!r}: only the digits 0-9 and A-F are allowed")
        if len(token) % 2:
            raise ConfigError(f"bad hex {given!r}: an odd number of digits")
        digits.append(token)
    return bytes.fromhex("".join(digits))


def _hex(data: bytes) -> str:
    return data.hex(" ").upper()


def _pkw_dict(pkw: Pkw, direction: str, page_size: int | None = None) -> dict[str, Any]:
    ident: RequestId | ResponseId = (
        RequestId(pkw.id) if direction == "request" else ResponseId(pkw.id)
    )
    number = pkw.error_number if direction == "response" else None
    return {
        "id": pkw.id,
        "id_name": ident.name,
        "id_text": ident.text,
        "pnu": pkw.pnu,
        "parameter": parameter_number(pkw.pnu, pkw.index, page_size),
        "index": pkw.index,
        "subindex": pkw.subindex,
        "spm_toggle": pkw.spm_toggle,
        "values": list(pkw.values),
        "error_number": number,
        "error_text": None if number is None else error_meaning(number),
    }


def describe(
    raw: bytes, layout: Layout, direction: str = "request", *, page_size: int | None = None
) -> dict[str, Any]:
    """Everything ``uss decode`` knows about ``raw`` as a JSON-ready dict. Raises
    `TelegramError` when the bytes are no telegram or do not fit ``layout``. ``page_size``:
    parameter numbers per IND page of the device (2000 for MICROMASTER 4), so that
    ``parameter`` is the number the drive's manual gives (P2010, not PNU 10)."""
    if direction not in DIRECTIONS:
        raise ConfigError(f"bad direction {direction!r}: expected request or response")
    telegram = Telegram.decode(raw, check_bcc=False)
    expected = bcc(raw[:-1])
    net = layout.unpack(telegram.data)
    broadcast = None
    if telegram.mode is AddressMode.BROADCAST and net.pkw is not None and layout.pkw == 4:
        bea = BroadcastEnableArray.from_pkw(net.pkw)
        broadcast = {
            "a": bea.a,
            "b": bea.b,
            "c": bea.c,
            "d": bea.d,
            "flag": bea.flag,
            "words": sorted(bea.enabled_words),
        }
    pzd1 = None
    if net.pzd:
        flags = ControlWord if direction == "request" else StatusWord
        pzd1 = {
            "kind": "control" if direction == "request" else "status",
            "set": [f.name for f in flags(net.pzd[0]) if f.name],
        }
    return {
        "hex": _hex(raw),
        "address": telegram.address,
        "mode": telegram.mode.label,
        "adr": telegram.adr,
        "lge": telegram.lge,
        "bcc": raw[-1],
        "bcc_expected": expected,
        "bcc_ok": raw[-1] == expected,
        "layout": str(layout),
        "direction": direction,
        "pkw": None if net.pkw is None else _pkw_dict(net.pkw, direction, page_size),
        "broadcast_enable": broadcast,
        "pzd": list(net.pzd),
        "pzd1": pzd1,
    }


def _render_pkw(info: dict[str, Any], lines: list[str], profile: Profile | None) -> None:
    pkw, bea = info["pkw"], info["broadcast_enable"]
    if pkw is None:
        lines.append("PKW        none (PKW 0)")
        return
    if bea is not None:
        words = ", ".join(str(w) for w in bea["words"]) or "none"
        lines.append(f"enable a   {bea['a']:04X}h: flag {int(bea['flag'])}, PZD words {words}")
        for name, word in (("b", 1), ("c", 4), ("d", 5)):
            lines.append(f"enable {name}   {bea[name]:04X}h: bits of PZD{word}")
        return
    kind = "request" if info["direction"] == "request" else "response"
    pke = (pkw["id"] << 12) | (0x800 if pkw["spm_toggle"] else 0) | pkw["pnu"]
    lines.append(
        f"PKE        {pke:04X}h: {kind} {pkw['id']} {pkw['id_name']} ({pkw['id_text']}), "
        f"PNU {pkw['pnu']}, toggle {int(pkw['spm_toggle'])}"
    )
    number = pkw.get("parameter", pkw["pnu"])
    label = f"P{number}" if profile is None else profile.label(number)
    if profile is not None and number in profile.database():
        label += f" ({profile.database().parameter(number).name})"
    if number != pkw["pnu"]:
        lines.append(
            f"           parameter {label}: PNU {pkw['pnu']} on IND page "
            f"{page_of(pkw['index'])} (bits 12..15)"
        )
    elif profile is not None and number in profile.database():
        lines.append(f"           parameter {label}")
    index = pkw["index"]
    extra = ""
    paged = profile is not None and profile.pnu_page_size is not None
    if index >> 8 and paged:
        extra = f", bits 8/9 = {index >> 8 & 3:02b}, page {page_of(index)} (bits 12..15)"
        if index >> 10 & 3:
            extra += f", bits 10/11 = {index >> 10 & 3:02b}"
    elif index >> 8:
        extra = f", bits 8/9 = {index >> 8 & 3:02b}, device bits {index >> 10}"
    lines.append(f"IND        {index:04X}h: subindex {pkw['subindex']}{extra}")
    values = pkw["values"]
    for i, word in enumerate(values, 1):
        lines.append(f"PWE{i:<7} {word:04X}h = {word}")
    if pkw["error_number"] is not None:
        lines.append(f"           error {pkw['error_number']}: {pkw['error_text']}")
    if kind == "response" and pkw["id"] == ResponseId.TEXT and values:
        text = Pkw(pkw["id"], values=tuple(values)).text()
        lines.append(f"           text {text!r}")


def render(info: dict[str, Any], profile: Profile | None = None) -> str:
    """The person-readable form of `describe`'s dict (``profile``: the parameter is named as
    the family's documents write it, ``r0052 (Status word 1)``)."""
    raw_len = len(info["hex"].split())
    verdict = "ok" if info["bcc_ok"] else f"WRONG, expected {info['bcc_expected']:02X}h"
    direction = (
        "request (master -> slave)"
        if info["direction"] == "request"
        else "response (slave -> master)"
    )
    pkw_count, pzd_count = info["layout"].split(",")
    lines = [
        f"telegram   {info['hex']} ({raw_len} bytes)",
        f"ADR        {info['adr']:02X}h: address {info['address']}, {info['mode']}",
        f"LGE        {info['lge']}: {info['lge'] - 2} net bytes",
        f"BCC        {info['bcc']:02X}h {verdict}",
        f"layout     PKW {pkw_count}, PZD {pzd_count}; {direction}",
    ]
    _render_pkw(info, lines, profile)
    pzd = info["pzd"]
    if pzd:
        kind = info["pzd1"]["kind"]
        table = CONTROL_BITS if kind == "control" else STATUS_BITS
        lines.append(f"PZD1       {pzd[0]:04X}h {kind} word")
        for bit, on, meaning in describe_bits(pzd[0], table):
            if bit in table or on:
                lines.append(f"             bit {bit:2} = {int(on)}  {meaning}")
    for i, word in enumerate(pzd[1:], 2):
        lines.append(f"PZD{i:<7} {word:04X}h = {word} ({raw16_to_percent(word):.2f} % of 4000h)")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    try:
        raw = parse_hex(args.hex)
        if args.layout is None:
            raise ConfigError("no layout given: --layout PKW,PZD is required, e.g. --layout 3,2")
        layout = Layout.parse(args.layout)
        page_size = None
        profile = None
        if args.profile is not None:
            from pyuss.profiles import get_profile

            profile = get_profile(args.profile)
            page_size = profile.pnu_page_size
        info = describe(raw, layout, args.direction, page_size=page_size)
    except (ConfigError, TelegramError) as exc:
        if args.json:
            print_error(exc, EXIT_USAGE)
        else:
            print(f"uss decode: {exc}", file=sys.stderr)
        return EXIT_USAGE
    print(json.dumps(info, indent=2) if args.json else render(info, profile))
    return EXIT_OK
