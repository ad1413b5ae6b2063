"""Process data modules of the KS VARIO and their configuration rules (KS VARIO interface
description 3.1).

17 modules, each with its identifier byte (the byte a DP master sends in Chk_Cfg):
A.1 parameter channel (8/8 bytes), A.2 variable multiplexer (4/4), A.3..A.6 fixed multiplexers
for 1, 4, 8, 14 data (6/6, 12/12, 20/20, 32/32), A.7 "activate output data" (1 byte out),
B.1..B.5 input words (1, 2, 4, 8, 16), B.6..B.10 output words (1, 2, 4, 8, 16).

Rules of a configuration (3.1, 3.5), each raising `ConfigError` with its own message:

1. at least one module;
2. the parameter channel (A.1) at most once;
3. the variable multiplexer (A.2) at most once;
4. A.1 not after A.2;
5. at least one I/O module (B.x) after A.2;
6. at most 50 modules;
7. at most 244 input bytes and 244 output bytes;
8. A.1 and single data (B.x) before the first fixed multiplexer A.3..A.6 (3.5: "Einzeldaten,
   sowie das Modul für den Parameterkanal sind vor dem ersten Multiplexmodul zu verwenden").

Identifier bytes follow the general DP format (IEC 61158 / EN 50170): bits 0-3 length - 1,
bits 4-5 00 special / 01 input / 10 output / 11 input and output, bit 6 words, bit 7
consistency over the whole module.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from pyuss.errors import ConfigError

MAX_MODULES = 50
MAX_INPUT_BYTES = 244
MAX_OUTPUT_BYTES = 244


@dataclass(frozen=True, slots=True)
class Module:
    """One module type: ``key`` (``A.1`` .. ``B.10``), ``number`` (1..17, the GSD reference),
    identifier byte, input and output bytes (master view: input = coupler -> master)."""

    key: str
    number: int
    ident: int
    name: str
    inputs: int
    outputs: int

    @property
    def is_io(self) -> bool:
        return self.key.startswith("B.")

    @property
    def is_fixed_mux(self) -> bool:
        return self.key in ("A.3", "A.4", "A.5", "A.6")

    @property
    def mux_size(self) -> int:
        """Data words of a fixed multiplexer (0 for other modules)."""
        return (self.inputs - 4) // 2 if self.is_fixed_mux else 0

    def __str__(self) -> str:
        return f"{self.key} ({self.name})"


def ident_sizes(ident: int) -> tuple[int, int]:
    """(input bytes, output bytes) of a general-format identifier byte."""
    if not ident & 0x30:
        raise ConfigError(f"identifier {ident:02X}h is a special format, not a general one")
    n = (ident & 0x0F) + 1
    if ident & 0x40:
        n *= 2
    inputs = n if ident & 0x10 else 0
    outputs = n if ident & 0x20 else 0
    return inputs, outputs


def _m(key: str, number: int, ident: int, name: str) -> Module:
    i, o = ident_sizes(ident)
    return Module(key, number, ident, name, i, o)


#: All modules, in the order of the interface description's table (3.1) and the GSD file (9.4).
MODULES: tuple[Module, ...] = (
    _m("A.1", 1, 0xF3, "General-Parameter channel"),
    _m("A.2", 2, 0x71, "Variable Multiplexfunc."),
    _m("A.3", 3, 0xF2, "1 data fix multiplexfunc."),
    _m("A.4", 4, 0xF5, "4 data fix multiplexfunc."),
    _m("A.5", 5, 0xF9, "8 data fix multiplexfunc."),
    _m("A.6", 6, 0xFF, "14 data fix multiplexfunc."),
    _m("A.7", 17, 0x20, "General-Activate output data"),
    _m("B.1", 7, 0x50, "I/O - 1 word IN"),
    _m("B.2", 8, 0x51, "I/O - 2 words IN"),
    _m("B.3", 9, 0x53, "I/O - 4 words IN"),
    _m("B.4", 10, 0x57, "I/O - 8 words IN"),
    _m("B.5", 11, 0x5F, "I/O - 16 words IN"),
    _m("B.6", 12, 0x60, "I/O - 1 word OUT"),
    _m("B.7", 13, 0x61, "I/O - 2 words OUT"),
    _m("B.8", 14, 0x63, "I/O - 4 words OUT"),
    _m("B.9", 15, 0x67, "I/O - 8 words OUT"),
    _m("B.10", 16, 0x6F, "I/O - 16 words OUT"),
)

BY_KEY = {m.key: m for m in MODULES}
BY_IDENT = {m.ident: m for m in MODULES}


def module(key: str) -> Module:
    """The module named ``key`` (``A.1``, ``a1``, ``B.10`` ...)."""
    k = key.strip().upper()
    if "." not in k and len(k) >= 2:
        k = k[0] + "." + k[1:]
    try:
        return BY_KEY[k]
    except KeyError:
        known = ", ".join(BY_KEY)
        raise ConfigError(f"unknown module {key!r} (known: {known})") from None


def parse_modules(text: str) -> list[Module]:
    """Modules from a comma-separated list of keys: ``"A.1,A.2,B.5,B.10"``."""
    return [module(part) for part in text.split(",") if part.strip()]


@dataclass(frozen=True, slots=True)
class Slot:
    """Where one configured module sits in the process images."""

    module: Module
    position: int
    in_offset: int
    out_offset: int


class Configuration:
    """A validated list of modules with their offsets in the input and output images."""

    def __init__(self, modules: Iterable[Module | str]) -> None:
        mods = [m if isinstance(m, Module) else module(m) for m in modules]
        validate(mods)
        self.modules: tuple[Module, ...] = tuple(mods)
        slots: list[Slot] = []
        i = o = 0
        for pos, m in enumerate(mods):
            slots.append(Slot(m, pos, i, o))
            i += m.inputs
            o += m.outputs
        self.slots: tuple[Slot, ...] = tuple(slots)
        self.input_bytes = i
        self.output_bytes = o

    @classmethod
    def from_chk_cfg(cls, data: bytes) -> Configuration:
        return cls(decode_chk_cfg(data))

    def chk_cfg(self) -> bytes:
        return chk_cfg_bytes(self.modules)

    def __repr__(self) -> str:
        return f"Configuration({','.join(m.key for m in self.modules)})"


def validate(modules: Sequence[Module]) -> None:
    """Check a module list against the interface description's rules (see module docstring)."""
    keys = [m.key for m in modules]
    if not modules:
        raise ConfigError("a configuration needs at least one module")
    if keys.count("A.1") > 1:
        raise ConfigError("the parameter channel A.1 may be configured only once")
    if keys.count("A.2") > 1:
        raise ConfigError("the variable multiplexer A.2 may be configured only once")
    if "A.1" in keys and "A.2" in keys and keys.index("A.1") > keys.index("A.2"):
        raise ConfigError(
            "the parameter channel A.1 cannot come after the variable multiplexer A.2"
        )
    if "A.2" in keys and not any(m.is_io for m in modules[keys.index("A.2") + 1 :]):
        raise ConfigError(
            "the variable multiplexer A.2 needs at least one I/O module (B.x) after it"
        )
    if len(modules) > MAX_MODULES:
        raise ConfigError(f"{len(modules)} modules: at most {MAX_MODULES} are allowed")
    inputs = sum(m.inputs for m in modules)
    outputs = sum(m.outputs for m in modules)
    if inputs > MAX_INPUT_BYTES:
        raise ConfigError(f"{inputs} input bytes: at most {MAX_INPUT_BYTES} are allowed")
    if outputs > MAX_OUTPUT_BYTES:
        raise ConfigError(f"{outputs} output bytes: at most {MAX_OUTPUT_BYTES} are allowed")
    first_fixed = next((i for i, m in enumerate(modules) if m.is_fixed_mux), None)
    if first_fixed is not None:
        late = [m for m in modules[first_fixed:] if m.key == "A.1" or m.is_io]
        if late:
            raise ConfigError(
                f"{late[0]} must come before the first fixed multiplexer {modules[first_fixed].key}"
            )


def chk_cfg_bytes(modules: Sequence[Module]) -> bytes:
    """The Chk_Cfg data of a module list: one identifier byte per module."""
    return bytes(m.ident for m in modules)


def decode_chk_cfg(data: bytes) -> list[Module]:
    """Modules from Chk_Cfg data; every byte must be one of the 17 identifiers."""
    mods: list[Module] = []
    for pos, byte in enumerate(data):
        m = BY_IDENT.get(byte)
        if m is None:
            raise ConfigError(f"Chk_Cfg byte {pos} ({byte:02X}h) is not a KS VARIO module")
        mods.append(m)
    return mods
