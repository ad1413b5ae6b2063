"""Reading parameter files into a `ParameterDatabase`: which files, in which order, which
edition.

- A built-in profile is ``pyuss/profiles/data/NAME.toml`` (files beginning with ``_`` are
  shared bases, not profiles); any other file is read by its path.
- ``extends`` in ``[profile]`` builds on another file: the base is read first, each later
  layer replaces its ``[profile]`` fields and table entries and the parameters it defines
  again; ``[profile] remove`` drops parameters of the base. A file extends a built-in profile
  by name or a file by a path relative to itself; a built-in profile and text given directly
  extend built-in profiles only; a cycle is refused.
- ``[editions]`` of the top file: ``NAME@EDITION`` (or the ``edition`` argument) chooses one;
  its ``manual`` replaces the profile's, its ``remove`` drops parameters, each of its
  ``[[parameter]]`` tables replaces the fields it names. The file's own values follow its
  ``[profile] edition``, required with ``[editions]``.

Loading validates everything and refuses a bad file with a `ConfigError` naming the file, the
parameter and the field (the fields of a ``[[parameter]]`` entry: `pyuss.drive.fields`; the
other tables: `pyuss.drive.tables`). The format is documented in ``docs/drive.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pyuss.drive.database import (
    INTERFACE_ROLES,
    ROLES,
    STATE_CODE_NAMES,
    ParameterDatabase,
)
from pyuss.drive.fields import PARAM_KEYS, Where, int_list, read_parameter
from pyuss.drive.tables import (
    check_references,
    read_codes,
    read_commissioning,
    read_hints,
    read_number_texts,
    read_process,
    read_profile,
    read_refs,
    read_sources,
    read_words,
)
from pyuss.errors import ConfigError
from pyuss.userfile import parse_toml, read_text

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


def _build(
    layers: list[tuple[str, dict[str, Any]]], edition: str | None = None
) -> ParameterDatabase:
    """The database of ``layers`` (base first, each later one over the ones before) in
    ``edition`` of the top file's ``[editions]`` (None: the file's own)."""
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
        for removed in int_list(prof.get("remove", []), Where(source, "[profile]"), "remove"):
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
    if own is None:
        own = ""
    elif not isinstance(own, str) or not own or EDITION_MARK in own:
        raise Where(top_source, "[profile]").error(
            "edition", f"must be a non-empty text without {EDITION_MARK}"
        )
    editions = _editions(top.get("editions", {}), own, top_source)
    if edition is None:
        edition = own
    else:
        _apply_edition(edition, own, editions, profile_data, raw_params, top_source)
    sources = " + ".join(source for source, _ in layers)
    known = tuple(e for e in (own, *editions) if e)
    profile = read_profile(profile_data, top_source, sources, edition, known)
    parameters = {
        pnu: read_parameter(entry, Where(source, f"parameter {pnu}:"), profile)
        for pnu, (source, entry) in raw_params.items()
    }
    db = ParameterDatabase(
        profile,
        parameters,
        roles=read_refs(tables["drive"], "drive", ROLES, sources),
        interface=read_refs(tables["interface"], "interface", INTERFACE_ROLES, sources),
        state_codes=read_codes(tables["state_codes"], "state_codes", STATE_CODE_NAMES, sources),
        faults=read_codes(tables["faults"], "faults", None, sources),
        fault_texts=read_number_texts(tables["fault_texts"], "fault_texts", sources),
        warning_texts=read_number_texts(tables["warning_texts"], "warning_texts", sources),
        process_setpoints=read_process(tables["process"], "setpoints", sources, parameters),
        process_actuals=read_process(tables["process"], "actuals", sources, parameters),
        commissioning=read_commissioning(tables["commissioning"], sources, parameters),
        words=read_words(tables["words"], sources),
        hints=read_hints(tables["hints"], sources),
        sources=read_sources(tables["sources"], sources, parameters, profile),
    )
    check_references(db, sources)
    return db


def _editions(value: object, own: str, source: str) -> dict[str, dict[str, Any]]:
    """The ``[editions]`` of the file itself (``own``: the edition of its own values, "" for
    none), their form checked (the values are checked as parameters when an edition is
    chosen)."""
    if not isinstance(value, dict):
        raise ConfigError(f"{source}: [editions] must be a table of editions")
    if value and not own:
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
        int_list(table.get("remove", []), Where(where), "remove")
        changes = table.get("parameter", [])
        if not isinstance(changes, list) or not all(isinstance(c, dict) for c in changes):
            raise ConfigError(f"{where}: 'parameter' must be an array of tables")
        for change in changes:
            pnu = change.get("pnu")
            if isinstance(pnu, bool) or not isinstance(pnu, int):
                raise ConfigError(f"{where}: a parameter change without 'pnu'")
            extra = set(change) - PARAM_KEYS
            if extra:
                raise ConfigError(f"{where}: parameter {pnu}: unknown field(s) {sorted(extra)}")
        out[name] = table
    return out


def _apply_edition(
    edition: str,
    own: str,
    editions: dict[str, dict[str, Any]],
    profile_data: dict[str, Any],
    raw_params: dict[int, tuple[str, dict[str, Any]]],
    source: str,
) -> None:
    """Change ``raw_params`` and ``profile_data`` to ``edition`` (``own``: the file's own): its
    ``remove`` drops parameters, each of its ``[[parameter]]`` tables replaces the fields it
    names."""
    known = ", ".join(e for e in (own, *editions) if e) or "none"
    if edition != own and edition not in editions:
        raise ConfigError(f"{source}: unknown edition {edition!r} (known: {known})")
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
