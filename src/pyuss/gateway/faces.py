"""The registry of the gateway's faces: one `FaceSpec` per face.

A face is a module with a class ``Face(plant, options)`` that has ``start()`` and ``close()``,
and one entry here naming it: its module and class (imported only when the face is
configured), the extra and library range `pyuss.gateway.extras.require` checks, how to read
its table of the configuration file, its command-line flag and how the gateway names its
endpoints when it prints them. `pyuss.gateway.config`, `pyuss.gateway.extras`,
`pyuss.gateway.run` and ``uss gateway`` iterate `faces()`; adding a face is a module and an
entry, nothing else.

Faces of other packages join through the entry point group ``pyuss.faces``: each entry point
names a `FaceSpec` (``dummy = "mypackage.face:SPEC"``), read once, when the gateway first asks
for its faces. One that cannot be loaded is left out with a warning naming it; the gateway
runs on with the others. `register` adds a face from Python (tests, embedding programs).
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.metadata
import logging
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from pyuss.errors import ConfigError
from pyuss.gateway.options import (
    ModbusOptions,
    MqttOptions,
    OpcuaOptions,
    modbus_options,
    mqtt_options,
    opcua_options,
)
from pyuss.points.config import PlantConfig, Where
from pyuss.points.endpoint import parse_endpoint
from pyuss.system import install_command

if TYPE_CHECKING:
    from pyuss.points.plant import Plant

__all__ = [
    "ENTRY_POINTS",
    "Face",
    "FaceSpec",
    "Flag",
    "Library",
    "faces",
    "register",
    "unregister",
]

ENTRY_POINTS = "pyuss.faces"
"""The entry point group through which other packages add faces."""

log = logging.getLogger("pyuss.gateway")

RESERVED = (
    "bus",
    "web",
    "config",
    "port",
    "address",
    "baud",
    "profile",
    "layout",
    "parameter",
    "cycle_time",
    "bus_name",
    "read_only",
    "duration",
    "help",
)
"""No face's name: the other tables of the configuration file (``web`` belongs to ``uss web``)
and the other flags of ``uss gateway``."""

_NAME = re.compile(r"[a-z][a-z0-9_]*")


class Face(Protocol):
    async def start(self) -> None: ...

    async def close(self) -> None: ...


Reader = Callable[[Mapping[str, Any], Where, PlantConfig, Path | None], Any]
"""Reads a face's table: ``(table, where, plant, base)`` to its options; `ConfigError` naming
the key (``where.key(...)``). ``base``: the folder of the configuration file, for the files
the table names."""

Builder = Callable[[Any, "Plant", Any], Iterable[tuple[str, Face]]]
"""``(face class, plant, options)`` to the faces to start, each with the name it is printed
under."""


@dataclass(frozen=True, slots=True)
class Library:
    """The library a face imports: its module, its distribution, the lowest version supported
    and the first version not supported (None: no bound)."""

    module: str
    distribution: str
    low: tuple[int, int] | None = None
    high: tuple[int, int] | None = None


@dataclass(frozen=True, slots=True)
class Flag:
    """The command-line flag ``--NAME VALUE`` of a face: ``apply(options or None, VALUE)``
    gives the options with that address (the face's own defaults when it has no table);
    `ConfigError` for a bad value (the gateway puts the flag in front)."""

    metavar: str
    help: str
    apply: Callable[[Any, str], Any]


def _endpoint(face: Any) -> str:
    """The default name of a face's endpoint: its ``endpoint`` or its options' one."""
    where = getattr(face, "endpoint", None) or getattr(face, "options", None)
    return str(getattr(where, "endpoint", where))


def _read_only(options: Any) -> Any:
    """The default: the options' ``read_only`` set; options without one refuse (a face that
    cannot refuse writes is not started as if it did)."""
    if not dataclasses.is_dataclass(options) or not any(
        f.name == "read_only" for f in dataclasses.fields(options)
    ):
        raise ConfigError("its options have no read_only, so it cannot refuse writes")
    return dataclasses.replace(options, read_only=True)  # type: ignore[type-var]


@dataclass(frozen=True, slots=True)
class FaceSpec:
    """One face of the gateway. ``name`` is its table in the configuration file, its flag
    (``--NAME``) and the name it is printed under; ``module`` and ``cls`` name its class,
    imported when it is configured; ``library`` (None: pyuss alone) is checked before any
    port opens and ``extra`` is the pip extra that installs it (None: the install names the
    library itself)."""

    name: str
    module: str
    cls: str
    read: Reader
    flag: Flag | None = None
    library: Library | None = None
    extra: str | None = None
    bus_keys: tuple[str, ...] = ()
    """Keys a ``[[bus]]`` table may carry for this face (as Modbus's ``modbus = "..."``)."""
    build: Builder | None = None
    """None: one face, ``cls(plant, options)``, printed under ``name``."""
    endpoint: Callable[[Any], str] = _endpoint
    read_only: Callable[[Any], Any] = _read_only
    """The options with every write refused (``--read-only``)."""

    def face_class(self) -> Any:
        return getattr(importlib.import_module(self.module), self.cls)

    def instances(self, plant: Plant, options: Any) -> list[tuple[str, Face]]:
        face_class = self.face_class()
        if self.build is None:
            return [(self.name, face_class(plant, options))]
        return list(self.build(face_class, plant, options))

    @property
    def install(self) -> str:
        if self.extra is not None:
            return install_command(f"pyuss[{self.extra}]")
        return install_command(self.library.distribution if self.library else self.name)


# -- the faces of pyuss -----------------------------------------------------------------------


def _modbus_faces(
    face_class: Any, plant: Plant, options: ModbusOptions
) -> Iterable[tuple[str, Face]]:
    """One server for the buses without an address of their own, one for each that has."""
    shared = [b for b in plant.buses if b not in options.bus_endpoints]
    kwargs = {"word_order": options.word_order, "read_only": options.read_only}
    if shared:
        yield "modbus", face_class(plant, options.endpoint, buses=shared, **kwargs)
    for bus, endpoint in options.bus_endpoints.items():
        yield f"modbus {bus}", face_class(plant, endpoint, buses=[bus], **kwargs)


def _modbus_flag(options: ModbusOptions | None, text: str) -> ModbusOptions:
    where = parse_endpoint(text, "modbus")
    return dataclasses.replace(options, endpoint=where) if options else ModbusOptions(where)


def _mqtt_flag(options: MqttOptions | None, text: str) -> MqttOptions:
    """The broker of ``--mqtt URL``; the file's user and password stay unless the URL names
    a user of its own (a login the file gives is never dropped without a word)."""
    where = parse_endpoint(text, "mqtt")
    user, password = where.username, where.password
    if options:
        if user is None:
            user, password = options.username, options.password
        return dataclasses.replace(options, endpoint=where, username=user, password=password)
    return MqttOptions(where, username=user, password=password)


def _opcua_flag(options: OpcuaOptions | None, text: str) -> OpcuaOptions:
    where = parse_endpoint(text, "opcua")
    return dataclasses.replace(options, endpoint=where) if options else OpcuaOptions(where)


BUILTIN: tuple[FaceSpec, ...] = (
    FaceSpec(
        name="modbus",
        module="pyuss.gateway.modbus",
        cls="ModbusFace",
        read=lambda table, where, plant, base: modbus_options(table, where, plant),
        flag=Flag("HOST:PORT", "serve Modbus TCP here", _modbus_flag),
        extra="modbus",
        bus_keys=("modbus",),
        build=_modbus_faces,
    ),
    FaceSpec(
        name="mqtt",
        module="pyuss.gateway.mqtt",
        cls="MqttFace",
        read=lambda table, where, plant, base: mqtt_options(table, where, base),
        flag=Flag("URL", "publish to this MQTT broker", _mqtt_flag),
        library=Library("aiomqtt", "aiomqtt", (2, 3), (3, 0)),
        extra="mqtt",
    ),
    FaceSpec(
        name="opcua",
        module="pyuss.gateway.opcua",
        cls="OpcuaFace",
        read=lambda table, where, plant, base: opcua_options(table, where, base),
        flag=Flag("URL", "serve OPC UA here (opc.tcp://HOST:PORT)", _opcua_flag),
        library=Library("asyncua", "asyncua", (2, 0), (3, 0)),
        extra="opcua",
    ),
)


# -- the registry -----------------------------------------------------------------------------

_registry: dict[str, FaceSpec] = {spec.name: spec for spec in BUILTIN}
_loaded = False


def register(spec: FaceSpec, *, replace: bool = False) -> None:
    """Add ``spec`` to the faces (after the others); `ConfigError` if its name is no table
    name (lower-case letters, digits, ``_``), is reserved or is taken (unless ``replace``)."""
    if not isinstance(spec, FaceSpec):
        raise ConfigError(f"a face is registered as a FaceSpec, not {spec!r}")
    if not _NAME.fullmatch(spec.name) or spec.name in RESERVED:
        raise ConfigError(
            f"face {spec.name!r}: a face's name is lower-case letters, digits and _, "
            f"and none of {', '.join(RESERVED)}"
        )
    if spec.name in _registry and not replace:
        raise ConfigError(f"face {spec.name!r}: there is such a face already")
    _registry[spec.name] = spec


def unregister(name: str) -> None:
    """Remove the face ``name`` (nothing if there is none)."""
    _registry.pop(name, None)


def _load_entry_points() -> None:
    for entry in importlib.metadata.entry_points(group=ENTRY_POINTS):
        try:
            spec = entry.load()
            if not isinstance(spec, FaceSpec) or spec.name != entry.name:
                raise ConfigError(f"expected the FaceSpec named {entry.name!r}, not {spec!r}")
            register(spec)
        except Exception as exc:  # a broken package must not stop the other faces
            log.warning("face %s (%s) left out: %s", entry.name, entry.value, exc)


def faces() -> Mapping[str, FaceSpec]:
    """Every face, by name: pyuss's own, those of the ``pyuss.faces`` entry points (read the
    first time) and those registered."""
    global _loaded
    if not _loaded:
        _loaded = True
        _load_entry_points()
    return _registry
