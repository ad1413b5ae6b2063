"""Shared test helpers: the specification lives in ../shared beside the project."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"


def load_vectors(name: str) -> Any:
    """Load ``../shared/vectors/<name>.json``; the tests are bound to the shared vectors."""
    path = SHARED / "vectors" / f"{name}.json"
    return json.loads(path.read_text(encoding="utf-8"))


@pytest.fixture
def uss_vectors() -> Any:
    return load_vectors("uss")
