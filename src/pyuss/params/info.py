"""`ParamInfo`: what is known of one parameter, whichever source it came from.

One frozen record per parameter number: name, unit, data type (`pyuss.drive.datatypes`),
scaling, array size, access, limits, default, value texts, bit texts, access level and when it
can be changed. It is built from an entry of a parameter file (`from_parameter`, the simulator's
TOML format read by `pyuss.drive.loader`, its entries by `pyuss.drive.fields`, so a key added
there reaches the model through the database) or from a parameter description a drive sent
(`from_description`, C 6).

Numbers in a `ParamInfo` are the drive's own: ``minimum``, ``maximum``, ``allowed`` and
``default`` are raw values as they travel in PWE (as in the parameter file and in description
elements 7 and 8); ``scaling`` turns a raw value into the physical one (physical = raw x
scaling, in ``unit``). `pyuss.params.values` converts between words, raw values, physical
values and text.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

from pyuss.drive.database import Access, NameStyle, Parameter
from pyuss.drive.datatypes import TYPE_NAMES, DataType, Value, shortest_float
from pyuss.params.names import param_name

__all__ = [
    "Access",
    "DescriptionLike",
    "ParamInfo",
    "Source",
    "from_description",
    "from_parameter",
]


class Source(enum.Enum):
    """Where a `ParamInfo` came from, highest trust first."""

    USER = "user"
    """A parameter file the user gave (``--params FILE``)."""
    DRIVE = "drive"
    """The drive's own parameter description, read live (C 6)."""
    PROFILE = "profile"
    """The parameter file shipped with the drive's profile."""


@dataclass(frozen=True, slots=True)
class ParamInfo:
    """What is known of parameter ``pnu`` (see the module docstring)."""

    pnu: int
    name: str
    dtype: DataType
    unit: str = ""
    scaling: float | None = None
    """Physical value = raw value x scaling; None: the raw value is the physical one."""
    decimals: int | None = None
    """Decimal places to show (None: as many as the value needs, at least 2 for a float)."""
    array: int | None = None
    """Number of elements of an array parameter, None for a simple one."""
    length: int = 0
    """Characters or bytes of a string parameter (0 for other types)."""
    access: Access = Access.RW
    minimum: int | float | None = None
    """Lowest raw value a write may set (None: the type's)."""
    maximum: int | float | None = None
    """Highest raw value a write may set (None: the type's)."""
    allowed: tuple[int, ...] | None = None
    """The only raw values a write may set, where the drive has such a list."""
    default: tuple[Value, ...] = ()
    """The factory value of every element (raw; empty when unknown)."""
    texts: Mapping[int, str] = field(default_factory=dict)
    """Value texts: raw value -> text (an enumerated parameter)."""
    bit_texts: Mapping[int, tuple[str, str]] = field(default_factory=dict)
    """Bit texts of a bit field: bit -> (text of 0, text of 1)."""
    index_texts: tuple[str, ...] = ()
    """Texts naming the elements of an array."""
    level: int | None = None
    """The access level a user needs to see or change the parameter (None: not known)."""
    changeable: str | None = None
    """When the parameter can be changed, in the letters of the parameter files (Siemens
    manuals): C in quick commissioning, U while running, T when ready to run (a
    ``stopped_only`` parameter is ``"CT"``); None: not known."""
    active: bool = False
    """A change from elsewhere is reported spontaneously (C 4.2.1.2)."""
    reset_only: bool = False
    """Writes may only reset it to 0."""
    store: bool = True
    """The drive keeps it in EEPROM."""
    bico: bool = False
    """A BICO input (SINAMICS firmware 4): its value is a `pyuss.protocol.bico.Bico`, the
    signal source it reads (``r722.2``)."""
    macro: bool = False
    """A macro of the family: one value sets a group of other parameters (``macro`` in the
    parameter file); the search word ``macro`` finds it (`pyuss.params.ParamBook.search`)."""
    doc: str = ""
    source: Source = Source.PROFILE
    names: NameStyle = NameStyle.PROJECT
    """How the drive's family writes parameter numbers (`label`); not part of `to_dict`."""

    def label(self, index: int | None = None) -> str:
        """The parameter (element) as the family's documents write it: ``r0021``, ``P1120``,
        ``P947.0`` (`pyuss.params.names`)."""
        return param_name(self.pnu, index, style=self.names, read_only=self.read_only)

    # -- shape ---------------------------------------------------------------------------
    @property
    def is_array(self) -> bool:
        return self.array is not None

    @property
    def words(self) -> int:
        """PWE words one value occupies (C 6)."""
        return self.dtype.word_count(self.length)

    @property
    def writable(self) -> bool:
        return self.access is not Access.RO

    @property
    def read_only(self) -> bool:
        return self.access is Access.RO

    @property
    def type_name(self) -> str:
        """The data type as the parameter files name it (``float``, ``uint16``, ``v2``...)."""
        return self.dtype.label

    @property
    def is_numeric(self) -> bool:
        return self.dtype.is_integer or self.dtype is DataType.FLOAT

    @property
    def is_bit_field(self) -> bool:
        """V2: a bit pattern, written only as raw words."""
        return self.dtype is DataType.V2

    @property
    def is_scaled(self) -> bool:
        """An integer whose physical value is raw x scaling (a float is never scaled)."""
        return self.scaling is not None and self.scaling != 1.0 and self.dtype.is_integer

    @property
    def low(self) -> int | float | None:
        """The effective lowest raw value: ``minimum``, the smallest allowed one, the type's."""
        if self.minimum is not None:
            return self.minimum
        if self.allowed:
            return min(self.allowed)
        return self.dtype.type_range[0] if self.is_numeric else None

    @property
    def high(self) -> int | float | None:
        """The effective highest raw value: ``maximum``, the largest allowed one, the type's."""
        if self.maximum is not None:
            return self.maximum
        if self.allowed:
            return max(self.allowed)
        return self.dtype.type_range[1] if self.is_numeric else None

    def to_dict(self) -> dict[str, Any]:
        """The record as JSON-ready data (the keys `uss params --json` prints)."""
        data: dict[str, Any] = {
            "pnu": self.pnu,
            "name": self.name,
            "type": self.type_name,
            "unit": self.unit,
            "scaling": self.scaling,
            "array": self.array,
            "access": self.access.value,
            "min": self.minimum,
            "max": self.maximum,
            "source": self.source.value,
        }
        if self.length:
            data["length"] = self.length
        if self.decimals is not None:
            data["decimals"] = self.decimals
        if self.allowed is not None:
            data["allowed"] = list(self.allowed)
        if self.default:
            data["default"] = [v.hex(" ") if isinstance(v, bytes) else v for v in self.default]
        if self.texts:
            data["texts"] = {str(k): v for k, v in self.texts.items()}
        if self.bit_texts:
            data["bit_texts"] = {str(k): list(v) for k, v in self.bit_texts.items()}
        if self.index_texts:
            data["index_texts"] = list(self.index_texts)
        if self.level is not None:
            data["level"] = self.level
        if self.changeable is not None:
            data["changeable"] = self.changeable
        if self.active:
            data["active"] = True
        if self.reset_only:
            data["reset_only"] = True
        if not self.store:
            data["store"] = False
        if self.bico:
            data["bico"] = True
        if self.macro:
            data["macro"] = True
        if self.doc:
            data["doc"] = self.doc
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ParamInfo:
        """The record `to_dict` wrote (the description cache file); `ValueError` if broken."""
        try:
            dtype = TYPE_NAMES[data["type"]]
            default: tuple[Value, ...] = tuple(
                bytes.fromhex(v) if dtype is DataType.OCTET_STRING else v
                for v in data.get("default", ())
            )
            return cls(
                pnu=int(data["pnu"]),
                name=str(data["name"]),
                dtype=dtype,
                unit=str(data.get("unit", "")),
                scaling=None if data.get("scaling") is None else float(data["scaling"]),
                decimals=data.get("decimals"),
                array=data.get("array"),
                length=int(data.get("length", 0)),
                access=Access(data.get("access", "rw")),
                minimum=data.get("min"),
                maximum=data.get("max"),
                allowed=None if data.get("allowed") is None else tuple(data["allowed"]),
                default=default,
                texts={int(k): str(v) for k, v in data.get("texts", {}).items()},
                bit_texts={
                    int(k): (str(v[0]), str(v[1])) for k, v in data.get("bit_texts", {}).items()
                },
                index_texts=tuple(data.get("index_texts", ())),
                level=data.get("level"),
                changeable=data.get("changeable"),
                active=bool(data.get("active", False)),
                reset_only=bool(data.get("reset_only", False)),
                store=bool(data.get("store", True)),
                bico=bool(data.get("bico", False)),
                macro=bool(data.get("macro", False)),
                doc=str(data.get("doc", "")),
                source=Source(data.get("source", "drive")),
            )
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ValueError(f"not a parameter record: {exc}") from None


def from_parameter(
    param: Parameter, source: Source = Source.PROFILE, names: NameStyle = NameStyle.PROJECT
) -> ParamInfo:
    """The record of a parameter-file entry (`pyuss.drive.database.Parameter`).

    Keys the file format may carry beyond the simulator's own (``level``: access level,
    ``changeable``: when it can be changed) are taken where the database has them; a
    ``stopped_only`` parameter without ``changeable`` is changeable ``"CT"`` (not running).
    """
    level = getattr(param, "level", None)
    changeable = getattr(param, "changeable", None)
    if changeable is not None and not isinstance(changeable, str):
        changeable = getattr(changeable, "value", str(changeable))
    if changeable is None and param.stopped_only:
        changeable = "CT"
    return ParamInfo(
        pnu=param.pnu,
        name=param.name,
        dtype=param.dtype,
        unit=param.unit,
        scaling=param.scaling,
        decimals=param.decimals if param.scaling is not None or param.decimals else None,
        array=param.array,
        length=param.length,
        access=param.access,
        minimum=param.minimum,
        maximum=param.maximum,
        allowed=param.allowed,
        default=param.default,
        texts=dict(param.texts),
        bit_texts=dict(param.bit_texts),
        index_texts=param.index_texts,
        level=level if isinstance(level, int) and not isinstance(level, bool) else None,
        changeable=changeable,
        active=param.active,
        reset_only=param.reset_only,
        store=param.store,
        bico=param.bico,
        macro=param.macro,
        doc=param.doc,
        source=source,
        names=names,
    )


class DescriptionLike(Protocol):
    """What `from_description` reads of a parameter description (`pyuss.master.Description`
    has these properties, decoded from the elements of C 6)."""

    @property
    def pnu(self) -> int: ...
    @property
    def type_code(self) -> int | None: ...
    @property
    def name(self) -> str | None: ...
    @property
    def scaling(self) -> float | None: ...
    @property
    def identifier(self) -> int | None: ...
    @property
    def array_length(self) -> int | None: ...
    @property
    def is_array(self) -> bool | None: ...
    @property
    def read_only(self) -> bool | None: ...
    @property
    def active(self) -> bool | None: ...
    @property
    def low(self) -> int | float | None: ...
    @property
    def high(self) -> int | float | None: ...


def _scaling_of(desc: DescriptionLike) -> float | None:
    """The standardisation factor (element 3) where identifier bit 8 does not say "not
    relevant"; 1.0 and non-positive factors mean no scaling."""
    ident = desc.identifier
    if ident is not None and ident >> 8 & 1:
        return None
    factor = desc.scaling
    if factor is None or not factor > 0:
        return None
    factor = shortest_float(factor)
    return None if factor == 1.0 else factor


def from_description(
    desc: DescriptionLike, known: ParamInfo | None = None, names: NameStyle | None = None
) -> ParamInfo | None:
    """The record of a description the drive sent (C 6), over what ``known`` says.

    The drive's own data win: type, name, array size, scaling, access and limits. Unit, texts,
    default, access level and documentation (which the description does not carry) stay from
    ``known`` while its type agrees. ``names``: the family's naming style (default: that of
    ``known``). None when the description does not say the data type.
    """
    code = desc.type_code
    try:
        dtype = DataType(code) if code is not None else None
    except ValueError:
        dtype = None
    if dtype is None:
        return None
    same = known is not None and known.dtype is dtype
    style = names if names is not None else known.names if known is not None else NameStyle.PROJECT
    base = known if same and known is not None else ParamInfo(desc.pnu, f"P{desc.pnu}", dtype)
    if not same and known is not None:
        base = replace(base, name=known.name, unit=known.unit, level=known.level, doc=known.doc)
    name = (desc.name or "").strip() or base.name
    array = base.array
    length = base.length
    count = desc.array_length
    if dtype.is_string:
        if count:
            length = count
        array = None
    elif desc.is_array is not None:
        array = (count or base.array or 1) if desc.is_array else None
    access = base.access
    if desc.read_only is not None:
        if desc.read_only:
            access = Access.RO
        elif access is Access.RO:
            access = Access.RW
    minimum, maximum = base.minimum, base.maximum
    if (dtype.is_integer and dtype is not DataType.V2) or dtype is DataType.FLOAT:
        if isinstance(desc.low, int | float):
            minimum = desc.low
        if isinstance(desc.high, int | float):
            maximum = desc.high
    scaling = _scaling_of(desc) if dtype.is_integer else None
    return replace(
        base,
        name=name,
        dtype=dtype,
        array=array,
        length=length,
        access=access,
        minimum=minimum,
        maximum=maximum,
        scaling=scaling,
        decimals=base.decimals if scaling == base.scaling else None,
        active=bool(desc.active) if desc.active is not None else base.active,
        source=Source.DRIVE,
        names=style,
    )
