"""Fixtures every test package may use (helpers are in tests/support/)."""

from __future__ import annotations

from typing import Any

import pytest

from support.paths import load_vectors


@pytest.fixture
def uss_vectors() -> Any:
    return load_vectors("uss")
