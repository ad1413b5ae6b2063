"""A user's configuration folder of the test's own, on every system.

pyuss looks for ``uss.toml`` in the platform's folder for a user's configuration
(`pyuss.system.config_folder`: ``%APPDATA%\\pyuss`` on Windows, ``~/Library/Application
Support/pyuss`` on macOS, ``$XDG_CONFIG_HOME/pyuss`` elsewhere). A test that must not find the
user's own file, or that puts one there, points every variable those rules read into a folder
of its own: `environment` gives them, `isolate` sets them for the test and says where the
folder is.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pyuss import system


def environment(home: Path) -> dict[str, str]:
    """The variables that place the user's home and configuration folders under ``home``."""
    return {
        "HOME": str(home),
        "USERPROFILE": str(home),
        "XDG_CONFIG_HOME": str(home / ".config"),
        "APPDATA": str(home / "AppData" / "Roaming"),
    }


def isolate(monkeypatch: pytest.MonkeyPatch, home: Path) -> Path:
    """Set `environment` (``home``) for the test; the folder pyuss now reads ``uss.toml`` from
    (not created)."""
    for name, value in environment(home).items():
        monkeypatch.setenv(name, value)
    folder = system.config_folder()
    assert folder is not None and folder.is_relative_to(home), folder
    return folder


def empty_place(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty working directory under ``tmp_path`` for the test, no ``USS_CONFIG`` and a
    configuration folder of the test's own (`isolate`): no file of the user's is found.
    Returns the working directory."""
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.delenv("USS_CONFIG", raising=False)
    isolate(monkeypatch, tmp_path / "home")
    return work
