"""The README is where a new user starts: one list of the documentation, naming every page."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_readme_lists_every_docs_page_once_under_one_heading() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert text.count("\n## Documentation\n") == 1
    section = text.split("\n## Documentation\n", 1)[1].split("\n## ", 1)[0]
    listed = re.findall(r"^- `(docs/[\w.-]+\.md)`", section, flags=re.MULTILINE)
    pages = sorted(f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md"))
    assert sorted(listed) == pages
    assert len(listed) == len(set(listed))
