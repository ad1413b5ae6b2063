"""Fixtures of the parameter tests: a simulated drive with a parameter of every data type
(see support/typed.py)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from support.typed import TYPES_TOML, Simulator, start, stop


@pytest.fixture(scope="module")
def typed_params(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("params") / "typed.toml"
    path.write_text(TYPES_TOML, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def typed_sim(typed_params: Path) -> Iterator[Simulator]:
    """A drive at address 5 (variable layout) with the parameters of `TYPES_TOML`."""
    sim = start(typed_params, "--layout", "v,2")
    try:
        yield sim
    finally:
        stop(sim)
