"""The project's vectors (tests/vectors) carry the same data as tests/vectors where it exists.

Only the citation fields differ: the project's files cite documents by title and section
("section", "source"), the shared ones by file. Everything a test checks must be equal.
"""

from __future__ import annotations

import json
from typing import Any

import pytest

from support.paths import load_vectors, shared_folder

CITATIONS = {"seed", "section", "source"}


def _data(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _data(v) for k, v in value.items() if k not in CITATIONS}
    if isinstance(value, list):
        return [_data(v) for v in value]
    return value


@pytest.mark.parametrize("name", ["uss", "bass", "ksvario"])
def test_project_vectors_match_the_shared_ones(name: str) -> None:
    path = shared_folder() / "vectors" / f"{name}.json"
    shared = json.loads(path.read_text(encoding="utf-8"))
    assert _data(load_vectors(name)) == _data(shared)


@pytest.mark.parametrize("name", ["uss", "bass", "ksvario"])
def test_every_vector_cites_a_document_by_title(name: str) -> None:
    """A user has no ../shared: the project's vectors never cite a file of it."""
    text = json.dumps(load_vectors(name))
    assert '"seed"' not in text
    assert ".txt" not in text
    assert "source" in load_vectors(name)
