"""Shared test helpers.

The byte-exact vectors the tests use are the project's own, in ``tests/vectors/``, written from
the documents listed in docs/references.md. Where the specification folder of the project's
authors stands beside the clone (``../shared``), `tests/test_vectors.py` also checks that these
vectors hold the same data as the ones kept there; a clone without it runs everything else.
"""

from __future__ import annotations

import contextlib
import json
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
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


@pytest.fixture
def uss_vectors() -> Any:
    return load_vectors("uss")


def start_simulator(*options: str) -> tuple[subprocess.Popen[str], str]:
    """``uss simulate OPTIONS --pty`` in a process of its own: the process and its pty's path."""
    process = subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", "simulate", *options, "--pty"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    path = process.stdout.readline().strip()
    assert path.startswith("/dev/"), process.stderr.read() if process.stderr else path
    return process, path


def stop_simulator(process: subprocess.Popen[str]) -> None:
    """Stop a simulator as Ctrl+C does; kill it if it does not end within 10 s."""
    process.send_signal(signal.SIGINT)
    try:
        process.wait(10)
    except subprocess.TimeoutExpired:  # pragma: no cover
        process.kill()


@contextlib.contextmanager
def simulator_pty(*options: str) -> Iterator[str]:
    """A `uss simulate` process serving a pty for the block: yields the pty's path."""
    process, path = start_simulator(*options)
    try:
        yield path
    finally:
        stop_simulator(process)
