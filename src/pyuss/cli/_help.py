"""Help texts of the ``uss`` commands: the module docstring of each command is its help
description, shown as plain text (`plain` drops the reStructuredText quotes).

Style, for drive engineers: what the command or option does comes first, in their words; the
document and section it follows come after, in parentheses ("USS specification C 4.2.1.1";
docs/references.md lists the documents). ``tests/cli/test_help.py`` holds the rules.
"""

from __future__ import annotations

import re

__all__ = ["plain"]

_QUOTES = re.compile(r"``(.+?)``|(?<![\w`])`([^`\n]+)`(?![\w`])")


def plain(doc: str | None) -> str:
    """``doc`` without reStructuredText quotes: ````--port````, ```pyuss.bass```` become
    --port, pyuss.bass."""
    if not doc:
        return ""
    return _QUOTES.sub(lambda m: m.group(1) or m.group(2), doc)
