"""What the points know of a parameter: name, unit, type, scaling, access; typed reads and writes.

This is the one place where the points meet the parameter model `pyuss.params`: `ParamMeta`
is a `pyuss.params.ParamInfo` (the profile's parameter book, `ParamBook.for_profile`) seen as
a number with a unit, and reads and writes go through the drive's typed `Drive.read` /
`Drive.write`, which convert with the type and scaling and refuse a bad value before anything
is sent. A parameter the book does not know is shown as the unsigned word or double word the
drive sends, without a unit.

Only numbers are exposed: the faces carry integers and floats; a text or octet-string
parameter is refused when the configuration is checked.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from pyuss.drive.datatypes import DataType
from pyuss.drive.loader import load_profile
from pyuss.errors import ConfigError
from pyuss.master.drive import Drive
from pyuss.params import ParamBook, ParamInfo
from pyuss.profiles import get_profile

__all__ = ["ParamMeta", "ParameterModel"]


@dataclass(frozen=True, slots=True)
class ParamMeta:
    """One parameter (element) as the points show it."""

    pnu: int
    index: int | None
    name: str
    unit: str = ""
    is_float: bool = False
    signed: bool = False
    dword: bool = False
    scaling: float | None = None
    decimals: int = 0
    writable: bool = True
    known: bool = False
    """The parameter file describes it (else: raw unsigned value, writable as far as known)."""
    minimum: float | None = None
    maximum: float | None = None
    texts: Mapping[int, str] = field(default_factory=dict)
    label: str = ""
    """The parameter as its family's documents write it (``r0021``, ``P1120.0``; "": the
    generic ``key``), for messages to people."""

    @property
    def key(self) -> str:
        """``P21``, ``P1120.0``: the faces' stable key (topics, nodes), whatever the family."""
        return f"P{self.pnu}" if self.index is None else f"P{self.pnu}.{self.index}"

    @property
    def shown(self) -> str:
        """The parameter in messages: ``label``, else ``key``."""
        return self.label or self.key

    @property
    def is_integer(self) -> bool:
        """The value shown is an integer (no float type, no scaling)."""
        return not self.is_float and self.scaling is None

    def physical(self, raw: int | float) -> int | float:
        """The value in ``unit`` of a raw value."""
        if isinstance(raw, float) or self.scaling is None:
            return raw
        return round(raw * self.scaling, max(self.decimals, 0) + 6)

    def raw(self, value: float) -> int | float:
        """The raw value to send for ``value`` in ``unit``; `ConfigError` if it is no number,
        not whole where the parameter holds integers, or outside the parameter's limits."""
        if not _finite(value):
            raise ConfigError(f"{self.shown}: {value!r} is not a finite number")
        if self.minimum is not None and value < self.minimum - 1e-9:
            raise ConfigError(f"{self.shown}: {value:g} is below the minimum {self.minimum:g}")
        if self.maximum is not None and value > self.maximum + 1e-9:
            raise ConfigError(f"{self.shown}: {value:g} is above the maximum {self.maximum:g}")
        if self.is_float:
            return float(value)
        scaled = value / self.scaling if self.scaling is not None else value
        whole = round(scaled)
        if abs(scaled - whole) > 1e-6:
            step = f" in steps of {self.scaling:g}" if self.scaling else ""
            raise ConfigError(f"{self.shown}: {value!r} must be a whole number{step}")
        return int(whole)


def _finite(value: object) -> bool:
    return not isinstance(value, bool) and isinstance(value, int | float) and math.isfinite(value)


def _meta(info: ParamInfo, index: int | None, base: int) -> ParamMeta:
    dtype = info.dtype
    shown = info.label()
    if dtype.is_string:
        raise ConfigError(
            f"{shown} ({info.name}) is a {dtype.label} parameter: the gateway exposes numbers only"
        )
    if info.is_array and index is None:
        raise ConfigError(
            f"{shown} ({info.name}) is an array of {info.array}: name an element "
            f"({info.label(base)})"
        )
    if not info.is_array and index is not None:
        raise ConfigError(f"{shown} ({info.name}) is not an array: leave out the index")
    if info.is_array and index is not None:
        last = base + (info.array or 0) - 1
        if not base <= index <= last:
            raise ConfigError(f"{info.label(index)}: the elements are {base}..{last}")
    scaling = info.scaling
    writable = info.writable

    def scaled(limit: int | float | None) -> float | None:
        if limit is None or not writable:
            return None
        return float(limit) * scaling if scaling is not None else float(limit)

    return ParamMeta(
        pnu=info.pnu,
        index=index,
        name=info.name,
        unit=info.unit,
        is_float=dtype is DataType.FLOAT,
        signed=dtype in (DataType.INT8, DataType.INT16, DataType.INT32),
        dword=info.words == 2,
        scaling=scaling,
        decimals=info.decimals or 0,
        writable=writable,
        known=True,
        minimum=scaled(info.minimum),
        maximum=scaled(info.maximum),
        texts=dict(info.texts),
        label=info.label(index),
    )


class ParameterModel:
    """The parameters of one profile as the points use them (``profile`` None: a drive of
    unknown kind, of whose parameters nothing is known: they travel as words)."""

    def __init__(self, profile: str | None) -> None:
        self.profile = profile

    @functools.cached_property
    def book(self) -> ParamBook:
        if self.profile is None:
            return ParamBook()
        return ParamBook.for_profile(get_profile(self.profile))

    def meta(self, pnu: int, index: int | None = None, name: str | None = None) -> ParamMeta:
        """What is known of P``pnu`` (element ``index``); `ConfigError` for a parameter the
        points cannot show (text, a whole array)."""
        info = self.book.get(pnu)
        if info is not None:
            meta = _meta(info, index, self.book.index_base)
        else:
            meta = ParamMeta(pnu, index, f"P{pnu}")
        if name is not None:
            meta = replace(meta, name=name)
        return meta

    def role(self, role: str) -> tuple[int, int | None] | None:
        """The parameter the profile uses for ``role`` (``reference``, ``fault``), if any."""
        if self.profile is None:
            return None
        try:
            ref = load_profile(self.profile).roles.get(role)
        except ConfigError:
            return None
        return None if ref is None else (ref.pnu, ref.index)

    async def read(self, drive: Drive, meta: ParamMeta) -> int | float:
        """The value of ``meta`` in its unit, read through the drive's parameter channel."""
        value = await drive.read(meta.pnu, meta.index)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{meta.key}: the drive's value {value!r} is not a number")
        return value

    async def write(
        self, drive: Drive, meta: ParamMeta, value: float, *, eeprom: bool = False
    ) -> tuple[int | float, bool]:
        """Write ``value`` (in the unit) as a parameter job; returns the value the drive
        answered with, in the unit, and whether it is another value than the one written (the
        drive limits or rounds it: `pyuss.params.Reading.differs`, the words compared)."""
        if not meta.writable:
            raise ConfigError(f"{meta.key} ({meta.name}) is read-only")
        raw = meta.raw(value)  # refuses what is not a number, between steps, beyond limits
        send = float(value) if meta.is_float or meta.scaling is not None else int(raw)
        reading = await drive.write_param(meta.pnu, send, meta.index, eeprom=eeprom)
        answered = reading.value
        if isinstance(answered, bool) or not isinstance(answered, int | float):
            raise ConfigError(f"{meta.key}: the drive answered {answered!r}, not a number")
        return answered, reading.differs
