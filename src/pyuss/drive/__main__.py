"""Check and list parameter files: ``python -m pyuss.drive check FILE`` / ``show NAME|FILE``.

``check`` validates a parameter file (and the files it extends, and each of its editions) and
prints a one-line summary;
a bad file gives a one-line message naming file, parameter and field, and exit code 2.
``show`` lists the parameters of a built-in profile or a file, or one parameter with its
description elements and texts, each named as the family's documents write it (``r0021``,
``P1120``; ``P21`` in the generic style).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from pyuss.drive.database import ParameterDatabase
from pyuss.drive.datatypes import DataType
from pyuss.drive.faults import ParameterFault
from pyuss.drive.loader import builtin_profiles, load_database, load_profile, split_edition
from pyuss.drive.memory import ParameterMemory
from pyuss.errors import ConfigError


def _load(source: str) -> ParameterDatabase:
    if split_edition(source)[0] in builtin_profiles():
        return load_profile(source)  # NAME or NAME@EDITION
    if not Path(source).exists():
        known = ", ".join(builtin_profiles())
        raise ConfigError(f"{source}: neither a built-in profile ({known}) nor a file")
    return load_database(source)


def _value(value: object) -> str:
    if isinstance(value, bytes):
        return value.hex(" ").upper() or "-"
    if isinstance(value, str):
        return repr(value.rstrip())
    return str(value)


def _table(db: ParameterDatabase) -> list[str]:
    lines = [f"{'PNU':>5}  {'name':16}  {'type':8}  {'access':9}  {'default':>14}  limits / unit"]
    for p in db:
        shape = p.dtype.label + ("" if p.array is None else f"[{p.array}]")
        limits = ""
        if p.allowed is not None:
            limits = "{" + ", ".join(str(v) for v in p.allowed) + "}"
        elif p.minimum is not None or p.maximum is not None:
            limits = f"{p.low}..{p.high}"
        extra = " ".join(x for x in (limits, p.unit, "active" if p.active else "") if x)
        lines.append(
            f"{db.label(p.pnu):>5}  {p.name:16}  {shape:8}  {p.access.value:9}  "
            f"{_value(p.default[0]):>14}  {extra}"
        )
    return lines


def _detail(db: ParameterDatabase, pnu: int) -> list[str]:
    memory = ParameterMemory(db)
    p = db.parameter(pnu)
    title = f"{db.label(p.pnu)} {p.name!r}: {p.dtype.label}, {p.access.value}"
    lines = [title, f"  {p.doc}".rstrip()]
    if p.follows:
        lines.append(f"  follows: {p.follows}")
    for item in memory.description(pnu):
        words = " ".join(f"{w:04X}" for w in item.words)
        lines.append(f"  element {item.number:>2} {item.name:26} {words}")
    texts: list[tuple[str, int, bool]] = []
    if p.is_array:
        texts += [("index", y, False) for y in range(1, len(p.index_texts) + 1)]
        texts += [("value", v + 1, True) for v in p.texts]
    elif p.dtype is DataType.V2:
        texts += [("bit", 2 * b + s + 1, False) for b in p.bit_texts for s in (0, 1)]
    else:
        texts += [("value", v + 1, False) for v in p.texts]
    for kind, y, second in texts:
        lines.append(f"  text {kind:5} y={y:<3} {memory.text(pnu, y, second=second)!r}")
    return [line for line in lines if line.strip()]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pyuss.drive", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    check = sub.add_parser("check", help="validate a parameter file")
    check.add_argument("file")
    show = sub.add_parser("show", help="list the parameters of a profile or file")
    show.add_argument(
        "source",
        help=f"a file or one of: {', '.join(builtin_profiles())} (NAME@EDITION: an edition)",
    )
    show.add_argument("pnu", nargs="?", type=int, help="show one parameter in detail")
    args = parser.parse_args(argv)
    try:
        if args.command == "check":
            db = load_database(args.file)
            for edition in db.profile.editions[1:]:  # each edition's values checked too
                load_database(args.file, edition)
            editions = (
                f" (editions {', '.join(db.profile.editions)})" if db.profile.editions else ""
            )
            print(f"{args.file}: profile {db.profile.name!r}, {len(db)} parameters, ok{editions}")
        else:
            db = _load(args.source)
            print("\n".join(_table(db) if args.pnu is None else _detail(db, args.pnu)))
    except (ConfigError, ParameterFault) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
