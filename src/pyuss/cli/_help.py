"""Help texts of the ``uss`` commands: the module docstring of each command is its help
description, shown as plain text (`plain` drops the reStructuredText quotes).

Style, for drive engineers: what the command or option does comes first, in their words; the
document and section it follows come after, in parentheses ("USS specification C 4.2.1.1";
docs/references.md lists the documents). ``tests/cli/test_help.py`` holds the rules.
"""

from __future__ import annotations

import argparse
import re
from typing import Any

__all__ = ["actions", "plain", "subcommand"]

_QUOTES = re.compile(r"``(.+?)``|(?<![\w`])`([^`\n]+)`(?![\w`])")


def plain(doc: str | None) -> str:
    """``doc`` without reStructuredText quotes: ````--port````, ```pyuss.bass```` become
    --port, pyuss.bass."""
    if not doc:
        return ""
    return _QUOTES.sub(lambda m: m.group(1) or m.group(2), doc)


def subcommand(
    subparsers: Any, name: str, summary: str, doc: str | None
) -> argparse.ArgumentParser:
    """The parser of ``uss name``: ``summary`` in the list of commands, ``doc`` (the command's
    module docstring) as its description, in plain text and with its own line breaks."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        name,
        help=summary,
        description=plain(doc),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    return parser


def actions(
    parser: argparse.ArgumentParser, dest: str, metavar: str = "ACTION"
) -> argparse._SubParsersAction[argparse.ArgumentParser]:
    """The sub-commands of ``parser``, one of which must be given; its name goes to ``dest``."""
    sub = parser.add_subparsers(dest=dest, metavar=metavar)
    sub.required = True
    return sub
