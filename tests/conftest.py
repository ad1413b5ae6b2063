"""Shared test helpers: the specification lives in ../shared beside the project."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _find_shared() -> Path:
    """``shared/`` stands beside the project's root (``../shared``); worktrees may sit deeper."""
    for parent in ROOT.parents:
        candidate = parent / "shared"
        if (candidate / "vectors").is_dir():
            return candidate
    raise RuntimeError(f"no ../shared/vectors found above {ROOT}")


SHARED = _find_shared()


def load_vectors(name: str) -> Any:
    """Load ``../shared/vectors/<name>.json``; the tests are bound to the shared vectors."""
    path = SHARED / "vectors" / f"{name}.json"
    return json.loads(path.read_text(encoding="utf-8"))


@pytest.fixture
def uss_vectors() -> Any:
    return load_vectors("uss")
