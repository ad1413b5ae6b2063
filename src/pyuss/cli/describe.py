"""Read what a drive says about a parameter: its name, data type, limits, scaling, array size
(the parameter description, USS specification C 6). uss describe ADDRESS PNU

With the variable layout the whole description comes in one telegram (IND 255); with a fixed
layout element by element, leaving out the elements the drive refuses as too long for its PKW
area (USS specification C 7). ``--element N`` reads one element only. Descriptions are
optional: a drive that has none refuses the request (exit 1 with its error number) or does not
answer it, and the command then says that the drive gives no description (exit 1).

The first lines say what was read in the family's own terms: the SINAMICS manuals' "descriptive
elements (request ID 4), SINAMICS V20", and the layout of its elements in words (USS
specification C 6, or the Baumueller manual's four elements).
"""

from __future__ import annotations

import argparse
from typing import Any

from pyuss.cli._master import (
    EXIT_FAILED,
    EXIT_OK,
    command,
    emit,
    finish,
    integer,
    open_master,
    outcome,
    parameter,
    run,
)
from pyuss.errors import ConfigError
from pyuss.master.description import Description, layout_text
from pyuss.params.model import param_label


def register(subparsers: Any) -> None:
    parser = command(subparsers, "describe", "read the description of a parameter", __doc__)
    parser.add_argument("pnu", metavar="PNU", help="parameter number, e.g. 52, P1120 or r0052")
    parser.add_argument(
        "--element",
        type=integer,
        metavar="N",
        help="read element N only, 1..254, or 255 for the whole description in one telegram "
        "(USS specification C 6)",
    )
    finish(parser, main)


def whole_parameter(text: str) -> int:
    """A parameter number in any spelling (`pyuss.params.names`), without an index: a
    description is the whole parameter's."""
    pnu, index = parameter(text)
    if index is not None:
        raise ConfigError(f"{text!r}: a description is the whole parameter's, give no index")
    return pnu


def render(
    description: Description, label: str | None = None, *, term: str = "", family: str = ""
) -> str:
    """The description as printed; ``label``: the parameter as the drive's family writes it,
    ``term``: what the family's manuals call the description (``[profile]
    description_term``), ``family``: the drive's family ("" for a drive of unknown kind)."""
    name = label if label is not None else param_label(description.pnu)
    what = f"{term or 'parameter description'} (request ID 4)"
    lines = [f"{name}: {what}{f', {family}' if family else ''}"]
    lines.append(f"  {'layout':<15} {layout_text(description.style)}")
    summary = [
        ("name", description.name),
        ("data type", description.data_type),
        ("read-only", description.read_only),
        ("array", description.is_array),
        ("active", description.active),
        ("array elements", description.array_length),
        ("scaling", description.scaling),
        ("lower limit", description.low),
        ("upper limit", description.high),
    ]
    for name, value in summary:
        if value is not None:
            lines.append(f"  {name:<15} {value}")
    lines.append("  elements:")
    for element in description.elements.values():
        words = " ".join(f"{w:04X}" for w in element.words)
        value = "" if element.value is None else f"  = {element.value!r}"
        lines.append(f"    {element.number:>3} {element.name:<26} {words}{value}")
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    async def body() -> int:
        pnu = whole_parameter(args.pnu)
        async with open_master(args) as bus:
            drive = bus.drive(args.address)
            description = await outcome(
                args,
                {"address": args.address, "pnu": pnu},
                drive.read_description(pnu, args.element),
            )
        if description is None:
            return EXIT_FAILED
        data = {"address": args.address, **description.to_dict()}
        info = drive.profile.database().profile
        text = render(
            description,
            drive.params.label(pnu),
            term=info.description_term,
            family=info.title if drive.profile_named else "",
        )
        emit(args, data, text)
        return EXIT_OK

    return run("describe", args, body)
