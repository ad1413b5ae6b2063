"""What a device profile says about the telegram level, for the slave and the master alike.

A `Profile` is data plus a few pure functions. Its parameter database (numbers, types, limits,
texts) lives in the TOML file of the same name under ``pyuss/profiles/data`` and is read with
`Profile.database`; everything here is about how the device speaks USS:

- which layouts it accepts (`Profile.check_layout`, `Profile.default_layout`,
  `Profile.fixed_layout`);
- the timing it keeps: start pause and the window in which it answers (`Profile.start_pause`,
  `Profile.response_delay`);
- how parameter numbers above the 11 bits of PKE travel (`Profile.encode_pnu`,
  `Profile.decode_pnu`; reading 8: device-specific IND bits);
- the broadcast form it understands (`BroadcastForm`, reading 9), whether it sends spontaneous
  messages (C 4.2.1.2) and which request IDs it knows;
- the error numbers above the specification's (`Profile.error_meanings`,
  `Profile.error_meaning`) and which ones it answers when a job does not fit the PKW area
  (`Profile.too_large_error`, C 7) or names a reserved request ID (`Profile.unsupported_error`);
- what to do after a refusal (`Profile.error_hint`, `Profile.no_authority_hint`, from the
  parameter file's ``[hints]``);
- device behaviour switched by parameters (`BitRef`), such as Baumueller's response-delay mode.

Nothing here reads a clock or does I/O; a master uses the same objects to address a device
(PNU mapping, broadcast form, error names, time-outs).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache

from pyuss.drive.database import ParameterDatabase
from pyuss.drive.loader import load_profile
from pyuss.errors import ConfigError
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pkw import (
    MAX_PNU,
    NO_AUTHORITY_HINT,
    PAGE_BITS,
    error_hint,
    error_meaning,
    page_of,
    parameter_number,
)
from pyuss.protocol.timing import MAX_RESPONSE_DELAY, char_time

__all__ = ["BitRef", "BroadcastForm", "IdentityRule", "Profile"]

_PAGE_MASK = 0xF000


class BroadcastForm(enum.Enum):
    """How a device takes process data from a broadcast telegram (A 3, reading 9).

    A broadcast is never answered whatever the form (A 3, A 5.2.2).
    """

    NONE = "none"
    """The device takes nothing from broadcasts."""
    ENABLE_ARRAY = "enable-array"
    """The optional Siemens mechanism: a 4-word Broadcast Enable Array in the PKW area selects
    PZD words and control bits (appendix, C 5.2.3, `pyuss.protocol.broadcast`)."""
    MASKED_CONTROL = "masked-control"
    """Baumueller: PZD1 is merged into the control word through the mask in PWE1; setpoints
    and PKW jobs are not taken; optionally PZD2/PZD3 name the addresses that react (Baumueller
    manual
    2.2, reading 9)."""


@dataclass(frozen=True, slots=True)
class BitRef:
    """One bit of a parameter that switches device behaviour (for example P181 bit 2)."""

    pnu: int
    bit: int
    index: int | None = None

    def __str__(self) -> str:
        where = f"P{self.pnu}" if self.index is None else f"P{self.pnu}.{self.index}"
        return f"{where} bit {self.bit}"


@dataclass(frozen=True, slots=True)
class IdentityRule:
    """What one parameter of a drive shows when the drive is of a family: reading ``pnu``
    (element ``index``) answers one of ``values`` (None: any value), or, with ``present``
    False, is refused. `pyuss.profiles.identify` applies a profile's rules."""

    pnu: int
    index: int | None = None
    values: frozenset[int] | None = None
    present: bool = True

    def matches(self, value: float | None) -> bool:
        """Whether the answer ``value`` (None: refused) fits the rule."""
        if value is None:
            return not self.present
        if not self.present:
            return False
        return self.values is None or (float(value).is_integer() and int(value) in self.values)

    def __str__(self) -> str:
        where = f"P{self.pnu}" if self.index is None else f"P{self.pnu}[{self.index}]"
        if not self.present:
            return f"{where} absent"
        if self.values is None:
            return f"{where} present"
        return f"{where} in {{{', '.join(map(str, sorted(self.values)))}}}"


@dataclass(frozen=True, slots=True)
class Profile:
    """A device profile: see the module docstring. Instances are the built-in profiles of
    `pyuss.profiles` (``get_profile(name)``)."""

    name: str
    title: str
    follows: str
    """The document sections the profile follows (docs/references.md)."""
    default_layout: Layout
    """The layout used when neither the user nor the parameter file sets one."""
    manufacturer: str = ""
    """The maker of the family's drives ("": a profile of the USS specification, of no one
    maker)."""
    fixed_layout: Layout | None = None
    """The only layout the device knows (for example 6SE21: PKW 3, PZD 2), or None."""
    pkw_choices: tuple[int, ...] = (0, 3, 4, PKW_VARIABLE)
    max_pzd: int = 16
    start_pause_chars: float = 2.0
    """Silence before every telegram, in character times (A 5.1.2; Baumueller: 33 bits = 3)."""
    residual_extra_chars: float = 0.0
    """Character times the device allows beyond A 6.3's maximum residual time (NORD counts
    1.5 x (n + 4) from the start of STX: 0.5 more; `pyuss.protocol.timing`)."""
    response_delay_min: float = 0.0
    """Earliest answer after the request's BCC in seconds (never below the start pause)."""
    response_delay_max: float = MAX_RESPONSE_DELAY
    """Latest answer in seconds (A 5.2.1.1: 20 ms; never below the start pause)."""
    delayed_response_max: float = MAX_RESPONSE_DELAY
    """Latest answer while the device's response-delay mode is on (`delay_mode`)."""
    pnu_page_size: int | None = None
    """Parameter numbers per page in IND bits 12..15 (MICROMASTER 4: 2000); None: PKE only."""
    answer_index_zero: bool = False
    """Answers always carry IND = 0 (6SE21, SIMOVERT P 6SE21 manual 7.5)."""
    broadcast: BroadcastForm = BroadcastForm.NONE
    spontaneous: bool = False
    """The device reports changes of active parameters spontaneously (C 4.2.1.2)."""
    request_ids: frozenset[int] = frozenset(set(range(16)) - {10})
    """The request IDs the device knows (C Table 4.1 without the reserved 10)."""
    error_meanings: Mapping[int, str] = field(default_factory=dict)
    """Device error numbers (above the specification's 0..7) and their meanings."""
    too_large_error: int = 103
    """Error number of response 7 for a job whose answer does not fit the PKW area (C 7)."""
    unsupported_error: int = 102
    """Error number of response 7 for the reserved request ID 10."""
    diagnostic_pnu: int = 2040
    """First of the 18 diagnostic parameters of A 5.2.3 a slave offers (`pyuss.slave`)."""
    delay_mode: BitRef | None = None
    """The bit that switches the response-delay mode on (Baumueller P181 bit 2)."""
    broadcast_coding: BitRef | None = None
    """The bit that switches broadcast address coding on (Baumueller P181 bit 1)."""
    data: str = ""
    """Name of the built-in parameter file (default: the profile's name)."""
    addresses: tuple[int, int] = (0, 31)
    """Lowest and highest bus address the device can be given (A 2.1: 0..31)."""
    control_bits: Mapping[int, str] = field(default_factory=dict)
    """Control word bits (PZD1 of a request) and what they do on this family."""
    status_bits: Mapping[int, str] = field(default_factory=dict)
    """Status word bits (PZD1 of an answer) and what they show on this family; a text ending
    in "(0 = active)" marks a low-active bit."""
    identity: tuple[IdentityRule, ...] = ()
    """How a drive of this family shows its identity in its parameters (empty: it cannot be
    told from the others); see `pyuss.profiles.identify`."""

    def __post_init__(self) -> None:
        self.check_layout(self.default_layout)
        if self.fixed_layout is not None and self.fixed_layout != self.default_layout:
            raise ConfigError(f"profile {self.name}: the fixed layout must be the default")
        lo, hi = self.response_delay_min, self.response_delay_max
        if not 0 <= lo <= hi:
            raise ConfigError(f"profile {self.name}: response delay window {lo}..{hi} s")
        if self.pnu_page_size is not None and not 1 <= self.pnu_page_size <= MAX_PNU + 1:
            raise ConfigError(f"profile {self.name}: page size {self.pnu_page_size}")

    # -- parameter file ---------------------------------------------------------------------

    def database(self) -> ParameterDatabase:
        """The profile's built-in parameter database (read once, then shared: it is immutable)."""
        return _database(self.data or self.name)

    # The family's facts below live in its parameter file alone (docs/drive.md); these views
    # read them from there.

    @property
    def baud_codes(self) -> Mapping[int, int]:
        """Values of the device's baud rate parameter and the rates they select (Siemens P2010:
        6 = 9600), from the parameter's value texts; empty where the rate is set in baud or not
        by a parameter."""
        return self.database().baud_codes() or {}

    @property
    def faults(self) -> Mapping[int, str]:
        """The family's fault numbers (as its fault display shows them) and short texts: the
        file's ``[fault_texts]``."""
        return self.database().fault_texts

    @property
    def fault_names(self) -> Mapping[int, str]:
        """Every fault number the family's file knows, with its text: the ``[fault_texts]``,
        and for a number that only a ``[faults]`` role names (``telegram_failure = 65``) the
        role's words ("telegram failure")."""
        texts: dict[int, str] = {}
        for name, code in self.database().faults.items():
            texts.setdefault(code, name.replace("_", " "))
        texts.update(self.faults)
        return texts

    @property
    def warnings(self) -> Mapping[int, str]:
        """The family's warning numbers and short texts: the file's ``[warning_texts]``."""
        return self.database().warning_texts

    @property
    def reference(self) -> int | None:
        """The parameter that scales setpoints and actual values: its value is 100 %, 4000h in
        a 16-bit PZD word (Siemens P2000, NORD P105): the file's ``[drive] reference``."""
        ref = self.database().roles.get("reference")
        return None if ref is None else ref.pnu

    # -- layouts ----------------------------------------------------------------------------

    def check_layout(self, layout: Layout) -> Layout:
        """``layout`` if the device accepts it, else `ConfigError` saying what it accepts."""
        if self.fixed_layout is not None and layout != self.fixed_layout:
            raise ConfigError(
                f"profile {self.name} uses the fixed layout {self.fixed_layout} only, not {layout}"
            )
        if layout.pkw not in self.pkw_choices:
            choices = ", ".join("v" if p == PKW_VARIABLE else str(p) for p in self.pkw_choices)
            raise ConfigError(f"profile {self.name}: PKW must be one of {choices}, not {layout}")
        if layout.pzd > self.max_pzd:
            raise ConfigError(
                f"profile {self.name}: at most {self.max_pzd} PZD words, not {layout.pzd}"
            )
        return layout

    @property
    def fixed_length_only(self) -> bool:
        """The device knows no variable-length PKW area."""
        return PKW_VARIABLE not in self.pkw_choices

    # -- timing -----------------------------------------------------------------------------

    def start_pause(self, baud: int) -> float:
        """The silence the device keeps before it sends, in seconds."""
        return self.start_pause_chars * char_time(baud)

    def response_delay(self, baud: int, *, delayed: bool = False) -> tuple[float, float]:
        """``(earliest, latest)`` start of an answer after the request's end, in seconds. Both
        are at least the start pause (A 5.2.1.1, reading 10); ``delayed``: the response-delay mode
        of the device is on."""
        pause = self.start_pause(baud)
        high = self.delayed_response_max if delayed else self.response_delay_max
        return (max(pause, self.response_delay_min), max(pause, high))

    # -- parameter numbers ------------------------------------------------------------------

    @property
    def max_pnu(self) -> int:
        """The largest parameter number the device can be addressed with."""
        if self.pnu_page_size is None:
            return MAX_PNU
        return 16 * self.pnu_page_size - 1

    def encode_pnu(self, pnu: int) -> tuple[int, int]:
        """``(PKE bits 0..10, IND bits)`` that address parameter ``pnu``; the IND bits are to
        be or-ed into the index word (reading 8)."""
        if isinstance(pnu, bool) or not isinstance(pnu, int) or not 0 <= pnu <= self.max_pnu:
            raise ConfigError(
                f"parameter number must be 0..{self.max_pnu} for profile {self.name}, got {pnu!r}"
            )
        if self.pnu_page_size is None:
            return pnu, 0
        page, number = divmod(pnu, self.pnu_page_size)
        bits = 0
        for weight, bit in enumerate(PAGE_BITS):
            if page >> weight & 1:
                bits |= 1 << bit
        return number, bits

    def decode_pnu(self, pnu_bits: int, index: int) -> int:
        """The parameter number a request addresses with PKE bits 0..10 and the IND word."""
        return parameter_number(pnu_bits, index, self.pnu_page_size)

    def page(self, index: int) -> int:
        """The page number in IND bits 12..15 (0 without paging)."""
        return 0 if self.pnu_page_size is None else page_of(index)

    def strip_page(self, index: int) -> int:
        """The IND word without the page bits: subindex and text bits."""
        return index & ~_PAGE_MASK if self.pnu_page_size is not None else index

    # -- errors -----------------------------------------------------------------------------

    def error_meaning(self, number: int) -> str:
        """The meaning of error ``number`` from a response 7, with this profile's numbers."""
        return error_meaning(number, self.error_meanings)

    def error_hint(self, number: int) -> str:
        """What to do after error ``number`` of a response 7: the family's own hint (its
        file's ``[hints]``) or the family-neutral one; "" where none is known."""
        hints = {k: v for k, v in self.database().hints.items() if isinstance(k, int)}
        return error_hint(number, hints)

    @property
    def no_authority_hint(self) -> str:
        """What to do after response 8 (no parameter change rights): the family's words
        (``[hints] no_authority``, for example which parameter gives USS the rights) or the
        family-neutral ones."""
        return self.database().hints.get("no_authority", NO_AUTHORITY_HINT)

    def label(self, pnu: int, index: int | None = None) -> str:
        """``pnu`` as the family's documents write it (``r0021``, ``P1120``, NORD ``P102``)."""
        return self.database().label(pnu, index)

    def fault_text(self, number: int) -> str:
        """The short text of fault ``number`` of this family ("" if unknown)."""
        return self.faults.get(number, "")

    def warning_text(self, number: int) -> str:
        """The short text of warning ``number`` of this family ("" if unknown)."""
        return self.warnings.get(number, "")

    def baud_of_code(self, code: int) -> int | None:
        """The baud rate the device's baud parameter value ``code`` selects (None: unknown)."""
        return self.baud_codes.get(code)

    def code_of_baud(self, baud: int) -> int | None:
        """The baud parameter value that selects ``baud`` (None: the device cannot)."""
        for code, rate in self.baud_codes.items():
            if rate == baud:
                return code
        return None


@cache
def _database(name: str) -> ParameterDatabase:
    return load_profile(name)
