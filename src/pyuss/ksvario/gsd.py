"""The KS VARIO GSD file (KS VARIO interface description 9.4): emit it, and parse GSD files of this
kind back.

`emit_gsd()` writes the device database file of the interface description with these deliberate
differences,
all towards the GSD standard so that configuration tools read it without warnings:

* ``MaxTsdr_*`` where the interface description writes ``MaxTcdr_*`` (the standard keyword);
* ``Max_Input_Len`` / ``Max_Output_Len`` spelt as the standard spells them;
* ``Ext_User_Prm_Data_Const(0)`` carries all 4 user parameter bytes (00 00 00 00), not 3, so
  a tool that applies only the constant still sends the full 4 bytes (interface description 6);
* the A.7 module name is in English like the others; text is plain ASCII, lines end CR LF.

`parse_gsd()` reads such files (keywords are case-insensitive, ``;`` starts a comment outside
quotes, ``\\`` continues a line): general keywords, ``PrmText`` blocks, ``ExtUserPrmData``
blocks (``Bit(n)`` or ``BitArea(a-b)`` with default and range, ``Prm_Text_Ref``), the
``Ext_User_Prm_Data_Const``/``_Ref`` lines, ``Module`` blocks (name, identifier bytes,
reference number), ``Unit_Diag_Bit`` texts and ``Unit_Diag_Area`` value texts.

Diagnosis bit numbers in the GSD count from byte 9 of the diagnosis (bit 0 = byte 9 bit 0):
``Unit_Diag_Area=24-31`` is byte 12 (firmware version), bit 32 byte 13 bit 0 (E.1), bit 40
byte 14 (Lim), bit 48 byte 15 (Fail), matching 6.1.2.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from pyuss.errors import ConfigError
from pyuss.ksvario.diag import IDENT_NUMBER
from pyuss.ksvario.modules import MODULES, Module

FILE_NAME = "PMA_1030.gsd"

_BAUDS = ("9.6", "19.2", "31.25", "45.45", "93.75", "187.5", "500", "1.5M", "3M", "6M", "12M")
_TSDR = (60, 60, 60, 60, 60, 60, 100, 150, 250, 450, 800)

#: (reference, name, bit, texts) of the user parameters (interface description 6, 9.4).
USER_PRM_TEXTS: tuple[tuple[int, str, int, tuple[str, str]], ...] = (
    (1, "Motorola/Intel format", 0, ("IEEE(Motorola)", "Intel")),
    (2, "Diagnosis format", 1, ("extended", "standard")),
    (3, "Fail-safe", 2, ("last value", "zero")),
)

#: Unit_Diag_Bit texts of the interface description's GSD (bit numbers counted from diagnosis byte
#: 9).
DIAG_BIT_TEXTS: dict[int, str] = {
    32: "E.1 Internal error",
    33: "E.2 Internal error/temporary",
    34: "E.3 Dev. configuration mismatch",
    35: "E.4 Hardware error",
    36: "E.5 Internal interface problem",
    40: "Lim Limit alarm",
    41: "HCA Heating current alarm",
    42: "SSR Heating current short circ.",
    43: "LOOP Control loop alarm",
    48: "Fail Fail input",
}


def _module_title(m: Module) -> str:
    return f"{m.key}: {m.name}"


def emit_gsd() -> str:
    """The GSD file text of the simulated KS VARIO (CR LF line ends, ASCII)."""
    out: list[str] = [
        ";=====",
        "; Device Database File for product KS Vario / DP",
        "; PMA Prozess- und Maschinen Automation GmbH, Kassel",
        "; Version : V1.0",
        f"; File: {FILE_NAME}",
        ";=====",
        "#Profibus_DP",
        "GSD_Revision=1",
        'Vendor_Name = "PMA GmbH"',
        'Model_Name = "KS Vario/DP"',
        'Revision = "V 1.0"',
        "Revision_Number = 1",
        f"Ident_Number = 0x{IDENT_NUMBER:04X}",
        "Protocol_Ident = 0",
        "Station_Type = 0",
        "FMS_supp = 0",
        'Hardware_Release = "HV 01.00"',
        'Software_Release = "SV 01.00"',
        ";Product supports the baud rates:",
    ]
    out += [f"{b}_supp = 1" for b in _BAUDS]
    out.append(";max. time to answer after a request")
    out += [f"MaxTsdr_{b} = {t}" for b, t in zip(_BAUDS, _TSDR, strict=True)]
    out += [
        "Redundancy = 0",
        "Repeater_Ctrl_Sig = 0",
        "24V_Pins = 0",
        'Bitmap_Device = "PMA1030N"',
        'Bitmap_Diag = "PMA1030D"',
        'Bitmap_SF = "PMA1030S"',
        ";",
        ";--DP-Slave related key words -----",
        "Freeze_Mode_supp = 1",
        "Sync_Mode_supp = 1",
        "Auto_Baud_supp = 1",
        "Set_Slave_Add_supp = 0",
        "Max_User_Prm_Data_Len = 4",
        "Min_Slave_Intervall = 1",
        "Modul_Offset = 0",
        "Modular_Station = 1",
        "Max_Module = 50",
        "Max_Input_Len = 244",
        "Max_Output_Len = 244",
        "Max_Data_Len = 488",
        ";",
        ";--User parameter text -----",
    ]
    for ref, _name, _bit, texts in USER_PRM_TEXTS:
        out.append(f"PrmText={ref}")
        out += [f'Text({i})="{t}"' for i, t in enumerate(texts)]
        out.append("EndPrmText")
    for ref, name, bit, _texts in USER_PRM_TEXTS:
        out += [
            f'ExtUserPrmData={ref} "{name}"',
            f"Bit({bit}) 0 0-1",
            f"Prm_Text_Ref={ref}",
            "EndExtUserPrmData",
        ]
    out.append(";--Device user parameters -----")
    out.append("Ext_User_Prm_Data_Const(0) = 0x00,0x00,0x00,0x00")
    out += [f"Ext_User_Prm_Data_Ref(3) = {ref}" for ref, *_ in USER_PRM_TEXTS]
    out.append(";--Modules -----")
    for m in MODULES:
        out += [f'Module = "{_module_title(m)}" 0x{m.ident:02X}', str(m.number), "EndModule"]
    out += [
        "Slave_Family = 5",
        "Max_Diag_Data_Len = 15",
        "Fail_Safe = 1",
        ";--Diagnosis -----",
        "Unit_Diag_Area = 24-31",
    ]
    out += [f'Value({v}) = "Firmware V{v // 10}.{v % 10}"' for v in range(10, 41)]
    out.append("Unit_Diag_Area_End")
    out += [f'Unit_Diag_Bit({bit}) = "{text}"' for bit, text in DIAG_BIT_TEXTS.items()]
    return "\r\n".join(out) + "\r\n"


# --------------------------------------------------------------------------- parser


@dataclass(frozen=True, slots=True)
class GsdModule:
    name: str
    config: bytes
    reference: int | None = None


@dataclass(frozen=True, slots=True)
class GsdUserPrm:
    """One ``ExtUserPrmData`` block: a bit field of the user parameters."""

    reference: int
    name: str
    first_bit: int
    last_bit: int
    default: int
    minimum: int
    maximum: int
    text_ref: int | None = None


@dataclass(frozen=True, slots=True)
class GsdDiagArea:
    first_bit: int
    last_bit: int
    values: dict[int, str]


@dataclass(slots=True)
class Gsd:
    """A parsed GSD file."""

    keywords: dict[str, str] = field(default_factory=dict)
    modules: list[GsdModule] = field(default_factory=list)
    prm_texts: dict[int, dict[int, str]] = field(default_factory=dict)
    user_prms: dict[int, GsdUserPrm] = field(default_factory=dict)
    prm_const: list[tuple[int, bytes]] = field(default_factory=list)
    prm_refs: list[tuple[int, int]] = field(default_factory=list)
    diag_bits: dict[int, str] = field(default_factory=dict)
    diag_areas: list[GsdDiagArea] = field(default_factory=list)

    def keyword(self, name: str) -> str | None:
        return self.keywords.get(name.lower())

    def number(self, name: str) -> int | None:
        value = self.keyword(name)
        return None if value is None else _num(value)

    def text(self, name: str) -> str | None:
        value = self.keyword(name)
        return None if value is None else value.strip('"')

    @property
    def ident_number(self) -> int | None:
        return self.number("Ident_Number")

    def default_user_prm(self) -> bytes:
        """The user parameter bytes with all defaults applied (const, then referenced bits)."""
        length = self.number("Max_User_Prm_Data_Len") or 0
        data = bytearray(length)
        for offset, const in self.prm_const:
            end = offset + len(const)
            if end > len(data):
                data.extend(bytes(end - len(data)))
            data[offset:end] = const
        for offset, ref in self.prm_refs:
            prm = self.user_prms.get(ref)
            if prm is None:
                raise ConfigError(f"Ext_User_Prm_Data_Ref({offset}) names unknown block {ref}")
            if offset >= len(data):
                data.extend(bytes(offset + 1 - len(data)))
            width = prm.last_bit - prm.first_bit + 1
            mask = ((1 << width) - 1) << prm.first_bit
            data[offset] = (data[offset] & ~mask) | ((prm.default << prm.first_bit) & mask)
        return bytes(data)

    def module_by_ident(self, ident: int) -> GsdModule | None:
        return next((m for m in self.modules if m.config == bytes((ident,))), None)


def _num(text: str) -> int:
    t = text.strip()
    return int(t, 16) if t.lower().startswith("0x") else int(t, 10)


def _strip_comment(line: str) -> str:
    quoted = False
    for i, c in enumerate(line):
        if c == '"':
            quoted = not quoted
        elif c == ";" and not quoted:
            return line[:i]
    return line


_RE_KEY = re.compile(r"^([A-Za-z0-9_.]+)\s*(?:\(\s*([0-9xXa-fA-F]+)\s*\))?\s*=\s*(.*)$")
_RE_MODULE = re.compile(r'^"([^"]*)"\s*(.*)$')
_RE_EXTPRM = re.compile(r'^(\S+)\s+"([^"]*)"$')
_RE_BIT = re.compile(
    r"^(Bit|BitArea)\s*\(\s*(\d+)\s*(?:-\s*(\d+))?\s*\)\s+(\S+)\s+(\S+)\s*-\s*(\S+)$", re.I
)


def parse_gsd(text: str) -> Gsd:
    """Parse a GSD file of this kind. Raises `ConfigError` naming the line that is wrong."""
    raw_lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    lines: list[tuple[int, str]] = []
    pending = ""
    pending_no = 0
    for no, raw in enumerate(raw_lines, 1):
        line = _strip_comment(raw).strip()
        if pending:
            line = pending + line
            no = pending_no
            pending = ""
        if line.endswith("\\"):
            pending, pending_no = line[:-1], no
            continue
        if line:
            lines.append((no, line))
    gsd = Gsd()
    state = "global"
    in_dp = False
    mod_name, mod_config = "", b""
    mod_ref: int | None = None
    prm_ref = 0
    prm_name = ""
    prm_fields: dict[str, int] = {}
    prm_text_no = 0
    area: GsdDiagArea | None = None
    for no, line in lines:
        try:
            low = line.lower()
            if line.startswith("#"):
                in_dp = low == "#profibus_dp"
                continue
            if not in_dp:
                continue
            if state == "prmtext":
                if low == "endprmtext":
                    state = "global"
                    continue
                m = _RE_KEY.match(line)
                if not m or m.group(1).lower() != "text" or m.group(2) is None:
                    raise ValueError('expected Text(n)="..." or EndPrmText')
                gsd.prm_texts[prm_text_no][_num(m.group(2))] = m.group(3).strip().strip('"')
                continue
            if state == "extprm":
                if low == "endextuserprmdata":
                    if "first" not in prm_fields:
                        raise ValueError(f"ExtUserPrmData {prm_ref} has no Bit/BitArea line")
                    gsd.user_prms[prm_ref] = GsdUserPrm(
                        prm_ref,
                        prm_name,
                        prm_fields["first"],
                        prm_fields["last"],
                        prm_fields["default"],
                        prm_fields["min"],
                        prm_fields["max"],
                        prm_fields.get("text"),
                    )
                    state = "global"
                    continue
                b = _RE_BIT.match(line)
                if b:
                    first = int(b.group(2))
                    last = int(b.group(3)) if b.group(3) else first
                    prm_fields.update(
                        first=first,
                        last=last,
                        default=_num(b.group(4)),
                        min=_num(b.group(5)),
                        max=_num(b.group(6)),
                    )
                    continue
                m = _RE_KEY.match(line)
                if m and m.group(1).lower() == "prm_text_ref":
                    prm_fields["text"] = _num(m.group(3))
                    continue
                raise ValueError("unexpected line in ExtUserPrmData")
            if state == "module":
                if low == "endmodule":
                    gsd.modules.append(GsdModule(mod_name, mod_config, mod_ref))
                    state = "global"
                    continue
                if re.fullmatch(r"\d+", line):
                    mod_ref = int(line)
                    continue
                continue  # module-level keywords are not needed here
            if state == "diagarea":
                assert area is not None
                if low == "unit_diag_area_end":
                    gsd.diag_areas.append(area)
                    area = None
                    state = "global"
                    continue
                m = _RE_KEY.match(line)
                if not m or m.group(1).lower() != "value" or m.group(2) is None:
                    raise ValueError('expected Value(n)="..." or Unit_Diag_Area_End')
                area.values[_num(m.group(2))] = m.group(3).strip().strip('"')
                continue
            # global state
            m = _RE_KEY.match(line)
            if not m:
                raise ValueError("expected KEY = VALUE")
            key, index, value = m.group(1).lower(), m.group(2), m.group(3).strip()
            if key == "prmtext":
                prm_text_no = _num(value)
                gsd.prm_texts[prm_text_no] = {}
                state = "prmtext"
            elif key == "extuserprmdata":
                e = _RE_EXTPRM.match(value)
                if not e:
                    raise ValueError('expected ExtUserPrmData=n "name"')
                prm_ref, prm_name, prm_fields = _num(e.group(1)), e.group(2), {}
                state = "extprm"
            elif key == "module":
                mm = _RE_MODULE.match(value)
                if not mm:
                    raise ValueError('expected Module = "name" config bytes')
                config = [_num(x) for x in mm.group(2).replace(",", " ").split()]
                if not config or any(not 0 <= c <= 0xFF for c in config):
                    raise ValueError("module identifier bytes must be 0..255")
                mod_name, mod_config, mod_ref = mm.group(1), bytes(config), None
                state = "module"
            elif key == "ext_user_prm_data_const":
                if index is None:
                    raise ValueError("Ext_User_Prm_Data_Const needs an offset")
                data = bytes(_num(x) for x in value.split(","))
                gsd.prm_const.append((_num(index), data))
            elif key == "ext_user_prm_data_ref":
                if index is None:
                    raise ValueError("Ext_User_Prm_Data_Ref needs an offset")
                gsd.prm_refs.append((_num(index), _num(value)))
            elif key == "unit_diag_bit":
                if index is None:
                    raise ValueError("Unit_Diag_Bit needs a bit number")
                gsd.diag_bits[_num(index)] = value.strip('"')
            elif key == "unit_diag_area":
                a, _, b2 = value.partition("-")
                area = GsdDiagArea(_num(a), _num(b2 or a), {})
                state = "diagarea"
            else:
                gsd.keywords[key if index is None else f"{key}({index})"] = value
        except (ValueError, KeyError) as exc:
            raise ConfigError(f"GSD line {no}: {line!r}: {exc}") from None
    if state != "global":
        raise ConfigError(f"GSD ends inside a {state} block")
    if not in_dp and not gsd.keywords:
        raise ConfigError("no #Profibus_DP section in the GSD file")
    return gsd
