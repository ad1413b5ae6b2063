"""`ParamBook`: what is known of one drive's parameters, from three sources in order of trust.

1. A parameter file the user gives (``--params FILE``, `ParamBook.use_file`): the TOML format
   the simulator reads (docs/drive.md), read by `pyuss.drive.database`. Its entries stand as
   written.
2. The drive's own parameter descriptions (C 6), read live by `pyuss.master.Drive` and handed
   to `ParamBook.learn`. The drive's type, name, array size, scaling, access and limits win
   over the profile's file; the unit, texts and default the description does not carry stay
   from the file while the type agrees. Descriptions are kept per drive in memory (one book per
   `Drive`) and, if the user wants, in a cache file (`save_cache` / `load_cache`, JSON written
   atomically), so a later run needs not ask again.
3. The parameter file shipped with the drive's profile (``pyuss/profiles/data/NAME.toml``).

When the master reads a description is the book's `describe` policy: `Describe.AUTO`
(default) as the drive's profile says - a drive whose profile says it has descriptions
(`ParamBook.drive_describes`) is asked for the parameters no file knows, a drive of no named
profile never -, `Describe.MISSING` for the parameters no file knows whatever the profile says,
`Describe.ALWAYS` for every parameter before its first use, `Describe.NEVER` never. Most USS
slaves in the field know no descriptions (request 4 is optional, C 6): a drive that refuses a
description (any error number but 0, "illegal parameter number": that parameter is not there)
or does not answer the request although it answers others is remembered as one without
descriptions (`ParamBook.without_descriptions`, kept in the cache file too) and not asked
again, whatever the policy.
"""

from __future__ import annotations

import enum
import json
from collections.abc import Iterable, Iterator
from dataclasses import replace
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from pyuss.atomicfile import check_regular, check_target, write_atomically
from pyuss.drive.database import NameStyle, ParameterDatabase
from pyuss.drive.loader import load_database
from pyuss.errors import ConfigError

if TYPE_CHECKING:
    from pyuss.params.model import Reading
    from pyuss.profiles.base import Profile
from pyuss.params.model import (
    DescriptionLike,
    ParamInfo,
    Source,
    from_description,
    from_parameter,
    param_label,
)
from pyuss.params.names import param_name, parse_param_name
from pyuss.profiles import Profile, get_profile, profile_names
from pyuss.protocol.pkw import RequestId
from pyuss.userfile import parse_json, read_text

__all__ = ["CACHE_VERSION", "MACRO_WORDS", "Describe", "ParamBook", "macro_profiles"]

CACHE_VERSION = 1

MACRO_WORDS = ("macro", "macros")
"""Search words that find the parameters a family's file marks as macros (``macro = true``,
docs/drive.md), whatever their names say."""


class Describe(enum.Enum):
    """When the master asks a drive for a parameter's description (C 6)."""

    AUTO = "auto"
    """As the profile says: `MISSING` where it says the drive has descriptions, else `NEVER`."""
    NEVER = "never"
    MISSING = "missing"
    """Only for parameters neither the user's file nor the profile's knows."""
    ALWAYS = "always"
    """Before the first use of every parameter: the drive's own data win."""


class ParamBook:
    """The parameters of one drive; see the module docstring."""

    def __init__(
        self,
        shipped: Iterable[ParamInfo] = (),
        *,
        index_base: int = 1,
        profile: str = "",
        describe: Describe = Describe.AUTO,
        drive_describes: bool = False,
        names: NameStyle = NameStyle.PROJECT,
    ) -> None:
        self.profile = profile
        """Name of the profile whose file the book started from ('' for none)."""
        self.names = names
        """How the drive's family writes parameter numbers (`label`, `pyuss.params.names`)."""
        self.index_base = index_base
        """The first array index of the drive (C 3.2 counts from 1; MICROMASTER 4 from 0)."""
        self.describe = describe
        self.drive_describes = drive_describes
        """The profile says the drive answers description requests (request 4, C 6)."""
        self.without_descriptions = False
        """The drive showed it has no descriptions: it refused one or did not answer."""
        self._shipped: dict[int, ParamInfo] = {p.pnu: p for p in shipped}
        self._live: dict[int, ParamInfo] = {}
        self._user: dict[int, ParamInfo] = {}
        self._refused: set[int] = set()
        self.user_file: str | None = None

    @classmethod
    def for_profile(cls, profile: Profile, **options: Any) -> ParamBook:
        """The book a drive of ``profile`` starts with: the profile's shipped parameter file;
        descriptions are expected where the profile's drives answer request 4."""
        db = profile.database()
        options.setdefault(
            "drive_describes", int(RequestId.READ_PBE_ELEMENT) in profile.request_ids
        )
        options.setdefault("names", db.profile.names)
        return cls(
            (from_parameter(p, names=options["names"]) for p in db),
            index_base=db.profile.index_base,
            profile=profile.name,
            **options,
        )

    @classmethod
    def from_database(cls, db: ParameterDatabase, source: Source = Source.PROFILE) -> ParamBook:
        """A book of one parameter file's entries."""
        return cls(
            (from_parameter(p, source, db.profile.names) for p in db),
            index_base=db.profile.index_base,
            profile=db.profile.name,
            names=db.profile.names,
        )

    # -- sources -----------------------------------------------------------------------------
    def use_file(self, path: str | Path) -> None:
        """Take the user's parameter file (highest trust); `ConfigError` if it is bad."""
        self.use_database(load_database(path))
        self.user_file = str(path)

    def use_database(self, db: ParameterDatabase) -> None:
        """Take the entries of a parameter database as the user's (highest trust); they are
        named in the style of the drive's profile, or the file's own for a drive of none."""
        if not self.profile:
            self.names = db.profile.names
        self._user = {p.pnu: from_parameter(p, Source.USER, self.names) for p in db}

    def learn(self, description: DescriptionLike) -> ParamInfo | None:
        """Take a description the drive sent (C 6); returns the record it gives, or None when
        the description does not say the data type."""
        pnu = description.pnu
        info = from_description(description, self._shipped.get(pnu), self.names)
        if info is None:
            self._refused.add(pnu)
            return None
        self._live[pnu] = info
        self._refused.discard(pnu)
        return info

    def no_description(self, pnu: int) -> None:
        """Note that the drive gives no description of ``pnu`` (not asked again)."""
        self._refused.add(pnu)

    def no_descriptions(self) -> None:
        """Note that the drive has no descriptions at all (none is asked for again)."""
        self.without_descriptions = True

    def needs_description(self, pnu: int) -> bool:
        """Whether the master should read ``pnu``'s description before using it."""
        if self.describe is Describe.NEVER or self.without_descriptions:
            return False
        if pnu in self._live or pnu in self._refused or pnu in self._user:
            return False
        if self.describe is Describe.AUTO and not self.drive_describes:
            return False
        if self.describe is Describe.ALWAYS:
            return True
        return pnu not in self._shipped

    # -- looking up --------------------------------------------------------------------------
    def get(self, pnu: int) -> ParamInfo | None:
        """What is known of ``pnu`` from the most trusted source that knows it, or None."""
        return self._user.get(pnu) or self._live.get(pnu) or self._shipped.get(pnu)

    def label(self, pnu: int, index: int | None = None) -> str:
        """Parameter ``pnu`` (element ``index``) as the drive's family writes it: ``r0021``,
        ``P1120``, ``P947.0`` (by its access where known; ``P`` where not)."""
        info = self.get(pnu)
        if info is not None:
            return param_label(pnu, index, info)
        return param_name(pnu, index, style=self.names)

    def __getitem__(self, pnu: int) -> ParamInfo:
        info = self.get(pnu)
        if info is None:
            raise KeyError(pnu)
        return info

    def __contains__(self, pnu: object) -> bool:
        return isinstance(pnu, int) and self.get(pnu) is not None

    def pnus(self) -> list[int]:
        """Every known parameter number, in order."""
        return sorted({*self._user, *self._live, *self._shipped})

    def __iter__(self) -> Iterator[ParamInfo]:
        for pnu in self.pnus():
            info = self.get(pnu)
            assert info is not None
            yield info

    def __len__(self) -> int:
        return len(self.pnus())

    def search(self, words: str | Iterable[str] = "") -> list[ParamInfo]:
        """Parameters whose number or name matches: ``"1120"``, ``"P1120"`` or ``"r0021"`` finds
        that number (``"11"`` every number starting with 11, ``"r00"`` every one written
        ``r00..``; an index as in ``"947.1"`` or ``"r0947[1]"`` that number only; any spelling
        of `pyuss.params.names`), other words must all appear in the name, the unit or the
        documentation (case does not matter); ``macro`` (`MACRO_WORDS`) also finds the
        parameters the file marks as macros. No words: every parameter."""
        terms = words.split() if isinstance(words, str) else [w for t in words for w in t.split()]
        found = []
        for info in self:
            if all(_matches(info, term) for term in terms):
                found.append(info)
        return found

    def indices(self, info: ParamInfo) -> range:
        """The element indices of an array parameter (empty for a simple one)."""
        if info.array is None:
            return range(0)
        return range(self.index_base, self.index_base + info.array)

    # -- cache file --------------------------------------------------------------------------
    def cache_data(self) -> dict[str, Any]:
        """The descriptions learnt from the drive (and the refusals, and whether it has none
        at all: ``"descriptions": false``), as JSON-ready data."""
        data: dict[str, Any] = {
            "parameters": [info.to_dict() for _, info in sorted(self._live.items())],
            "no_description": sorted(self._refused),
        }
        if self.without_descriptions:
            data["descriptions"] = False
        return data

    def load_cache_data(self, data: Any, where: str = "cache") -> None:
        """Take descriptions a `cache_data` call returned (`ConfigError` if broken)."""
        try:
            live = {}
            for item in data.get("parameters", []):
                info = ParamInfo.from_dict({**item, "source": "drive"})
                live[info.pnu] = replace(info, names=self.names)
            refused = {int(p) for p in data.get("no_description", [])}
            described = data.get("descriptions", True)
        except (AttributeError, TypeError, ValueError) as exc:
            raise ConfigError(f"{where}: not a description cache: {exc}") from None
        if not isinstance(described, bool):
            raise ConfigError(f"{where}: 'descriptions' must be true or false, not {described!r}")
        self._live.update(live)
        self._refused.update(refused - set(live))
        if not described:
            self.no_descriptions()

    def load_cache(self, path: str | Path, key: str) -> None:
        """Take the descriptions kept for drive ``key`` in the cache file ``path`` (a missing
        file is an empty cache; `check_cache` first says whether it can be kept there)."""
        path = check_cache(path)
        if not path.exists():
            return
        text = read_text(path, "the description cache")
        data = _cache_file(text, path)
        entry = data["drives"].get(key)
        if entry is not None:
            self.load_cache_data(entry, f"{path}: drive {key}")

    def save_cache(self, path: str | Path, key: str) -> None:
        """Keep this book's descriptions for drive ``key`` in ``path`` (other drives' entries in
        the file stay), written atomically."""
        path = check_cache(path)
        if path.exists():
            data = _cache_file(read_text(path, "the description cache"), path)
        else:
            data = {"version": CACHE_VERSION, "drives": {}}
        data["drives"][key] = self.cache_data()
        write_atomically(
            path, (json.dumps(data, indent=1) + "\n").encode(), "the description cache"
        )


def check_cache(path: str | Path) -> Path:
    """``path`` as a `Path` if a description cache can be read and kept there; `ConfigError`
    naming it if not: a folder, a folder missing or not writable, or a device, pipe or socket
    (reading a pipe would wait for a writer forever, and keeping the cache would put a file in
    its place)."""
    target = Path(path)
    if target.is_dir():  # as every file pyuss reads says it
        raise ConfigError(f"{target}: cannot read the description cache: it is a folder")
    check_target(target, "the description cache")
    check_regular(target, "give a file")
    return target


def _cache_file(text: str, path: Path) -> dict[str, Any]:
    data = parse_json(text, str(path), problem="not a description cache (JSON)")
    if (
        not isinstance(data, dict)
        or data.get("version") != CACHE_VERSION
        or not isinstance(data.get("drives"), dict)
    ):
        raise ConfigError(f"{path}: not a pyuss description cache (version {CACHE_VERSION})")
    return data


def _matches(info: ParamInfo, term: str) -> bool:
    low = term.casefold()
    try:
        pnu, index = parse_param_name(low)
    except ConfigError:
        pass
    else:
        if index is not None:
            return info.pnu == pnu
        digits = low.lstrip("pr")
        return str(info.pnu).startswith(digits) or f"{info.pnu:04d}".startswith(digits)
    if low in MACRO_WORDS and info.macro:
        return True
    haystack = f"{info.name} {info.unit} {info.doc}".casefold()
    return low in haystack


@cache
def macro_profiles() -> tuple[str, ...]:
    """The built-in profiles whose parameter file has a macro parameter (``macro = true``)."""
    return tuple(
        name for name in profile_names() if any(p.macro for p in get_profile(name).database())
    )


class ParamReader(Protocol):
    """What reads a drive's parameters: its parameter book, profile, whether that profile is
    named (a drive of unknown kind: numbers without texts) and ``read_param`` - a local drive
    (`pyuss.master.Drive`) or one behind a gateway (`pyuss.plant.RemoteParams`). The panels of
    `pyuss.points.view` and the source check of `pyuss.commission.sources` read through it."""

    @property
    def params(self) -> ParamBook: ...

    @property
    def profile(self) -> Profile: ...

    @property
    def profile_named(self) -> bool: ...

    async def read_param(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> Reading: ...
