"""The project's files the tests read: its root, and the byte-exact vectors in
``tests/vectors/`` (the project's own, written from the documents listed in
docs/references.md). Where the specification folder of the project's authors stands beside
the clone (``../shared``), `tests/test_vectors.py` also checks that these vectors hold the
same data as the ones kept there; a clone without it runs everything else."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "tests" / "vectors"


def _find_shared() -> Path | None:
    """``shared/`` beside the project's root (``../shared``; worktrees may sit deeper), if any."""
    for parent in ROOT.parents:
        candidate = parent / "shared"
        if (candidate / "vectors").is_dir():
            return candidate
    return None


SHARED = _find_shared()


def load_vectors(name: str) -> Any:
    """Load the project's vectors ``tests/vectors/<name>.json``."""
    path = VECTORS / f"{name}.json"
    return json.loads(path.read_text(encoding="utf-8"))


def shared_folder() -> Path:
    """The ``../shared`` folder, or skip the calling test where the clone has none beside it."""
    if SHARED is None:
        pytest.skip("no ../shared beside this clone: the comparison with it does not apply")
    return SHARED
