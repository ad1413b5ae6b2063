"""The tables of a parameter file beside its ``[[parameter]]`` entries, read and checked:
``[profile]`` (`ProfileInfo`), the roles of ``[drive]`` and ``[interface]``, ``[state_codes]``,
``[faults]``, ``[fault_texts]``, ``[warning_texts]``, ``[hints]``, ``[process]``,
``[commissioning]``, ``[words]`` and ``[sources]``, and every reference they make to a
parameter (`check_references`, once the parameters are read).

Rules they hold (docs/drive.md):

- A reference is a PNU, or ``[PNU, index]`` for an element of an array (an index of the
  profile's ``index_base``); it names a parameter the file defines, which holds a number.
- A role reads the parameter with the unit it needs: a time unit (s, ms, min) for the
  `TIME_ROLES`; %, none (4000h = 100 %) or the ``reference`` parameter's unit for the
  `LEVEL_ROLES`, ``setpoint`` and ``actual``; the unit of `MOTOR_UNITS` for the motor roles; an
  integer parameter for state, fault, warning and the words.
- The ``baud`` interface parameter tells its rates (`baud_codes`); ``failure_time`` has a time
  unit or none (s).
- Process data are at most 14 words (PZD3..PZD16) of 16-bit (or 8-bit) scalars; 0 leaves a
  word unused.
- A number's text (``[fault_texts]``, ``[warning_texts]``, ``[hints]``) that is empty drops
  the number a file it extends gave.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from pyuss.drive.database import (
    COMMISSIONING_KEYS,
    LEVEL_ROLES,
    MOTOR_UNITS,
    SOURCE_KEYS,
    SOURCE_KINDS,
    TIME_ROLES,
    TIME_UNITS,
    WORD_KEYS,
    Commissioning,
    DescriptionStyle,
    NameStyle,
    Parameter,
    ParameterDatabase,
    ParamRef,
    ProfileInfo,
    Source,
    Sources,
    WordBits,
    baud_codes,
)
from pyuss.drive.datatypes import DataType
from pyuss.drive.faults import ParameterFault
from pyuss.drive.fields import Where, choice, flag_field, int_list, text_field
from pyuss.errors import ConfigError


def read_profile(
    data: dict[str, Any], source: str, sources: str, edition: str, editions: tuple[str, ...]
) -> ProfileInfo:
    """``[profile]`` of the layers merged (``data``) as `ProfileInfo`: read from ``sources``,
    following ``edition`` of the file's ``editions``."""
    where = Where(source, "[profile]")
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise where.error("name", "required, a non-empty text")
    index_base = data.get("index_base", 1)
    if index_base not in (0, 1) or isinstance(index_base, bool):
        raise where.error("index_base", "must be 0 or 1")
    description = choice(
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
        title=text_field(data.get("title", ""), where, "title"),
        follows=text_field(data.get("follows", data.get("seed", "")), where, "follows"),
        manual=text_field(data.get("manual", ""), where, "manual"),
        source=sources,
        index_base=index_base,
        description=description,
        description_term=text_field(data.get("description_term", ""), where, "description_term"),
        text_write=flag_field(data.get("text_write", False), where, "text_write"),
        max_pnu=max_pnu,
        access_level=level_ref,
        write_enable=enable_ref,
        write_enable_bit=enable_bit,
        protected_level=protected_level,
        names=choice(NameStyle, data.get("names", "pyuss"), where, "names"),
        response_delay_ms=None if delay is None else float(delay),
        edition=edition,
        editions=editions,
    )


def _ref(value: object, where: Where, name: str) -> ParamRef:
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
    where: Where,
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


def read_refs(
    table: dict[str, Any],
    table_name: str,
    known: Sequence[str],
    source: str,
) -> dict[str, ParamRef]:
    where = Where(source, f"[{table_name}]")
    result = {}
    for key, value in table.items():
        if key not in known:
            raise where.error(key, f"unknown; known are {', '.join(known)}")
        result[key] = _ref(value, where, key)
    return result


def read_codes(
    table: dict[str, Any], table_name: str, known: Sequence[str] | None, source: str
) -> dict[str, int]:
    where = Where(source, f"[{table_name}]")
    result = {}
    for key, value in table.items():
        if known is not None and key not in known:
            raise where.error(key, f"unknown; known are {', '.join(known)}")
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF:
            raise where.error(key, "must be an integer 0..65535")
        result[key] = value
    return result


def read_number_texts(table: dict[str, Any], table_name: str, source: str) -> dict[int, str]:
    """A table of numbers and their texts (``[fault_texts]``: ``72 = "..."``); an empty text
    drops a number an extended file gave."""
    where = Where(source, f"[{table_name}]")
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


def read_hints(table: dict[str, Any], source: str) -> dict[int | str, str]:
    """``[hints]``: error numbers of response 7 and ``no_authority`` with what to do."""
    named = {key: table.pop(key) for key in HINT_KEYS if key in table}
    found: dict[int | str, str] = {
        number: text for number, text in read_number_texts(table, "hints", source).items()
    }
    for key, value in named.items():
        if not isinstance(value, str):
            raise Where(source, "[hints]").error(key, "must be a text")
        if value:
            found[key] = value
    return found


def read_process(
    table: dict[str, Any], key: str, source: str, parameters: Mapping[int, Parameter]
) -> tuple[int, ...]:
    where = Where(source, "[process]")
    extra = set(table) - {"setpoints", "actuals"}
    if extra:
        raise where.error(sorted(extra)[0], "unknown; known are setpoints, actuals")
    pnus = int_list(table.get(key, []), where, key)
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


def check_references(db: ParameterDatabase, source: str) -> None:
    """The parameters ``db``'s profile, roles and commissioning name exist and fit their use."""
    parameters = {p.pnu: p for p in db}
    profile = db.profile
    for name in ("access_level", "write_enable"):
        ref = getattr(profile, name)
        if ref is not None:
            _check_ref(ref, parameters, profile, Where(source, "[profile]"), name)
    _check_roles(db, parameters, source)
    if db.commissioning is not None:
        where = Where(source, "[commissioning]")
        for key in ("rated_frequency", "rated_speed", "pole_pairs"):
            ref = getattr(db.commissioning, key)
            if ref is not None:
                _check_ref(ref, parameters, profile, where, key)


def _check_roles(db: ParameterDatabase, parameters: Mapping[int, Parameter], source: str) -> None:
    where = Where(source, "[drive]")
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
        where = Where(source, "[interface]")
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


def read_commissioning(
    table: dict[str, Any], source: str, parameters: Mapping[int, Parameter]
) -> Commissioning | None:
    if not table:
        return None
    where = Where(source, "[commissioning]")
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
    keep = tuple(int_list(table.get("keep_on_reset", []), where, "keep_on_reset"))
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


def read_words(table: dict[str, Any], source: str) -> WordBits:
    where = Where(source, "[words]")
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

    ones = int_list(table.get("status_ones", []), where, "status_ones")
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


def read_sources(
    table: dict[str, Any],
    source: str,
    parameters: Mapping[int, Parameter],
    profile: ProfileInfo,
) -> Sources:
    where = Where(source, "[sources]")
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
