"""Help texts speak to drive engineers: every command and option says what it does first, the
document and section it follows after (in parentheses), in plain text, and never names the
project's own working papers."""

from __future__ import annotations

import argparse
import re

import pytest

from pyuss.cli.main import COMMANDS, build_parser

CITATION = re.compile(r"\b(?:[ABC] (?:Table )?\d+(?:\.\d+)*|USS specification|manual \d)")
"""A section of a document: A 5.3, C Table 5.4, USS specification, manual 1.2."""
PRIVATE = re.compile(r"\bseed\s+0|\bseed's\b|\bNOTES\b|``|`pyuss\.")
"""What means nothing to a user: working papers, reStructuredText quotes, module paths."""


def _parsers() -> list[tuple[str, argparse.ArgumentParser]]:
    found: list[tuple[str, argparse.ArgumentParser]] = []

    def walk(parser: argparse.ArgumentParser, name: str) -> None:
        found.append((name, parser))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub, child in action.choices.items():
                    walk(child, f"{name} {sub}")

    walk(build_parser(), "uss")
    return found


PARSERS = _parsers()
NAMES = [name for name, _ in PARSERS]


def _options(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [
        action
        for action in parser._actions
        if not isinstance(action, argparse._HelpAction | argparse._VersionAction)
        and not isinstance(action, argparse._SubParsersAction)
        and action.help != argparse.SUPPRESS  # hidden on purpose
    ]


def _cited_inside_parentheses(text: str) -> bool:
    for match in CITATION.finditer(text):
        before = text[: match.start()]
        if before.count("(") <= before.count(")"):
            return False
    return True


def test_every_command_is_covered() -> None:
    assert {name.split()[1] for name in NAMES if name != "uss"} == set(COMMANDS)


@pytest.mark.parametrize(("name", "parser"), PARSERS, ids=NAMES)
def test_help_is_plain_text_for_drive_engineers(name: str, parser: argparse.ArgumentParser) -> None:
    text = parser.format_help()
    assert not PRIVATE.search(text), (name, PRIVATE.search(text))
    description = (parser.description or "").strip()
    if name != "uss" and description:
        first = description.splitlines()[0]
        assert first[:1].isupper(), f"{name}: the description starts with what it does: {first!r}"
        assert not first.startswith("uss "), first


@pytest.mark.parametrize(("name", "parser"), PARSERS, ids=NAMES)
def test_every_option_says_what_it_does_then_where_it_comes_from(
    name: str, parser: argparse.ArgumentParser
) -> None:
    for action in _options(parser):
        label = "/".join(action.option_strings) or action.dest
        help_text = action.help or ""
        assert help_text and help_text != argparse.SUPPRESS, f"{name} {label}: no help"
        assert help_text[:1].isalpha() or help_text[:1] in "-.", f"{name} {label}: {help_text!r}"
        assert not CITATION.match(help_text), f"{name} {label}: the section comes after"
        assert _cited_inside_parentheses(help_text), f"{name} {label}: {help_text!r}"


def test_every_command_has_a_one_line_summary() -> None:
    (sub,) = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    summaries = {choice.dest: choice.help for choice in sub._choices_actions}
    assert set(summaries) == set(COMMANDS)
    assert all(text and len(text) <= 80 and "\n" not in text for text in summaries.values())
