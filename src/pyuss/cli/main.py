"""The `uss` command. Each sub-command lives in its own module of `pyuss.cli` and exposes
``register(subparsers)``; `COMMANDS` lists them in the order `uss --help` shows them.

Only the module of the sub-command given is imported (`uss --help` lists the others by their
`SUMMARIES`), so a command starts without loading what other commands need: `uss decode`
never imports the master or asyncio. A command that runs an event loop gets one with
microsecond timers (`pyuss.loop`).

Exit codes (all commands): 0 success, 1 the operation failed (no answer, drive refused, ...),
2 bad input (arguments, hex, files), 130 interrupted.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import logging
import os
import re
import sys
from collections.abc import Sequence
from typing import NoReturn

from pyuss import __version__
from pyuss.cli._help import actions
from pyuss.errors import UssError

COMMANDS: tuple[str, ...] = (
    "demo",
    "scan",
    "read",
    "write",
    "params",
    "backup",
    "diff",
    "restore",
    "status",
    "ack",
    "describe",
    "mirror",
    "run",
    "gateway",
    "simulate",
    "bus",
    "monitor",
    "wireshark",
    "decode",
    "web",
    "log",
    "bass",
    "ksvario",
)

SUMMARIES: dict[str, str] = {
    "demo": "run the master against three simulated drives on a virtual bus",
    "scan": "find drives, their baud rate and telegram layout",
    "read": "read parameter values from a drive",
    "write": "write a parameter value of a drive",
    "params": "list the known parameters of a profile or drive, searchable",
    "backup": "read a drive's parameter set into a file",
    "diff": "compare a drive with a backup, or two backups",
    "restore": "write a backup file back to a drive",
    "status": "show a drive's state, status word and values",
    "ack": "acknowledge a drive's fault",
    "describe": "read the description of a parameter",
    "mirror": "send mirror telegrams and check they come back unchanged",
    "run": "switch a drive on, follow its ramp live, switch it off on Ctrl+C",
    "gateway": "serve USS drives on Modbus TCP, MQTT (Home Assistant) and OPC UA",
    "simulate": "simulate drives (USS slaves) on a pty, TCP, serial port or virtual bus",
    "bus": "run a virtual RS-485 bus (ptys, TCP) with true character timing",
    "monitor": "listen to a USS line, decode and pair telegrams, write captures",
    "wireshark": "install or locate the Wireshark dissector for monitor captures",
    "decode": "decode a telegram given in hex",
    "web": "a commissioning page in the browser: bus, drives, parameters, trend, monitor",
    "log": "log drive values to a CSV file (status, actual values, parameters)",
    "bass": "Baumueller BASS service protocol (RS-232): read, write, simulated ring",
    "ksvario": "PMA KS VARIO over PROFIBUS-DP: read, write, simulate, GSD file",
}
"""The line of each command in `uss --help`, as its module registers it (a test keeps them
equal); a command missing here is imported to build the list."""

ONE_SHOT = frozenset(
    {"scan", "read", "write", "describe", "mirror", "params", "backup", "diff", "restore"}
    | {"status", "ack"}
)
"""Commands whose outcome is their one line of output: their log warnings (a slave that does
not send, ...) stay quiet unless -v asks for them, so a failure reads as one line."""

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """argparse's parser, except that with ``--json`` on the command line a refused argument
    is the JSON error object on stdout (``UsageError``, exit code 2), as every other failure
    of a command that takes ``--json``. Sub-command parsers are of the same class."""

    json_errors = False
    command: str | None = None
    _intermixing = False

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """A command's words and options in any order (``uss read 3 1120 --port X 1121``):
        argparse's intermixed parsing for the commands, whose parsers hold no sub-commands."""
        if self.prog == "uss" or _Parser._intermixing or self._subcommands():
            return super().parse_known_args(args, namespace)
        _Parser._intermixing = True
        try:
            return self.parse_known_intermixed_args(args, namespace)
        except TypeError:  # a kind of argument intermixed parsing does not take
            return super().parse_known_args(args, namespace)
        finally:
            _Parser._intermixing = False

    def _subcommands(self) -> bool:
        return any(isinstance(a, argparse._SubParsersAction) for a in self._actions)

    def error(self, message: str) -> NoReturn:
        owner = self._command_parser()
        if owner is not None:  # words left over: the command's, with its usage
            owner.error(message)
        if _Parser.json_errors:
            from pyuss.cli._output import failure, print_json, usage_error

            prog = self.prog
            if prog == "uss" and _Parser.command:  # left over for the top parser to report
                prog = f"uss {_Parser.command}"
            print_json(failure(_Parser.command, usage_error(f"{prog}: {message}")))
            self.exit(EXIT_USAGE)
        super().error(message)

    def _command_parser(self) -> argparse.ArgumentParser | None:
        """The parser of the command on the line, when this is the parser of `uss` itself
        (argparse leaves the words no parser took to the top one)."""
        if self.prog != "uss" or not _Parser.command:
            return None
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                found = action.choices.get(_Parser.command)
                return found if isinstance(found, argparse.ArgumentParser) else None
        return None


def build_parser(command: str | None = None, *, lazy: bool = False) -> argparse.ArgumentParser:
    """The parser of `uss`. ``lazy``: import only the module of ``command`` (None: none) and
    list the other commands by their summaries; otherwise every command module is imported."""
    parser = _Parser(
        prog="uss",
        description="Talk to drives over the USS protocol (Siemens MICROMASTER and SINAMICS, "
        "NORD, Baumueller, KS VARIO): find them on a line, read and write their parameters, "
        "run them; simulate drives and RS-485 lines, listen to a line, decode telegrams. "
        "'uss COMMAND --help' says more about each command.",
        epilog="exit codes: 0 done, 1 the operation failed, 2 bad input, 130 interrupted. "
        "Documentation: README.md and docs/ of the project.",
    )
    parser.add_argument("--version", action="version", version=f"pyuss {__version__}")
    parser.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=0,
        help="show warnings and progress on stderr; -vv also every telegram sent and received "
        "(logger pyuss.wire)",
    )
    sub = actions(parser, "command", "COMMAND")
    for name in COMMANDS:
        if lazy and name != command and name in SUMMARIES:
            sub.add_parser(name, help=SUMMARIES[name], add_help=False)
        else:
            importlib.import_module(f"pyuss.cli.{name}").register(sub)
    return parser


def command_of(argv: Sequence[str]) -> str | None:
    """The sub-command named in ``argv``: the first word that is no option (the options of
    `uss` itself take no value)."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


_NEGATIVE_NUMBER = re.compile(r"^-\d+$|^-\d*\.\d+$")
"""A word argparse takes as a negative number, not an option (its own rule)."""


def _is_option(word: str) -> bool:
    """Whether argparse reads ``word`` as an option (its rules: not ``-`` alone, not a
    negative number, no space)."""
    return (
        word.startswith("-")
        and word != "-"
        and not _NEGATIVE_NUMBER.match(word)
        and " " not in word
    )


def _known(parser: argparse.ArgumentParser, word: str) -> bool:
    """Whether ``parser`` takes the option ``word``: its own, with ``=VALUE``, a prefix of one
    of its long options (argparse's abbreviations; an ambiguous one it names itself), or a
    short option with its value or more short flags attached (``-vv``)."""
    strings = parser._option_string_actions
    name = word.split("=", 1)[0]
    if name in strings:
        return True
    if word.startswith("--"):
        return any(option.startswith(name) for option in strings if option.startswith("--"))
    return word[:2] in strings


def unknown_option(
    parser: argparse.ArgumentParser, words: Sequence[str]
) -> tuple[argparse.ArgumentParser, str] | None:
    """The first option in ``words`` that the (sub-)command it is given to does not take,
    with that command's parser; None when there is none. Found before parsing, so that an
    unknown option is named as such, not reported as a missing required one (or taken for
    the positional argument that follows it)."""
    for index, word in enumerate(words):
        if word == "--":  # the rest are positional
            return None
        if _is_option(word):
            if not _known(parser, word):
                return parser, word
            continue
        subparsers = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if subparsers and word in subparsers[0].choices:
            return unknown_option(subparsers[0].choices[word], words[index + 1 :])
    return None


def _refuse_unknown_option(parser: argparse.ArgumentParser, words: Sequence[str]) -> None:
    """Exit 2 with "unknown option --prot; did you mean --port?" where ``words`` hold one."""
    found = unknown_option(parser, words)
    if found is None:
        return
    owner, word = found
    name = word.split("=", 1)[0]
    options = sorted({o for o in owner._option_string_actions if o.startswith("--")})
    close = difflib.get_close_matches(name, options, n=1, cutoff=0.6)
    if owner is not parser and _known(parser, word):
        hint = f"{name} is an option of uss itself: give it before the command"
    elif close:
        hint = f"did you mean {close[0]}?"
    else:
        hint = f"'{owner.prog} --help' lists its options"
    owner.error(f"unknown option {name}; {hint}")


def main(argv: Sequence[str] | None = None) -> int:
    words = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(command_of(words), lazy=True)
    _Parser.json_errors = "--json" in words
    _Parser.command = command_of(words)
    try:
        _refuse_unknown_option(parser, words)
        args = parser.parse_args(words)
    finally:
        _Parser.json_errors = False
    quiet = logging.ERROR if args.command in ONE_SHOT else logging.WARNING
    level = quiet if args.verbose == 0 else (logging.INFO if args.verbose == 1 else logging.DEBUG)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    if "asyncio" in sys.modules:  # the command runs an event loop: keep sub-ms timing
        from pyuss.loop import installed

        with installed(least_slack=args.command not in ONE_SHOT):
            return _run(args)
    return _run(args)


def _run(args: argparse.Namespace) -> int:
    try:
        code: int = args.func(args)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except UssError as exc:
        if getattr(args, "json", False):
            from pyuss.cli._output import error_object, failure, print_json

            print_json(failure(args.command, error_object(exc, EXIT_FAILED)))
        else:
            print(f"uss {args.command}: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except BrokenPipeError:
        # The reader went away (``uss ... | head``): stop quietly, like any filter does.
        _silence_stdout()
        return EXIT_OK
    return code


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush raises no second error."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
