"""The parameter database of a simulated drive: what one declarative TOML file describes.

One file describes one device profile: the profile's settings (`ProfileInfo`), the parameters
(`Parameter`), which parameters the simulation uses for what (roles: ramp times, jog setpoints,
displays ...), the interface parameters (C 3), the process data mapping, the state codes a state
display shows, the fault codes the drive raises, and the family's commissioning, word bits and
sources (`Commissioning`, `WordBits`, `Sources`). The format is documented in ``docs/drive.md``;
the built-in profiles live in ``pyuss/profiles/data/``. `pyuss.drive.loader` reads the files
(``load_profile``, ``load_database``, ``parse_database``), `pyuss.drive.fields` and
`pyuss.drive.tables` check their fields.

The database is immutable: values live in `SimulatedDrive`.

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
from dataclasses import dataclass, field

from pyuss.drive.datatypes import (
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


def _bico(value: object) -> Bico:
    """A BICO input's value: a `Bico`, its text or its 32-bit value (error 5 for another kind,
    2 for a value that is no source)."""
    if isinstance(value, bool) or not isinstance(value, str | int):
        raise ParameterFault(ErrorNumber.WRONG_TYPE, f"{value!r} is no BICO source (r722.2)")
    try:
        return to_bico(value)
    except BicoError as exc:
        raise ParameterFault(ErrorNumber.LIMIT_EXCEEDED, str(exc)) from None
