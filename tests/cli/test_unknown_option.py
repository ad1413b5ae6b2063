"""An option a command does not take is named as such, with the nearest one it does take, on
every command and sub-command (exit 2) - not reported as a missing required option, nor its
value taken for the positional argument that follows."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import pytest

from cli.test_help import NAMES, PARSERS
from cli.test_json_output import _uss


@pytest.mark.parametrize(("prog", "parser"), PARSERS, ids=NAMES)
def test_every_command_names_an_option_it_does_not_take(
    prog: str, parser: argparse.ArgumentParser, capsys: pytest.CaptureFixture[str]
) -> None:
    words = prog.split()[1:]
    code, out, err = _uss(capsys, *words, "--prot", "/dev/x", "5", "1120")
    assert code == 2 and not out
    last = err.splitlines()[-1]
    if "--port" in parser._option_string_actions:
        assert last == f"{prog}: error: unknown option --prot; did you mean --port?"
    else:
        assert last.startswith(f"{prog}: error: unknown option --prot; "), last
    code, out, err = _uss(capsys, *words, "--no-such-option")
    assert code == 2 and not out
    assert err.splitlines()[-1] == (
        f"{prog}: error: unknown option --no-such-option; '{prog} --help' lists its options"
    )


def test_the_option_is_named_wherever_it_stands() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pyuss.cli.main", "read", "--prot", "/dev/x", "5", "1120"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2 and not done.stdout
    assert done.stderr.splitlines()[-1] == (
        "uss read: error: unknown option --prot; did you mean --port?"
    )
    assert "required" not in done.stderr


def test_json_errors_and_the_options_of_uss_itself(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _uss(capsys, "status", "5", "--port", "/dev/x", "--layot=3,2", "--json")
    (line,) = out.splitlines()
    assert code == 2 and json.loads(line)["error"] == {
        "type": "UsageError",
        "message": "uss status: unknown option --layot; did you mean --layout?",
        "exit_code": 2,
    }
    code, _, err = _uss(capsys, "read", "5", "52", "--port", "/dev/x", "-vv")
    assert code == 2
    assert err.splitlines()[-1] == (
        "uss read: error: unknown option -vv; -vv is an option of uss itself: give it before "
        "the command"
    )


def test_values_and_abbreviations_are_not_unknown_options(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Negative numbers, a lone ``-``, words after ``--`` and abbreviated options (argparse's
    own) pass on: the port that cannot be opened is the error."""
    argv = ["write", "5", "18", "-1", "--po", "/dev/nonexistent-uss-port", "--lay", "3,2"]
    code, _, err = _uss(capsys, *argv)
    assert code == 1 and "cannot open" in err and "unknown option" not in err


def test_a_word_too_many_is_named_by_the_command_it_was_given_to(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = _uss(capsys, "write", "3", "1120", "2.5", "s", "--port", "/dev/x")
    assert code == 2 and not out
    assert err.splitlines()[0].startswith("usage: uss write ")
    assert err.splitlines()[-1] == "uss write: error: unrecognized arguments: s"


def test_options_may_stand_between_the_words_of_a_command(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = _uss(capsys, "read", "3", "1120", "--port", "/dev/no-such-port", "1121")
    assert code == 1 and "unrecognized" not in err  # both parameters taken: the port is tried
    assert err.startswith("uss read: cannot open serial port /dev/no-such-port")
    code, out, err = _uss(
        capsys, "params", "--profile", "micromaster4", "3", "--port", "/dev/no-such-port", "ramp"
    )
    assert code == 1 and not out
    assert err.startswith("uss params: cannot open serial port /dev/no-such-port")


@pytest.mark.parametrize(
    ("option", "value"),
    [("--timeout", "inf"), ("--timeout", "0"), ("--response-delay", "inf"), ("--tolerance", "inf")],
)
def test_a_time_that_never_ends_is_refused_before_the_port_opens(
    capsys: pytest.CaptureFixture[str], option: str, value: str
) -> None:
    # an endless time would keep the command waiting for ever on a silent drive
    code, out, err = _uss(capsys, "read", "3", "52", "--port", "/dev/no-such-port", option, value)
    assert code == 2 and not out
    assert err.startswith(f"uss read: {option} {float(value)}: must be a number of")
