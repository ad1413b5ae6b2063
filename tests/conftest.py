"""Fixtures every test package may use (helpers are in tests/support/), and the one hook that
skips the tests a system cannot run (`support.posix`: ptys, other POSIX-only things)."""

from __future__ import annotations

from typing import Any

import pytest

from support.paths import load_vectors
from support.posix import skip_reason


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        reason = skip_reason(item)
        if reason is not None:
            item.add_marker(pytest.mark.skip(reason=reason))


@pytest.fixture
def uss_vectors() -> Any:
    return load_vectors("uss")
