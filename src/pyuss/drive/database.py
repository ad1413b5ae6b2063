"""The parameter database of a simulated drive, read from a declarative TOML file.

One file describes one device profile: the profile's settings (``[profile]``), the parameters
(``[[parameter]]``), which parameters the simulation uses for what (``[drive]``: ramp times,
jog setpoints, displays ...), the interface parameters (``[interface]``, C 3), the process data
mapping (``[process]``), the state codes a state display shows (``[state_codes]``) and the fault
codes the drive raises (``[faults]``). The format is documented in ``docs/drive.md``; the
built-in profiles live in ``pyuss/profiles/data/``.

Loading validates everything and refuses a bad file with a `ConfigError` naming the file, the
parameter and the field. The database itself is immutable: values live in `SimulatedDrive`.

Choices where the documents are silent (also in docs/drive.md):

- Limits (``min``/``max``) are raw values, the numbers that travel in PWE; ``scaling`` gives the
  physical value (raw x scaling, in ``unit``).
- Limits bind every write through an interface and the default of a writable parameter. A
  read-only parameter is a display the device itself updates; its limits describe the display
  range and are not applied to its own value. (C 8 example 2 reads 4000h from P52 whose lower
  limit is 5FFFh in example 4; a display parameter is the reading under which both hold.)
- Array indices: IND addresses element ``IND - index_base``; ``index_base`` is 1 for the
  SIMOVERT MASTERDRIVES style of the generic profile ("Index 1 = SST 1", C 3.2; C 8 example 5
  writes "the 2nd position" with IND 2) and 0 where a device counts from 0 (MICROMASTER 4).
"""

from __future__ import annotations

import enum
import math
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TypeVar

from pyuss.drive.datatypes import (
    TYPE_NAMES,
    DataType,
    Value,
    decode,
    encode,
    is_visible,
    round_float,
)
from pyuss.drive.faults import ParameterFault
from pyuss.errors import ConfigError
from pyuss.protocol.bico import Bico, BicoError, to_bico
from pyuss.protocol.pkw import ErrorNumber
from pyuss.userfile import parse_toml, read_text

TEXT_LENGTH = 16
"""A text element is always 16 characters (C 8 example 7, after the PROFIBUS profile)."""

MAX_ARRAY = 254
"""IND low byte 0..254 addresses elements; 255 means the whole array (C 4.2.2)."""

MAX_STRING = 240
"""Longest octet or visible string: it must fit the variable PKW area (C 4.1.2: m <= 124)."""

TIME_UNITS: dict[str, float] = {"ms": 0.001, "s": 1.0, "min": 60.0}

BAUD_UNITS = ("baud", "bd", "bit/s", "bps")
"""Units (any case) of a baud rate parameter whose value is the rate itself (Baumueller 182)."""

_BAUD_TEXT = re.compile(r"\s*(\d+(?:[.,]\d+)?)\s*(k?)\s*(?:baud|bd|bit/s|bps)\b", re.IGNORECASE)


class Access(enum.Enum):
    """Who may change a parameter."""

    RW = "rw"
    """Changeable through any interface with write authority."""
    RO = "ro"
    """Read-only (error 1 on writes); the drive itself may update it (displays)."""
    PROTECTED = "protected"
    """Changeable only while the access level parameter is high enough (else error 12)."""


class DescriptionStyle(enum.Enum):
    """Which parameter description (PBE) layout a profile answers with."""

    PROFIBUS = "profibus"
    """Elements 1..10 of C 6 (Bild 6.1), after the PROFIBUS profile the spec cites."""
    BAUMUELLER = "baumueller"
    """Elements 1, 2, 5, 6: attribute, info, minimum, maximum (Baumueller manual 2.2.1)."""


class NameStyle(enum.Enum):
    """How a family's documents write a parameter number (``[profile]`` key ``names``);
    `pyuss.params.names` writes and reads them."""

    PROJECT = "pyuss"
    """``P21``, ``P947.0``: a P before the number as it is (the generic profile, NORD)."""
    SIEMENS = "siemens"
    """``r0021`` for a read-only parameter, ``P1120`` for a writable one, four digits at
    least, as the MICROMASTER 4 and SINAMICS parameter lists and panels write them."""


def param_name(
    pnu: int,
    index: int | None = None,
    *,
    style: NameStyle = NameStyle.PROJECT,
    read_only: bool = False,
) -> str:
    """``P21``, ``P947.3`` (`NameStyle.PROJECT`); ``r0021``, ``P1120``, ``r0947.3``
    (`NameStyle.SIEMENS`: ``r`` where ``read_only``). The one formatter of parameter numbers
    (`pyuss.params.names` gives it to the upper layers)."""
    siemens = style is NameStyle.SIEMENS
    text = f"{'r' if siemens and read_only else 'P'}{pnu:04d}" if siemens else f"P{pnu}"
    return text if index is None else f"{text}.{index}"


class DisplayFormat(enum.IntEnum):
    """Display format code of the Baumueller attribute bits 8..11 (Baumueller manual 2.2.1)."""

    BIN = 0
    DEC = 1
    HEX = 2
    NORM = 4
    FIX = 5
    SCI = 6
    ENG = 7
    ASCII = 8


TIME_ROLES = (
    "ramp_up_time",
    "ramp_down_time",
    "quick_stop_time",
    "coast_time",
    "jog_ramp_time",
    "tolerance_time",
    "wait_time",
    "init_time",
)
"""Roles read as a duration (unit s, ms or min)."""

LEVEL_ROLES = ("jog1", "jog2", "tolerance", "compare_value")
"""Roles read as a fraction of the reference (unit %, the reference's unit, or '' = 4000h)."""

DISPLAY_ROLES = ("state", "fault", "warning", "control_word", "status_word", "setpoint", "actual")
"""Parameters the drive writes itself: state code, fault/warning number, words, values."""

MOTOR_ROLES = ("motor_voltage", "motor_current", "motor_power")
"""Rated motor data the simulation's motor model reads (units V, A, kW; `MOTOR_UNITS`)."""

OUTPUT_ROLES = ("output_voltage", "output_current", "output_power", "dc_link_voltage")
"""What the simulation's motor model shows: output voltage, current and power while the motor
runs, the DC link voltage while the drive is powered (units V, A, kW, V)."""

MOTOR_UNITS = {
    "motor_voltage": "V",
    "motor_current": "A",
    "motor_power": "kW",
    "output_voltage": "V",
    "output_current": "A",
    "output_power": "kW",
    "dc_link_voltage": "V",
}
"""The unit each motor role's parameter must have."""

IDENTITY_ROLES = ("firmware",)
"""What a drive tells of itself: its firmware version (shown by ``uss scan``)."""

ROLES = (
    *TIME_ROLES,
    *LEVEL_ROLES,
    "reference",
    *DISPLAY_ROLES,
    *MOTOR_ROLES,
    *OUTPUT_ROLES,
    *IDENTITY_ROLES,
)

INTERFACE_ROLES = ("address", "baud", "pkw", "pzd", "failure_time")
"""Interface parameters of C 3 the slave engine reads its settings from."""

STATE_NAMES = (
    "not_ready",
    "switch_on_inhibit",
    "ready_to_switch_on",
    "ready",
    "operation",
    "jog",
    "off1",
    "off3",
    "fault",
)
"""Keys of ``[state_codes]`` (the `DriveState` names in lower case)."""

STATE_CODE_NAMES = (*STATE_NAMES, "commissioning")
"""Keys ``[state_codes]`` accepts: the states, and ``commissioning`` (shown while the
commissioning parameter of ``[commissioning]`` is not 0)."""

CHANGEABLE_LETTERS = "CUT"
"""When a parameter can be changed, as the Siemens parameter lists say it: C in
commissioning (the commissioning parameter is not 0), U while the motor runs, T while the
drive is ready but does not run."""

COMMISSIONING_KEYS = (
    "parameter",
    "quick",
    "factory",
    "end",
    "reset",
    "keep_on_reset",
    "rated_frequency",
    "rated_speed",
    "pole_pairs",
)
"""Keys of ``[commissioning]`` (see `Commissioning`)."""

WORD_KEYS = ("reverse", "status_ones", "direction", "jog_switches_on")
"""Keys of ``[words]`` (see `WordBits`)."""

SOURCE_KINDS = ("command", "setpoint")
"""What a ``[sources]`` table may gate: the control word and the main setpoint."""

SOURCE_KEYS = ("command", "command_uss", "setpoint", "setpoint_uss")
"""Keys of ``[sources]`` (see `Sources`)."""


@dataclass(frozen=True, slots=True)
class ParamRef:
    """A parameter, or one element of an array parameter, by PNU and IND (None: scalar)."""

    pnu: int
    index: int | None = None

    def __str__(self) -> str:
        return f"P{self.pnu}" if self.index is None else f"P{self.pnu}.{self.index}"


@dataclass(frozen=True, slots=True, eq=False)
class Parameter:
    """One parameter as the file declares it (its value lives in the drive)."""

    pnu: int
    name: str
    dtype: DataType
    default: tuple[Value, ...]
    """The factory value of every element (one element for a scalar)."""
    array: int | None = None
    """Number of elements, None for a scalar."""
    length: int = 0
    """Length of a string in characters or bytes (0 for other types)."""
    minimum: int | float | None = None
    maximum: int | float | None = None
    allowed: tuple[int, ...] | None = None
    """The only values a write may set (for example PKW counts 0, 3, 4, 127)."""
    access: Access = Access.RW
    active: bool = False
    """Active parameter: a change from another interface is reported spontaneously (C 4.2.1.2)."""
    unit: str = ""
    scaling: float | None = None
    """Physical value = raw value x scaling; None: the raw value is the physical one."""
    decimals: int = 0
    display: DisplayFormat = DisplayFormat.DEC
    command: bool = False
    store: bool = True
    """May be saved with the EEPROM request IDs."""
    reset_only: bool = False
    """Writes may only reset it to 0 (else error 6)."""
    stopped_only: bool = False
    """Changeable only while the drive does not run (else error 17)."""
    texts: Mapping[int, str] = field(default_factory=dict)
    """Value texts (value -> text); for an array the second text field (C Table 4.6)."""
    index_texts: tuple[str, ...] = ()
    """Texts naming the elements of an array (C Table 4.5)."""
    bit_texts: Mapping[int, tuple[str, str]] = field(default_factory=dict)
    """V2: bit -> (text of 0, text of 1) (C Table 4.5)."""
    level: int | None = None
    """The access level the device lists the parameter under (Siemens P0003: 1 standard ..
    4 service); None where the file does not say."""
    changeable: str | None = None
    """When it can be changed: letters of ``CUT`` (`CHANGEABLE_LETTERS`); None: always, as far
    as access and ``stopped_only`` allow."""
    bico: bool = False
    """A BICO input (SINAMICS firmware 4): a ``uint32`` whose value names a signal source,
    `pyuss.protocol.bico.Bico` (``r722.2``); the file gives its defaults as such texts."""
    macro: bool = False
    """A macro: one value sets a group of other parameters at once (the SINAMICS V20's
    connection and application macros, firmware 4's p0015); ``uss params macro`` lists them."""
    doc: str = ""
    follows: str = ""
    """Where the facts come from: a document and section (docs/references.md), or "project"."""

    @property
    def is_array(self) -> bool:
        return self.array is not None

    @property
    def elements(self) -> int:
        """Number of values held (1 for a scalar)."""
        return 1 if self.array is None else self.array

    @property
    def word_count(self) -> int:
        """Words one value occupies in PWE."""
        return self.dtype.word_count(self.length)

    @property
    def writable(self) -> bool:
        return self.access is not Access.RO

    @property
    def low(self) -> int | float:
        """The effective lower limit: ``min``, else the smallest allowed value, else the type's."""
        if self.minimum is not None:
            return self.minimum
        return self.dtype.type_range[0] if self.allowed is None else min(self.allowed)

    @property
    def high(self) -> int | float:
        """The effective upper limit: ``max``, else the largest allowed value, else the type's."""
        if self.maximum is not None:
            return self.maximum
        return self.dtype.type_range[1] if self.allowed is None else max(self.allowed)

    def to_words(self, value: Value) -> tuple[int, ...]:
        """PKW words of one value."""
        return encode(self.dtype, value, self.length)

    def from_words(self, words: Sequence[int]) -> Value:
        """The value ``words`` carry, checked against the type (errors 5 and 2)."""
        return decode(self.dtype, words, self.length)

    def coerce(self, value: object) -> Value:
        """``value`` as this type holds it, or a `ParameterFault` (5 wrong type, 2 range); a
        BICO input takes a `Bico`, its text (``"r722.2"``) or its 32-bit value."""
        if self.bico:
            return _bico(value)
        dtype = self.dtype
        if dtype is DataType.FLOAT:
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ParameterFault(ErrorNumber.WRONG_TYPE, f"{value!r} is not a number")
            number = float(value)
            if not math.isfinite(number) or abs(number) > dtype.type_range[1]:
                raise ParameterFault(ErrorNumber.LIMIT_EXCEEDED, f"{value!r} does not fit a float")
            return round_float(number)
        if dtype.is_integer:
            if isinstance(value, bool) or not isinstance(value, int):
                raise ParameterFault(ErrorNumber.WRONG_TYPE, f"{value!r} is not an integer")
            low, high = dtype.type_range
            if not low <= value <= high:
                raise ParameterFault(
                    ErrorNumber.LIMIT_EXCEEDED, f"{value} does not fit {dtype.label}"
                )
            return value
        if dtype is DataType.VISIBLE_STRING:
            if not isinstance(value, str):
                raise ParameterFault(ErrorNumber.WRONG_TYPE, f"{value!r} is not a text")
            if len(value) > self.length or not is_visible(value):
                raise ParameterFault(
                    ErrorNumber.LIMIT_EXCEEDED,
                    f"text must be at most {self.length} visible ASCII characters",
                )
            return value.ljust(self.length)
        if not isinstance(value, bytes | bytearray):
            raise ParameterFault(ErrorNumber.WRONG_TYPE, f"{value!r} is not a byte string")
        if len(value) > self.length:
            raise ParameterFault(ErrorNumber.LIMIT_EXCEEDED, f"at most {self.length} bytes")
        return bytes(value).ljust(self.length, b"\0")

    def check_write(self, value: object) -> Value:
        """Coerce ``value`` and apply the rules for a write: reset-only, allowed set, limits."""
        checked = self.coerce(value)
        if self.reset_only and checked != 0:
            raise ParameterFault(
                ErrorNumber.SET_NOT_ALLOWED, f"may only be reset to 0, not {value!r}"
            )
        if self.allowed is not None and checked not in self.allowed:
            choices = ", ".join(str(v) for v in self.allowed)
            raise ParameterFault(ErrorNumber.LIMIT_EXCEEDED, f"{checked!r} is not one of {choices}")
        if isinstance(checked, int | float) and not self.low <= checked <= self.high:
            raise ParameterFault(
                ErrorNumber.LIMIT_EXCEEDED, f"{checked!r} is outside {self.low}..{self.high}"
            )
        return checked

    def __repr__(self) -> str:
        shape = "" if self.array is None else f"[{self.array}]"
        return f"<Parameter P{self.pnu} {self.name!r} {self.dtype.label}{shape}>"


@dataclass(frozen=True, slots=True)
class ProfileInfo:
    """The ``[profile]`` table: what the file describes and how the device counts."""

    name: str
    title: str = ""
    follows: str = ""
    """The document sections the file follows (docs/references.md)."""
    manual: str = ""
    """The manuals (title and edition) the file's facts come from."""
    source: str = ""
    """The file (or files, base first) the database was read from."""
    index_base: int = 1
    description: DescriptionStyle = DescriptionStyle.PROFIBUS
    description_term: str = ""
    """What the family's manuals call the parameter description a drive sends for request
    ID 4 (the SINAMICS manuals: "descriptive element"); "": the specification's "parameter
    description" (C 6)."""
    text_write: bool = False
    """Texts may be changed with request ID 15 (C Table 4.1 note 3: SIMOVERT MASTERDRIVES)."""
    max_pnu: int = 2047
    access_level: ParamRef | None = None
    """The parameter whose value unlocks protected parameters (the "keyword")."""
    protected_level: int = 1
    write_enable: ParamRef | None = None
    """A parameter whose bit ``write_enable_bit`` must be 1 for any interface but the drive's
    own to change parameters (Baumueller 126 "source de communication", Baumueller manual 1.5)."""
    write_enable_bit: int = 0
    names: NameStyle = NameStyle.PROJECT
    """How the family's documents write parameter numbers (``P21`` or ``r0021``/``P1120``)."""
    response_delay_ms: float | None = None
    """The response delay the family's manual gives, in ms (SINAMICS V20 10/2019: 20 ms):
    what a simulated drive answers after when asked to answer as its manual says
    (`pyuss.slave.SlaveEngine.manual_delay`); None: the manual gives none."""
    edition: str = ""
    """The manual edition the database follows: the file's own (``[profile] edition``) or
    the one chosen from its ``[editions]`` ("" for a file without editions)."""
    editions: tuple[str, ...] = ()
    """Every edition the file knows: its own first, then those of ``[editions]``."""


@dataclass(frozen=True, slots=True)
class Commissioning:
    """The ``[commissioning]`` table: the rule of a drive's commissioning parameter (Siemens
    P0010) and of its end (P3900), the drive's own rule, carried out by `SimulatedDrive`:

    - while ``parameter`` is not 0 the drive is in commissioning: it does not switch on, a
      parameter whose ``changeable`` letters hold C can be changed, one without C cannot
      (error 17); the ``commissioning`` state code is shown;
    - writing a value other than 0 to ``end`` (only possible in commissioning, its
      ``changeable`` is C) ends the quick commissioning: the motor data are calculated (pole
      pairs = round(60 x ``rated_frequency`` / ``rated_speed``) into ``pole_pairs``), then
      ``end`` and ``parameter`` go back to 0;
    - writing 1 to ``reset`` while ``parameter`` is ``factory`` restores the factory value of
      every parameter but those in ``keep_on_reset`` and clears the EEPROM store of them;
      ``reset`` and ``parameter`` go back to 0.
    """

    parameter: int
    quick: int = 1
    factory: int | None = None
    end: int | None = None
    reset: int | None = None
    keep_on_reset: tuple[int, ...] = ()
    rated_frequency: ParamRef | None = None
    rated_speed: ParamRef | None = None
    pole_pairs: ParamRef | None = None
    """The motor data (PNU or [PNU, index]: a drive with data sets calculates the first)."""


@dataclass(frozen=True, slots=True)
class WordBits:
    """The ``[words]`` table: control and status word bits beyond the specification's (C Tables
    5.4, 5.5), as the family uses them; `SimulatedDrive` applies them.

    ``reverse``: control bit that inverts the setpoint (MICROMASTER 4 / SINAMICS bit 11).
    ``status_ones``: status bits shown as 1 while their (low-active) warning is absent.
    ``direction``: status bit that is 1 while the motor turns right (positive), 0 left.
    ``jog_switches_on``: jog bits 8/9 switch the drive on from "ready to switch on" (ON/OFF1 =
    0) and off again when they drop, and are not acted on while it is switched on (MICROMASTER
    4, SINAMICS); false: the USS specification's jog from standstill with operation enabled
    (C Table 5.4). See `pyuss.drive.states`.
    """

    reverse: int | None = None
    status_ones: tuple[int, ...] = ()
    direction: int | None = None
    jog_switches_on: bool = False


@dataclass(frozen=True, slots=True)
class Source:
    """One source parameter of ``[sources]``: the parameter (element) that selects where the
    drive takes its commands or setpoint from, and the value that means USS."""

    ref: ParamRef
    uss: int


@dataclass(frozen=True, slots=True)
class Sources:
    """The ``[sources]`` table: the parameters that decide whether the drive follows the
    control word (``command``, Siemens P0700) and the main setpoint (``setpoint``, P1000) of
    USS, each with the value that means USS (``command_uss``, ``setpoint_uss``). While a
    source parameter holds another value `SimulatedDrive` ignores that part of the process
    data; the names of the other values are the parameter's value texts. None: the family
    has no such parameter, USS always counts."""

    command: Source | None = None
    setpoint: Source | None = None

    def get(self, kind: str) -> Source | None:
        """The source of ``kind`` (one of `SOURCE_KINDS`)."""
        found: Source | None = getattr(self, kind)
        return found

    def __iter__(self) -> Iterator[tuple[str, Source]]:
        for kind in SOURCE_KINDS:
            source = self.get(kind)
            if source is not None:
                yield kind, source


class ParameterDatabase:
    """The validated parameters of one profile, with the roles the simulation reads."""

    def __init__(
        self,
        profile: ProfileInfo,
        parameters: Mapping[int, Parameter],
        *,
        roles: Mapping[str, ParamRef] | None = None,
        interface: Mapping[str, ParamRef] | None = None,
        state_codes: Mapping[str, int] | None = None,
        faults: Mapping[str, int] | None = None,
        fault_texts: Mapping[int, str] | None = None,
        warning_texts: Mapping[int, str] | None = None,
        process_setpoints: Sequence[int] = (),
        process_actuals: Sequence[int] = (),
        commissioning: Commissioning | None = None,
        words: WordBits | None = None,
        hints: Mapping[int | str, str] | None = None,
        sources: Sources | None = None,
    ) -> None:
        self.profile = profile
        self.commissioning = commissioning
        self.words = words or WordBits()
        self.sources = sources or Sources()
        """Where the drive takes commands and setpoint from (``[sources]``)."""
        self._parameters = dict(sorted(parameters.items()))
        self.roles: Mapping[str, ParamRef] = dict(roles or {})
        self.interface: Mapping[str, ParamRef] = dict(interface or {})
        self.state_codes: Mapping[str, int] = dict(state_codes or {})
        self.faults: Mapping[str, int] = dict(faults or {})
        self.fault_texts: Mapping[int, str] = dict(fault_texts or {})
        """The family's fault numbers, as its fault display shows them, and short texts."""
        self.warning_texts: Mapping[int, str] = dict(warning_texts or {})
        """The family's warning numbers and short texts."""
        self.process_setpoints = tuple(process_setpoints)
        self.process_actuals = tuple(process_actuals)
        self.hints: Mapping[int | str, str] = dict(hints or {})
        """What to do when the drive refuses, in the family's words (``[hints]``): by error
        number of response 7, and ``no_authority`` for response 8."""

    def __contains__(self, pnu: object) -> bool:
        return pnu in self._parameters

    def __iter__(self) -> Iterator[Parameter]:
        return iter(self._parameters.values())

    def __len__(self) -> int:
        return len(self._parameters)

    def label(self, pnu: int, index: int | None = None) -> str:
        """``pnu`` (element ``index``) as the family's documents write it: ``r0021``,
        ``P1120``, NORD ``P102``; a number the file does not know with a ``P``."""
        found = self._parameters.get(pnu)
        read_only = found is not None and found.access is Access.RO
        return param_name(pnu, index, style=self.profile.names, read_only=read_only)

    def parameter(self, pnu: int) -> Parameter:
        """The parameter numbered ``pnu``; error 0 "illegal PNU" if there is none."""
        try:
            return self._parameters[pnu]
        except KeyError:
            raise ParameterFault(ErrorNumber.ILLEGAL_PNU, "no such parameter", pnu=pnu) from None

    def baud_codes(self) -> Mapping[int, int] | None:
        """How the ``baud`` interface parameter holds the rate: a table code -> baud (C 3.1:
        1 = 300 ... 10 = 187500; MICROMASTER 4 P2010 has its own codes), or None where the value
        is the rate itself (unit Baud, Baumueller 182). See `baud_codes`."""
        ref = self.interface.get("baud")
        return None if ref is None else baud_codes(self.parameter(ref.pnu))

    def position(self, param: Parameter, index: int | None) -> int:
        """The element an IND addresses: 0 for a scalar without index, else ``index - base``.

        Refuses an index on a scalar (error 4), a missing or out-of-range index on an array
        (error 3).
        """
        if param.array is None:
            if index is not None:
                raise ParameterFault(
                    ErrorNumber.NOT_ARRAY, "parameter is not an array", pnu=param.pnu, index=index
                )
            return 0
        if index is None:
            raise ParameterFault(
                ErrorNumber.BAD_INDEX, "array parameter needs an index", pnu=param.pnu
            )
        base = self.profile.index_base
        if not base <= index < base + param.array:
            raise ParameterFault(
                ErrorNumber.BAD_INDEX,
                f"index {index} outside {base}..{base + param.array - 1}",
                pnu=param.pnu,
                index=index,
            )
        return index - base


def baud_codes(param: Parameter) -> Mapping[int, int] | None:
    """The baud rates a baud rate parameter's values stand for: None when its unit is a baud
    unit (`BAUD_UNITS`: the value is the rate), else code -> rate from its value texts
    ("9600 BAUD", "19.2 kBaud"); texts naming no rate are left out. `ConfigError` when neither
    tells a rate."""
    if param.unit.lower() in BAUD_UNITS:
        return None
    codes: dict[int, int] = {}
    for code, text in param.texts.items():
        match = _BAUD_TEXT.match(text)
        if match is not None:
            number = float(match.group(1).replace(",", "."))
            codes[code] = round(number * (1000 if match.group(2) else 1))
    if not codes:
        raise ConfigError(
            f"P{param.pnu} holds no baud rate: give it the unit Baud (its value is the rate) "
            'or value texts naming the rates ({ 6 = "9600 BAUD", ... })'
        )
    return codes


# --------------------------------------------------------------------------------------------
# loading


BUILTIN_PACKAGE = "pyuss.profiles"


def builtin_profiles() -> tuple[str, ...]:
    """Names of the profile data files shipped with pyuss (files whose name begins with ``_``
    are shared bases that other files extend, not profiles)."""
    return tuple(name for name in _builtin_files() if not name.startswith("_"))


def _builtin_files() -> tuple[str, ...]:
    from importlib import resources  # here: a command that reads no file starts sooner

    folder = resources.files(BUILTIN_PACKAGE).joinpath("data")
    return tuple(
        sorted(p.name.removesuffix(".toml") for p in folder.iterdir() if p.name.endswith(".toml"))
    )


EDITION_MARK = "@"
"""What joins a profile's name and an edition of its manual: ``sinamics-v20@2012``."""


def split_edition(name: str) -> tuple[str, str | None]:
    """``(profile, edition)`` of ``NAME@EDITION`` (edition None without the mark);
    `ConfigError` for an empty part."""
    if EDITION_MARK not in name:
        return name, None
    base, _, edition = name.partition(EDITION_MARK)
    if not base or not edition:
        raise ConfigError(f"profile {name!r}: write NAME{EDITION_MARK}EDITION, both parts given")
    return base, edition


def load_profile(name: str) -> ParameterDatabase:
    """The parameter database of a built-in profile (``generic``, ``6se21``, ...);
    ``NAME@EDITION`` chooses an edition of its manual (``sinamics-v20@2012``, the file's
    ``[editions]``)."""
    base, edition = split_edition(name)
    if base not in builtin_profiles():
        known = ", ".join(builtin_profiles())
        raise ConfigError(f"unknown profile {base!r} (known: {known})")
    return _build(_read_layers(f"builtin:{base}", ()), edition)


def load_database(path: str | Path, edition: str | None = None) -> ParameterDatabase:
    """Read and validate a parameter file; ``extends`` in ``[profile]`` builds on another;
    ``edition`` chooses one of its ``[editions]``."""
    return _build(_read_layers(str(Path(path)), ()), edition)


def parse_database(
    text: str, source: str = "<text>", edition: str | None = None
) -> ParameterDatabase:
    """Validate parameter-file text (``extends`` may name built-in profiles only);
    ``edition`` chooses one of its ``[editions]``."""
    return _build(_with_bases(None, source, parse_toml(text, source), ()), edition)


def _read_source(ref: str) -> tuple[str, str]:
    """(name for messages, text) of a file or ``builtin:NAME``."""
    if ref.startswith("builtin:"):
        name = ref.removeprefix("builtin:")
        if name not in _builtin_files():
            raise ConfigError(f"unknown profile {name!r} (known: {', '.join(builtin_profiles())})")
        from importlib import resources

        res = resources.files(BUILTIN_PACKAGE).joinpath("data", f"{name}.toml")
        return f"profile {name} ({name}.toml)", res.read_text(encoding="utf-8")
    return ref, read_text(ref, "parameter file")


def _read_layers(ref: str, seen: tuple[str, ...]) -> list[tuple[str, dict[str, Any]]]:
    """The file ``ref`` and the files it extends, base first."""
    if ref in seen:
        raise ConfigError(f"{ref}: 'extends' forms a cycle: {' -> '.join((*seen, ref))}")
    name, text = _read_source(ref)
    return _with_bases(ref, name, parse_toml(text, name), seen)


def _with_bases(
    ref: str | None, name: str, data: dict[str, Any], seen: tuple[str, ...]
) -> list[tuple[str, dict[str, Any]]]:
    """The layers of ``data`` (read from the file ``ref``, None for text given directly):
    the ones it extends, base first, then itself."""
    profile = data.get("profile", {})
    base = profile.get("extends") if isinstance(profile, dict) else None
    if base is None:
        return [(name, data)]
    if not isinstance(base, str) or not base:
        raise ConfigError(f"{name}: [profile] field 'extends': must be a profile name or a path")
    if "/" in base or base.endswith(".toml"):
        if ref is None or ref.startswith("builtin:"):
            what = "a built-in profile" if ref is not None else "parameter text"
            raise ConfigError(f"{name}: {what} can only extend built-in profiles")
        base_ref = str((Path(ref).parent / base).resolve())
    elif base not in _builtin_files():
        known = ", ".join(builtin_profiles())
        raise ConfigError(
            f"{name}: [profile] field 'extends': unknown profile {base!r} (known: {known}; "
            "or a path to a .toml file)"
        )
    else:
        base_ref = f"builtin:{base}"
    return [*_read_layers(base_ref, (*seen, ref or name)), (name, data)]


_TOP_KEYS = {
    "profile",
    "parameter",
    "drive",
    "interface",
    "state_codes",
    "faults",
    "fault_texts",
    "warning_texts",
    "process",
    "commissioning",
    "words",
    "hints",
    "sources",
    "editions",
}
_EDITION_KEYS = {"manual", "remove", "parameter"}
_PROFILE_KEYS = {
    "name",
    "title",
    "follows",
    "seed",  # the older name of "follows"
    "manual",
    "extends",
    "index_base",
    "description",
    "description_term",
    "text_write",
    "max_pnu",
    "access_level",
    "protected_level",
    "write_enable",
    "write_enable_bit",
    "names",
    "remove",
    "response_delay_ms",
    "edition",
}
_PARAM_KEYS = {
    "pnu",
    "name",
    "type",
    "array",
    "length",
    "default",
    "min",
    "max",
    "allowed",
    "access",
    "active",
    "unit",
    "scaling",
    "decimals",
    "format",
    "command",
    "store",
    "reset_only",
    "stopped_only",
    "texts",
    "index_texts",
    "bit_texts",
    "level",
    "changeable",
    "bico",
    "macro",
    "doc",
    "follows",
    "seed",  # the older name of "follows"
}


class _Where:
    """Builds error messages that name file, parameter and field."""

    def __init__(self, source: str, what: str = "") -> None:
        self.source = source
        self.what = what

    def error(self, field_name: str, problem: str) -> ConfigError:
        where = f"{self.source}: {self.what}" if self.what else f"{self.source}:"
        return ConfigError(f"{where} field {field_name!r}: {problem}")


def _build(
    layers: list[tuple[str, dict[str, Any]]], edition: str | None = None
) -> ParameterDatabase:
    profile_data: dict[str, Any] = {}
    raw_params: dict[int, tuple[str, dict[str, Any]]] = {}
    tables: dict[str, dict[str, Any]] = {
        "drive": {},
        "interface": {},
        "state_codes": {},
        "faults": {},
        "fault_texts": {},
        "warning_texts": {},
        "process": {},
        "commissioning": {},
        "words": {},
        "hints": {},
        "sources": {},
    }
    for source, data in layers:
        unknown = set(data) - _TOP_KEYS
        if unknown:
            raise ConfigError(f"{source}: unknown table(s) {', '.join(sorted(unknown))}")
        prof = data.get("profile", {})
        if not isinstance(prof, dict):
            raise ConfigError(f"{source}: [profile] must be a table")
        extra = set(prof) - _PROFILE_KEYS
        if extra:
            raise ConfigError(f"{source}: [profile] unknown field(s) {', '.join(sorted(extra))}")
        for removed in _int_list(prof.get("remove", []), _Where(source, "[profile]"), "remove"):
            raw_params.pop(removed, None)
        profile_data.update(
            {k: v for k, v in prof.items() if k not in ("extends", "remove", "edition")}
        )
        for key, table in tables.items():
            value = data.get(key, {})
            if not isinstance(value, dict):
                raise ConfigError(f"{source}: [{key}] must be a table")
            table.update(value)
        params = data.get("parameter", [])
        if not isinstance(params, list):
            raise ConfigError(f"{source}: 'parameter' must be an array of tables ([[parameter]])")
        seen: set[int] = set()
        for number, entry in enumerate(params, start=1):
            if not isinstance(entry, dict):
                raise ConfigError(f"{source}: parameter entry {number} is not a table")
            pnu = entry.get("pnu")
            if isinstance(pnu, bool) or not isinstance(pnu, int):
                raise ConfigError(f"{source}: parameter entry {number}: field 'pnu' missing")
            if pnu in seen:
                raise ConfigError(f"{source}: parameter {pnu} is defined twice")
            seen.add(pnu)
            raw_params[pnu] = (source, entry)
    top_source, top = layers[-1]
    own = top.get("profile", {}).get("edition")
    if own is not None:
        if not isinstance(own, str) or not own or EDITION_MARK in own:
            raise _Where(top_source, "[profile]").error(
                "edition", f"must be a non-empty text without {EDITION_MARK}"
            )
        profile_data["edition"] = own
    editions = _editions(top.get("editions", {}), profile_data, top_source)
    profile_data["editions"] = (profile_data.get("edition", ""), *editions)
    if edition is not None:
        _apply_edition(edition, editions, profile_data, raw_params, top_source)
    else:
        profile_data["chosen"] = profile_data.get("edition", "")
    sources = " + ".join(source for source, _ in layers)
    profile = _profile(profile_data, top_source, sources)
    parameters = {
        pnu: _parameter(entry, _Where(source, f"parameter {pnu}:"), profile)
        for pnu, (source, entry) in raw_params.items()
    }
    db = ParameterDatabase(
        profile,
        parameters,
        roles=_refs(tables["drive"], "drive", ROLES, sources),
        interface=_refs(tables["interface"], "interface", INTERFACE_ROLES, sources),
        state_codes=_codes(tables["state_codes"], "state_codes", STATE_CODE_NAMES, sources),
        faults=_codes(tables["faults"], "faults", None, sources),
        fault_texts=_number_texts(tables["fault_texts"], "fault_texts", sources),
        warning_texts=_number_texts(tables["warning_texts"], "warning_texts", sources),
        process_setpoints=_process(tables["process"], "setpoints", sources, parameters),
        process_actuals=_process(tables["process"], "actuals", sources, parameters),
        commissioning=_commissioning(tables["commissioning"], sources, parameters),
        words=_words(tables["words"], sources),
        hints=_hints(tables["hints"], sources),
        sources=_sources(tables["sources"], sources, parameters, profile),
    )
    for name in ("access_level", "write_enable"):
        ref = getattr(profile, name)
        if ref is not None:
            _check_ref(ref, parameters, profile, _Where(sources, "[profile]"), name)
    _check_roles(db, sources)
    if db.commissioning is not None:
        where = _Where(sources, "[commissioning]")
        for key in ("rated_frequency", "rated_speed", "pole_pairs"):
            ref = getattr(db.commissioning, key)
            if ref is not None:
                _check_ref(ref, parameters, profile, where, key)
    return db


def _editions(
    value: object, profile_data: dict[str, Any], source: str
) -> dict[str, dict[str, Any]]:
    """The ``[editions]`` of the file itself, their form checked (the values are checked as
    parameters when an edition is chosen)."""
    if not isinstance(value, dict):
        raise ConfigError(f"{source}: [editions] must be a table of editions")
    own = profile_data.get("edition")
    if value and (not isinstance(own, str) or not own):
        raise ConfigError(
            f"{source}: [profile] field 'edition': required with [editions], the edition the "
            "file's own values follow"
        )
    out: dict[str, dict[str, Any]] = {}
    for name, table in value.items():
        where = f"{source}: [editions.{name}]"
        if name == own or EDITION_MARK in name:
            raise ConfigError(f"{where}: the name is the file's own edition or has {EDITION_MARK}")
        if not isinstance(table, dict):
            raise ConfigError(f"{where}: must be a table")
        extra = set(table) - _EDITION_KEYS
        if extra:
            raise ConfigError(f"{where}: unknown field(s) {', '.join(sorted(extra))}")
        if not isinstance(table.get("manual"), str) or not table["manual"]:
            raise ConfigError(f"{where}: field 'manual': required, the manual and its edition")
        _int_list(table.get("remove", []), _Where(where), "remove")
        changes = table.get("parameter", [])
        if not isinstance(changes, list) or not all(isinstance(c, dict) for c in changes):
            raise ConfigError(f"{where}: 'parameter' must be an array of tables")
        for change in changes:
            pnu = change.get("pnu")
            if isinstance(pnu, bool) or not isinstance(pnu, int):
                raise ConfigError(f"{where}: a parameter change without 'pnu'")
            extra = set(change) - _PARAM_KEYS
            if extra:
                raise ConfigError(f"{where}: parameter {pnu}: unknown field(s) {sorted(extra)}")
        out[name] = table
    return out


def _apply_edition(
    edition: str,
    editions: dict[str, dict[str, Any]],
    profile_data: dict[str, Any],
    raw_params: dict[int, tuple[str, dict[str, Any]]],
    source: str,
) -> None:
    """Change ``raw_params`` and ``profile_data`` to ``edition``: its ``remove`` drops
    parameters, each of its ``[[parameter]]`` tables replaces the fields it names."""
    own = profile_data.get("edition", "")
    known = ", ".join(e for e in (own, *editions) if e) or "none"
    if edition != own and edition not in editions:
        raise ConfigError(f"{source}: unknown edition {edition!r} (known: {known})")
    profile_data["chosen"] = edition
    if edition == own:
        return
    table = editions[edition]
    where = f"{source}: [editions.{edition}]"
    profile_data["manual"] = table["manual"]
    for pnu in table.get("remove", []):
        if raw_params.pop(pnu, None) is None:
            raise ConfigError(f"{where}: remove: the file has no parameter {pnu}")
    for change in table.get("parameter", []):
        pnu = change["pnu"]
        if pnu not in raw_params:
            raise ConfigError(f"{where}: parameter {pnu}: the file has no such parameter")
        base_source, entry = raw_params[pnu]
        raw_params[pnu] = (f"{base_source} edition {edition}", {**entry, **change})


def _profile(data: dict[str, Any], source: str, sources: str) -> ProfileInfo:
    where = _Where(source, "[profile]")
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise where.error("name", "required, a non-empty text")
    index_base = data.get("index_base", 1)
    if index_base not in (0, 1) or isinstance(index_base, bool):
        raise where.error("index_base", "must be 0 or 1")
    description = _choice(
        DescriptionStyle, data.get("description", "profibus"), where, "description"
    )
    max_pnu = data.get("max_pnu", 2047)
    if isinstance(max_pnu, bool) or not isinstance(max_pnu, int) or not 0 < max_pnu <= 65535:
        raise where.error("max_pnu", "must be an integer 1..65535")
    level = data.get("access_level")
    level_ref = None if level is None else _ref(level, where, "access_level")
    enable = data.get("write_enable")
    enable_ref = None if enable is None else _ref(enable, where, "write_enable")
    enable_bit = data.get("write_enable_bit", 0)
    if isinstance(enable_bit, bool) or enable_bit not in range(32):
        raise where.error("write_enable_bit", "must be a bit number 0..31")
    protected_level = data.get("protected_level", 1)
    if isinstance(protected_level, bool) or not isinstance(protected_level, int):
        raise where.error("protected_level", "must be an integer")
    delay = data.get("response_delay_ms")
    if delay is not None and (
        isinstance(delay, bool) or not isinstance(delay, int | float) or not 0 <= delay <= 1000
    ):
        raise where.error("response_delay_ms", "must be a number of milliseconds 0..1000")
    return ProfileInfo(
        name=name,
        title=_text(data.get("title", ""), where, "title"),
        follows=_text(data.get("follows", data.get("seed", "")), where, "follows"),
        manual=_text(data.get("manual", ""), where, "manual"),
        source=sources,
        index_base=index_base,
        description=description,
        description_term=_text(data.get("description_term", ""), where, "description_term"),
        text_write=_flag(data.get("text_write", False), where, "text_write"),
        max_pnu=max_pnu,
        access_level=level_ref,
        write_enable=enable_ref,
        write_enable_bit=enable_bit,
        protected_level=protected_level,
        names=_choice(NameStyle, data.get("names", "pyuss"), where, "names"),
        response_delay_ms=None if delay is None else float(delay),
        edition=_text(data.get("chosen", ""), where, "edition"),
        editions=tuple(e for e in data.get("editions", ()) if e),
    )


_E = TypeVar("_E", Access, DescriptionStyle, NameStyle)


def _choice(kind: type[_E], value: object, where: _Where, name: str) -> _E:
    """``value`` as a member of the enumeration ``kind`` (given by its value in the file)."""
    for member in kind:
        if member.value == value:
            return member
    raise where.error(name, "must be one of " + ", ".join(repr(m.value) for m in kind))


def _text(value: object, where: _Where, name: str) -> str:
    if not isinstance(value, str):
        raise where.error(name, "must be a text")
    return value


def _flag(value: object, where: _Where, name: str) -> bool:
    if not isinstance(value, bool):
        raise where.error(name, "must be true or false")
    return value


def _int_list(value: object, where: _Where, name: str) -> list[int]:
    if not isinstance(value, list) or not all(
        isinstance(v, int) and not isinstance(v, bool) for v in value
    ):
        raise where.error(name, "must be a list of integers")
    return list(value)


def _ref(value: object, where: _Where, name: str) -> ParamRef:
    if isinstance(value, int) and not isinstance(value, bool):
        return ParamRef(value)
    if (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
    ):
        return ParamRef(value[0], value[1])
    raise where.error(name, "must be a PNU or [PNU, index]")


def _check_ref(
    ref: ParamRef,
    parameters: Mapping[int, Parameter],
    profile: ProfileInfo,
    where: _Where,
    name: str,
) -> Parameter:
    label = name
    param = parameters.get(ref.pnu)
    if param is None:
        raise where.error(label, f"refers to P{ref.pnu}, which is not defined")
    if param.array is None and ref.index is not None:
        raise where.error(label, f"P{ref.pnu} is not an array, it takes no index")
    if param.array is not None:
        base = profile.index_base
        if ref.index is None or not base <= ref.index < base + param.array:
            raise where.error(
                label, f"P{ref.pnu} is an array: give [PNU, index] with a valid index"
            )
    if not param.dtype.is_integer and param.dtype is not DataType.FLOAT:
        raise where.error(label, f"P{ref.pnu} must hold a number")
    return param


def _refs(
    table: dict[str, Any],
    table_name: str,
    known: Sequence[str],
    source: str,
) -> dict[str, ParamRef]:
    where = _Where(source, f"[{table_name}]")
    result = {}
    for key, value in table.items():
        if key not in known:
            raise where.error(key, f"unknown; known are {', '.join(known)}")
        result[key] = _ref(value, where, key)
    return result


def _codes(
    table: dict[str, Any], table_name: str, known: Sequence[str] | None, source: str
) -> dict[str, int]:
    where = _Where(source, f"[{table_name}]")
    result = {}
    for key, value in table.items():
        if known is not None and key not in known:
            raise where.error(key, f"unknown; known are {', '.join(known)}")
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF:
            raise where.error(key, "must be an integer 0..65535")
        result[key] = value
    return result


def _number_texts(table: dict[str, Any], table_name: str, source: str) -> dict[int, str]:
    """A table of numbers and their texts (``[fault_texts]``: ``72 = "..."``); an empty text
    drops a number an extended file gave."""
    where = _Where(source, f"[{table_name}]")
    result = {}
    for key, value in table.items():
        if not key.isdigit() or not 0 <= int(key) <= 0xFFFF:
            raise where.error(key, "must be a number 0..65535")
        if not isinstance(value, str):
            raise where.error(key, "must be a text")
        if value:
            result[int(key)] = value
    return dict(sorted(result.items()))


HINT_KEYS = ("no_authority",)
"""The named entries of ``[hints]`` beside the error numbers: ``no_authority`` (response 8)."""


def _hints(table: dict[str, Any], source: str) -> dict[int | str, str]:
    """``[hints]``: error numbers of response 7 and ``no_authority`` with what to do."""
    named = {key: table.pop(key) for key in HINT_KEYS if key in table}
    found: dict[int | str, str] = {
        number: text for number, text in _number_texts(table, "hints", source).items()
    }
    for key, value in named.items():
        if not isinstance(value, str):
            raise _Where(source, "[hints]").error(key, "must be a text")
        if value:
            found[key] = value
    return found


def _process(
    table: dict[str, Any], key: str, source: str, parameters: Mapping[int, Parameter]
) -> tuple[int, ...]:
    where = _Where(source, "[process]")
    extra = set(table) - {"setpoints", "actuals"}
    if extra:
        raise where.error(sorted(extra)[0], "unknown; known are setpoints, actuals")
    pnus = _int_list(table.get(key, []), where, key)
    if len(pnus) > 14:
        raise where.error(key, "at most 14 entries (PZD3..PZD16)")
    for pnu in pnus:
        if pnu == 0:
            continue  # a gap: that PZD word is not used
        param = parameters.get(pnu)
        if param is None:
            raise where.error(key, f"refers to P{pnu}, which is not defined")
        if param.is_array or param.word_count != 1 or not param.dtype.is_integer:
            raise where.error(key, f"P{pnu} must be a 16-bit (or 8-bit) scalar")
    return tuple(pnus)


def _check_roles(db: ParameterDatabase, source: str) -> None:
    where = _Where(source, "[drive]")
    parameters = {p.pnu: p for p in db}
    for name, ref in db.roles.items():
        param = _check_ref(ref, parameters, db.profile, where, name)
        unit = param.unit
        if name in TIME_ROLES and unit not in TIME_UNITS:
            raise where.error(name, f"P{ref.pnu} must have a time unit (s, ms, min), not {unit!r}")
        if name in (*LEVEL_ROLES, "setpoint", "actual"):
            ref_unit = _reference_unit(db)
            if unit not in ("%", "") and unit != ref_unit:
                raise where.error(
                    name,
                    f"P{ref.pnu} unit {unit!r} needs a 'reference' parameter with that unit "
                    "(or use %, or no unit for 4000h = 100 %)",
                )
        if name in MOTOR_UNITS and unit != MOTOR_UNITS[name]:
            raise where.error(
                name, f"P{ref.pnu} must have the unit {MOTOR_UNITS[name]}, not {unit!r}"
            )
        if (
            name in ("state", "fault", "warning", "control_word", "status_word")
            and not param.dtype.is_integer
        ):
            raise where.error(name, f"P{ref.pnu} must be an integer parameter")
    for name, ref in db.interface.items():
        where = _Where(source, "[interface]")
        param = _check_ref(ref, parameters, db.profile, where, name)
        if name == "baud":
            try:
                baud_codes(param)
            except ConfigError as exc:
                raise where.error(name, str(exc)) from None
        if name == "failure_time" and param.unit and param.unit not in TIME_UNITS:
            raise where.error(
                name, f"P{ref.pnu} must have a time unit (s, ms, min; none: s), not {param.unit!r}"
            )


def _reference_unit(db: ParameterDatabase) -> str | None:
    ref = db.roles.get("reference")
    return None if ref is None else db.parameter(ref.pnu).unit


def _parameter(entry: dict[str, Any], where: _Where, profile: ProfileInfo) -> Parameter:
    extra = set(entry) - _PARAM_KEYS
    if extra:
        raise where.error(sorted(extra)[0], f"unknown; known are {', '.join(sorted(_PARAM_KEYS))}")
    pnu = entry["pnu"]
    if not 0 <= pnu <= profile.max_pnu:
        raise where.error("pnu", f"must be 0..{profile.max_pnu} in this profile")
    name = entry.get("name")
    if not isinstance(name, str) or not name:
        raise where.error("name", "required, a non-empty text")
    if len(name) > TEXT_LENGTH or not is_visible(name):
        raise where.error("name", f"at most {TEXT_LENGTH} visible ASCII characters (PBE element 6)")
    type_name = entry.get("type")
    if not isinstance(type_name, str) or type_name not in TYPE_NAMES:
        raise where.error("type", f"required, one of {', '.join(TYPE_NAMES)}")
    dtype = TYPE_NAMES[type_name]

    array = entry.get("array")
    if array is not None and (
        isinstance(array, bool) or not isinstance(array, int) or not 1 <= array <= MAX_ARRAY
    ):
        raise where.error("array", f"must be a number of elements 1..{MAX_ARRAY}")
    length = entry.get("length", 0)
    if dtype.is_string:
        if isinstance(length, bool) or not isinstance(length, int):
            raise where.error("length", "must be an integer")
        if not 1 <= length <= MAX_STRING:
            raise where.error("length", f"a string parameter needs a length 1..{MAX_STRING}")
    elif "length" in entry:
        raise where.error("length", "only string types have a length")

    access = _choice(Access, entry.get("access", "rw"), where, "access")

    numeric = dtype.is_integer or dtype is DataType.FLOAT
    minimum = _limit(entry, "min", dtype, where)
    maximum = _limit(entry, "max", dtype, where)
    if dtype is DataType.V2 or not numeric:
        for key in ("min", "max", "allowed"):
            if key in entry:
                raise where.error(key, f"not applicable to type {dtype.label}")
    if minimum is not None and maximum is not None and minimum > maximum:
        raise where.error("min", f"{minimum} is above max {maximum}")
    allowed = None
    if "allowed" in entry:
        values = _int_list(entry["allowed"], where, "allowed")
        if not values or not dtype.is_integer:
            raise where.error("allowed", "must be a non-empty list of integers")
        allowed = tuple(values)

    unit = _text(entry.get("unit", ""), where, "unit")
    scaling = entry.get("scaling")
    if scaling is not None and (
        isinstance(scaling, bool)
        or not isinstance(scaling, int | float)
        or not math.isfinite(scaling)
        or scaling <= 0
    ):
        raise where.error("scaling", "must be a positive number")
    decimals = entry.get("decimals", _decimals_of(scaling))
    if isinstance(decimals, bool) or not isinstance(decimals, int) or not 0 <= decimals <= 15:
        raise where.error("decimals", "must be 0..15")
    display = _display(entry.get("format"), dtype, where)

    texts = _value_texts(entry, dtype, array, where)
    index_texts = _index_texts(entry, array, where)
    bit_texts = _bit_texts(entry, dtype, array, where)

    bico = _flag(entry.get("bico", False), where, "bico")
    if bico and (dtype is not DataType.UINT32 or {"min", "max", "allowed", "texts"} & set(entry)):
        raise where.error("bico", "a BICO input is a uint32 without min, max, allowed or texts")

    param = Parameter(
        pnu=pnu,
        name=name,
        dtype=dtype,
        default=(),
        array=array,
        length=length if dtype.is_string else 0,
        minimum=minimum,
        maximum=maximum,
        allowed=allowed,
        access=access,
        active=_flag(entry.get("active", False), where, "active"),
        unit=unit,
        scaling=None if scaling is None else float(scaling),
        decimals=decimals,
        display=display,
        command=_flag(entry.get("command", False), where, "command"),
        store=_flag(entry.get("store", True), where, "store"),
        reset_only=_flag(entry.get("reset_only", False), where, "reset_only"),
        stopped_only=_flag(entry.get("stopped_only", False), where, "stopped_only"),
        texts=texts,
        index_texts=index_texts,
        bit_texts=bit_texts,
        level=_level(entry.get("level"), where),
        changeable=_changeable(entry.get("changeable"), where, access),
        bico=bico,
        macro=_flag(entry.get("macro", False), where, "macro"),
        doc=_text(entry.get("doc", ""), where, "doc"),
        follows=_text(entry.get("follows", entry.get("seed", "")), where, "follows"),
    )
    defaults = _defaults(entry, param, where)
    return replace(param, default=defaults)


def _level(value: object, where: _Where) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 4:
        raise where.error("level", "must be an access level 0..4")
    return value


def _changeable(value: object, where: _Where, access: Access) -> str | None:
    if value is None:
        return None
    if (
        not isinstance(value, str)
        or not value
        or any(c not in CHANGEABLE_LETTERS for c in value)
        or len(set(value)) != len(value)
    ):
        raise where.error("changeable", 'must be letters of C, U, T (for example "CT")')
    if access is Access.RO:
        raise where.error("changeable", "a read-only parameter is never changed")
    return "".join(c for c in CHANGEABLE_LETTERS if c in value)


def _commissioning(
    table: dict[str, Any], source: str, parameters: Mapping[int, Parameter]
) -> Commissioning | None:
    if not table:
        return None
    where = _Where(source, "[commissioning]")
    for key in table:
        if key not in COMMISSIONING_KEYS:
            raise where.error(key, f"unknown; known are {', '.join(COMMISSIONING_KEYS)}")
    motor: dict[str, ParamRef | None] = {}
    for key in ("rated_frequency", "rated_speed", "pole_pairs"):
        value = table.get(key)
        if value is None:
            motor[key] = None
            continue
        ref = _ref(value, where, key)
        if ref.pnu not in parameters:
            raise where.error(key, f"refers to P{ref.pnu}, which is not defined")
        motor[key] = ref
    pnus: dict[str, int | None] = {}
    for key in ("parameter", "end", "reset"):
        value = table.get(key)
        if value is None:
            pnus[key] = None
            continue
        if isinstance(value, bool) or not isinstance(value, int):
            raise where.error(key, "must be a PNU")
        param = parameters.get(value)
        if param is None:
            raise where.error(key, f"refers to P{value}, which is not defined")
        if param.is_array or not (param.dtype.is_integer or param.dtype is DataType.FLOAT):
            raise where.error(key, f"P{value} must be a numeric scalar")
        pnus[key] = value
    parameter = pnus["parameter"]
    if parameter is None:
        raise where.error("parameter", "required: the commissioning parameter's PNU")
    values = {}
    for key in ("quick", "factory"):
        value = table.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
            raise where.error(key, "must be an integer value of the commissioning parameter")
        values[key] = value
    keep = tuple(_int_list(table.get("keep_on_reset", []), where, "keep_on_reset"))
    return Commissioning(
        parameter=parameter,
        quick=1 if values["quick"] is None else values["quick"],
        factory=values["factory"],
        end=pnus["end"],
        reset=pnus["reset"],
        keep_on_reset=keep,
        rated_frequency=motor["rated_frequency"],
        rated_speed=motor["rated_speed"],
        pole_pairs=motor["pole_pairs"],
    )


def _words(table: dict[str, Any], source: str) -> WordBits:
    where = _Where(source, "[words]")
    for key in table:
        if key not in WORD_KEYS:
            raise where.error(key, f"unknown; known are {', '.join(WORD_KEYS)}")

    def bit(key: str) -> int | None:
        value = table.get(key)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 15:
            raise where.error(key, "must be a bit number 0..15")
        return value

    ones = _int_list(table.get("status_ones", []), where, "status_ones")
    if any(not 0 <= b <= 15 for b in ones):
        raise where.error("status_ones", "bits are 0..15")
    jog = table.get("jog_switches_on", False)
    if not isinstance(jog, bool):
        raise where.error("jog_switches_on", "must be true or false")
    return WordBits(
        reverse=bit("reverse"),
        status_ones=tuple(ones),
        direction=bit("direction"),
        jog_switches_on=jog,
    )


def _sources(
    table: dict[str, Any],
    source: str,
    parameters: Mapping[int, Parameter],
    profile: ProfileInfo,
) -> Sources:
    where = _Where(source, "[sources]")
    for key in table:
        if key not in SOURCE_KEYS:
            raise where.error(key, f"unknown; known are {', '.join(SOURCE_KEYS)}")
    found: dict[str, Source | None] = {}
    for kind in SOURCE_KINDS:
        value, uss = table.get(kind), table.get(f"{kind}_uss")
        if value is None:
            if uss is not None:
                raise where.error(f"{kind}_uss", f"needs {kind!r}, the parameter it is a value of")
            found[kind] = None
            continue
        ref = _ref(value, where, kind)
        param = _check_ref(ref, parameters, profile, where, kind)
        if uss is None:
            raise where.error(f"{kind}_uss", f"required with {kind!r}: the value meaning USS")
        if param.bico and isinstance(uss, str):
            try:
                uss = param.coerce(uss)
            except ParameterFault as exc:
                raise where.error(f"{kind}_uss", exc.detail) from None
        if isinstance(uss, bool) or not isinstance(uss, int):
            raise where.error(f"{kind}_uss", f"must be an integer value of P{ref.pnu}")
        try:
            param.check_write(uss)
        except ParameterFault as exc:
            raise where.error(
                f"{kind}_uss", f"P{ref.pnu} does not take {uss}: {exc.detail}"
            ) from None
        found[kind] = Source(ref, uss)
    return Sources(command=found["command"], setpoint=found["setpoint"])


def _bico(value: object) -> Bico:
    """A BICO input's value: a `Bico`, its text or its 32-bit value (error 5 for another kind,
    2 for a value that is no source)."""
    if isinstance(value, bool) or not isinstance(value, str | int):
        raise ParameterFault(ErrorNumber.WRONG_TYPE, f"{value!r} is no BICO source (r722.2)")
    try:
        return to_bico(value)
    except BicoError as exc:
        raise ParameterFault(ErrorNumber.LIMIT_EXCEEDED, str(exc)) from None


def _limit(entry: dict[str, Any], key: str, dtype: DataType, where: _Where) -> int | float | None:
    if key not in entry:
        return None
    value = entry[key]
    if dtype is DataType.FLOAT:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise where.error(key, "must be a number")
        if not math.isfinite(value) or abs(value) > dtype.type_range[1]:
            raise where.error(key, "must be a finite single precision number")
        return round_float(float(value))
    if not dtype.is_integer:
        raise where.error(key, f"not applicable to type {dtype.label}")
    if isinstance(value, bool) or not isinstance(value, int):
        raise where.error(key, "must be an integer")
    low, high = dtype.type_range
    if not low <= value <= high:
        raise where.error(key, f"{value} does not fit {dtype.label}")
    return value


def _decimals_of(scaling: object) -> int:
    """Decimal places implied by a scaling of 10^-k (0 for any other scaling)."""
    if isinstance(scaling, int | float) and not isinstance(scaling, bool):
        for places in range(16):
            if math.isclose(scaling, 10.0**-places, rel_tol=1e-9):
                return places
    return 0


def _display(value: object, dtype: DataType, where: _Where) -> DisplayFormat:
    if value is None:
        if dtype.is_string:
            return DisplayFormat.ASCII
        if dtype is DataType.V2:
            return DisplayFormat.HEX
        return DisplayFormat.NORM if dtype is DataType.FLOAT else DisplayFormat.DEC
    if not isinstance(value, str) or value.upper() not in DisplayFormat.__members__:
        names = ", ".join(m.lower() for m in DisplayFormat.__members__)
        raise where.error("format", f"must be one of {names}")
    return DisplayFormat[value.upper()]


def _element_text(text: object, where: _Where, key: str) -> str:
    if not isinstance(text, str) or len(text) > TEXT_LENGTH or not is_visible(text):
        raise where.error(key, f"texts are at most {TEXT_LENGTH} visible ASCII characters")
    return text


def _value_texts(
    entry: dict[str, Any], dtype: DataType, array: int | None, where: _Where
) -> dict[int, str]:
    table = entry.get("texts")
    if table is None:
        return {}
    if not isinstance(table, dict):
        raise where.error("texts", 'must be a table value = "text"')
    if not dtype.is_unsigned or dtype is DataType.V2:
        raise where.error("texts", "value texts exist for unsigned 8/16/32 types (C Table 4.5)")
    low, high = dtype.type_range
    result = {}
    for key, text in table.items():
        try:
            value = int(key, 0)
        except ValueError:
            raise where.error("texts", f"key {key!r} is not an integer value") from None
        if not low <= value <= min(high, 253):
            raise where.error("texts", f"value {value}: text element y = value + 1 must be <= 254")
        result[value] = _element_text(text, where, "texts")
    return dict(sorted(result.items()))


def _index_texts(entry: dict[str, Any], array: int | None, where: _Where) -> tuple[str, ...]:
    texts = entry.get("index_texts")
    if texts is None:
        return ()
    if array is None:
        raise where.error("index_texts", "only an array has index texts")
    if not isinstance(texts, list) or len(texts) > array:
        raise where.error("index_texts", f"must be a list of at most {array} texts")
    return tuple(_element_text(t, where, "index_texts") for t in texts)


def _bit_texts(
    entry: dict[str, Any], dtype: DataType, array: int | None, where: _Where
) -> dict[int, tuple[str, str]]:
    table = entry.get("bit_texts")
    if table is None:
        return {}
    if dtype is not DataType.V2 or array is not None:
        raise where.error("bit_texts", "bit texts exist for a V2 parameter that is not an array")
    if not isinstance(table, dict):
        raise where.error("bit_texts", 'must be a table bit = ["text of 0", "text of 1"]')
    result = {}
    for key, pair in table.items():
        try:
            bit = int(key, 0)
        except ValueError:
            raise where.error("bit_texts", f"key {key!r} is not a bit number") from None
        if not 0 <= bit <= 15:
            raise where.error("bit_texts", f"bit {bit} is not 0..15")
        if not isinstance(pair, list) or len(pair) != 2:
            raise where.error("bit_texts", f"bit {bit}: give two texts, for 0 and for 1")
        result[bit] = (
            _element_text(pair[0], where, "bit_texts"),
            _element_text(pair[1], where, "bit_texts"),
        )
    return dict(sorted(result.items()))


def _defaults(entry: dict[str, Any], param: Parameter, where: _Where) -> tuple[Value, ...]:
    raw = entry.get("default")
    if raw is None:
        zero: Value = (
            ""
            if param.dtype is DataType.VISIBLE_STRING
            else b""
            if param.dtype is DataType.OCTET_STRING
            else 0.0
            if param.dtype is DataType.FLOAT
            else 0
        )
        if isinstance(zero, int | float) and param.writable:
            zero = min(max(zero, param.low), param.high)
            if param.allowed is not None and zero not in param.allowed:
                zero = param.allowed[0]
            if param.dtype.is_integer:
                zero = int(zero)
        raw = zero
    if param.dtype is DataType.OCTET_STRING and isinstance(raw, str):
        try:
            raw = bytes.fromhex(raw)
        except ValueError:
            raise where.error("default", 'octets are given as hex text, e.g. "01 A0 FF"') from None
    if isinstance(raw, list) and param.dtype is DataType.OCTET_STRING:
        raise where.error("default", "give octets as hex text (one value for every element)")
    if isinstance(raw, list):
        if param.array is None:
            raise where.error("default", "a list of defaults needs an array parameter")
        if len(raw) != param.array:
            raise where.error("default", f"give {param.array} values or one for all elements")
        values = raw
    else:
        values = [raw] * param.elements
    result = []
    for value in values:
        if param.dtype is DataType.OCTET_STRING and isinstance(value, str):
            value = bytes.fromhex(value)
        try:
            checked = param.check_write(value) if param.writable else param.coerce(value)
        except ParameterFault as exc:
            raise where.error("default", exc.detail) from None
        result.append(checked)
    return tuple(result)
