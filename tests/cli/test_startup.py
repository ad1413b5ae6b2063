"""``uss`` starts with what the command needs: ``uss --help`` and ``uss decode`` load neither
asyncio nor the master, bus or simulator; `SUMMARIES` say what each command's module says."""

from __future__ import annotations

import argparse
import importlib
import json
import subprocess
import sys

import pytest

from pyuss.cli.main import COMMANDS, SUMMARIES

HEAVY = ("asyncio", "pyuss.master", "pyuss.bus", "pyuss.slave", "pyuss.drive", "pyuss.monitor")


def _modules_after(argv: list[str]) -> list[str]:
    """The modules loaded by ``uss ARGV`` (run in a fresh interpreter)."""
    code = (
        "import json, sys\n"
        "from pyuss.cli.main import main\n"
        "try:\n"
        f"    main({argv!r})\n"
        "except SystemExit:\n"
        "    pass\n"
        "print(json.dumps(sorted(sys.modules)), file=sys.stderr)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    return list(json.loads(done.stderr.strip().splitlines()[-1]))


@pytest.mark.parametrize(
    "argv",
    [
        ["--help"],
        ["decode", "02 0C 05 10 34 00 00 00 00 04 7E 00 00 55", "--layout", "3,2"],
        ["decode", "--help"],
        ["nonsense"],
    ],
)
def test_help_and_decode_load_no_event_loop_and_no_master(argv: list[str]) -> None:
    loaded = _modules_after(argv)
    heavy = [m for m in loaded if m.split(".")[0] in HEAVY or m.startswith(HEAVY)]
    assert heavy == []


def test_a_command_loads_only_its_own_module() -> None:
    loaded = _modules_after(["read", "--help"])
    modules = {m.removeprefix("pyuss.cli.") for m in loaded if m.startswith("pyuss.cli.")}
    assert modules & set(COMMANDS) == {"read"}  # besides it, shared helpers (_master) only


@pytest.mark.parametrize("name", COMMANDS)
def test_the_summary_in_uss_help_is_the_commands_own(name: str) -> None:
    parser = argparse.ArgumentParser(prog="uss")
    sub = parser.add_subparsers()
    importlib.import_module(f"pyuss.cli.{name}").register(sub)
    (action,) = sub._choices_actions
    assert SUMMARIES.get(name) == action.help
