"""What the points know of a parameter: name, unit, type, scaling, access; typed reads and writes.

This is the one place where the points meet the parameter model. It reads the knowledge of a
drive's parameters from its profile's parameter file (the TOML files of
``pyuss/profiles/data``, read by `pyuss.drive.database`) and reads and writes the raw words
through `Drive.read` / `Drive.read_float` / `Drive.write`, converting with the file's type
and scaling. A parameter the file does not know is shown as the unsigned word or double word
the drive sends, without a unit.

Only numbers are exposed: the faces carry integers and floats; a text or octet-string
parameter is refused when the configuration is checked.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from pyuss.drive.database import Access, Parameter, ParameterDatabase, load_profile
from pyuss.drive.datatypes import DataType
from pyuss.errors import ConfigError
from pyuss.master.drive import Drive

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

    @property
    def key(self) -> str:
        return f"P{self.pnu}" if self.index is None else f"P{self.pnu}.{self.index}"

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
            raise ConfigError(f"{self.key}: {value!r} is not a finite number")
        if self.minimum is not None and value < self.minimum - 1e-9:
            raise ConfigError(f"{self.key}: {value:g} is below the minimum {self.minimum:g}")
        if self.maximum is not None and value > self.maximum + 1e-9:
            raise ConfigError(f"{self.key}: {value:g} is above the maximum {self.maximum:g}")
        if self.is_float:
            return float(value)
        scaled = value / self.scaling if self.scaling is not None else value
        whole = round(scaled)
        if abs(scaled - whole) > 1e-6:
            step = f" in steps of {self.scaling:g}" if self.scaling else ""
            raise ConfigError(f"{self.key}: {value!r} must be a whole number{step}")
        return int(whole)


def _finite(value: object) -> bool:
    return not isinstance(value, bool) and isinstance(value, int | float) and math.isfinite(value)


def _meta(param: Parameter, index: int | None, profile_base: int) -> ParamMeta:
    dtype = param.dtype
    if dtype.is_string:
        raise ConfigError(
            f"P{param.pnu} ({param.name}) is a {dtype.label} parameter: the gateway exposes "
            "numbers only"
        )
    if param.is_array and index is None:
        raise ConfigError(
            f"P{param.pnu} ({param.name}) is an array of {param.array}: name an element "
            f"(P{param.pnu}.{profile_base})"
        )
    if not param.is_array and index is not None:
        raise ConfigError(f"P{param.pnu} ({param.name}) is not an array: leave out the index")
    if param.is_array and index is not None:
        last = profile_base + (param.array or 0) - 1
        if not profile_base <= index <= last:
            raise ConfigError(f"P{param.pnu}.{index}: the elements are {profile_base}..{last}")
    scaling = param.scaling
    low = param.minimum
    high = param.maximum
    writable = param.writable

    def scaled(limit: int | float | None) -> float | None:
        if limit is None or not writable:
            return None
        return float(limit) * scaling if scaling is not None else float(limit)

    return ParamMeta(
        pnu=param.pnu,
        index=index,
        name=param.name,
        unit=param.unit,
        is_float=dtype is DataType.FLOAT,
        signed=dtype in (DataType.INT8, DataType.INT16, DataType.INT32),
        dword=param.word_count == 2,
        scaling=scaling,
        decimals=param.decimals,
        writable=writable and param.access is not Access.RO,
        known=True,
        minimum=scaled(low),
        maximum=scaled(high),
        texts=dict(param.texts),
    )


class ParameterModel:
    """The parameters of one profile as the points use them."""

    def __init__(self, profile: str) -> None:
        self.profile = profile

    @functools.cached_property
    def database(self) -> ParameterDatabase | None:
        try:
            return load_profile(self.profile)
        except ConfigError:
            return None

    def meta(self, pnu: int, index: int | None = None, name: str | None = None) -> ParamMeta:
        """What is known of P``pnu`` (element ``index``); `ConfigError` for a parameter the
        points cannot show (text, a whole array)."""
        db = self.database
        if db is not None and pnu in db:
            meta = _meta(db.parameter(pnu), index, db.profile.index_base)
        else:
            meta = ParamMeta(pnu, index, f"P{pnu}")
        if name is not None:
            meta = replace(meta, name=name)
        return meta

    def role(self, role: str) -> tuple[int, int | None] | None:
        """The parameter the profile uses for ``role`` (``reference``, ``fault``), if any."""
        db = self.database
        if db is None:
            return None
        ref = db.roles.get(role)
        return None if ref is None else (ref.pnu, ref.index)

    async def read(self, drive: Drive, meta: ParamMeta) -> int | float:
        """The value of ``meta`` in its unit, read through the drive's parameter channel."""
        if meta.is_float:
            return await drive.read_float(meta.pnu, meta.index)
        raw = await drive.read(meta.pnu, meta.index, signed=meta.signed)
        return meta.physical(raw)

    async def write(
        self, drive: Drive, meta: ParamMeta, value: float, *, eeprom: bool = False
    ) -> int | float:
        """Write ``value`` (in the unit) as a parameter job; returns the value the drive
        answered with, in the unit."""
        if not meta.writable:
            raise ConfigError(f"{meta.key} ({meta.name}) is read-only")
        raw = meta.raw(value)
        if isinstance(raw, float):
            answered = await drive.write(meta.pnu, raw, meta.index, eeprom=eeprom)
        else:
            answered = await drive.write(
                meta.pnu,
                raw,
                meta.index,
                dword=meta.dword if meta.known else None,
                eeprom=eeprom,
            )
        if isinstance(answered, float):
            return answered
        if meta.signed and not meta.dword and answered >= 0x8000:
            answered -= 0x10000
        elif meta.signed and meta.dword and answered >= 0x8000_0000:
            answered -= 0x1_0000_0000
        return meta.physical(answered)
