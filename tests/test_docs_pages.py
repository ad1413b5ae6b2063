"""Every page of docs/ opens with its title line and one short paragraph saying what the page
is for and who reads it, before its first ``##`` section."""

from __future__ import annotations

from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
LONGEST = 600
"""Characters an opening paragraph may have: one short paragraph."""


def opening(text: str) -> tuple[str, str]:
    """The title line and the first paragraph after it (HTML comments skipped), before any
    ``##`` section; an empty paragraph where the page has none."""
    lines = text.splitlines()
    title = lines[0] if lines else ""
    paragraph: list[str] = []
    for line in lines[1:]:
        if line.startswith("## "):
            break
        if not line.strip() or line.lstrip().startswith("<!--"):
            if paragraph:
                break
            continue
        if line.startswith(("```", "|", "#", "- ")):
            break
        paragraph.append(line)
    return title, " ".join(paragraph)


@pytest.mark.parametrize("page", sorted(p.name for p in DOCS.glob("*.md")))
def test_every_page_opens_with_a_title_and_what_it_is_for(page: str) -> None:
    title, paragraph = opening((DOCS / page).read_text(encoding="utf-8"))
    assert title.startswith("# ") and title[2:].strip(), f"docs/{page}: no title line"
    assert paragraph, f"docs/{page}: no opening paragraph before its first section"
    assert len(paragraph) <= LONGEST, f"docs/{page}: an opening of {len(paragraph)} characters"


def test_the_rule_sees_a_page_without_an_opening() -> None:
    assert opening("# Title\n\n## First\n\ntext\n") == ("# Title", "")
    assert opening("# Title\n\n```text\nx\n```\n") == ("# Title", "")
    assert opening("# T\n\n<!-- page run by tests/x.py -->\n\nFor you.\n") == ("# T", "For you.")
