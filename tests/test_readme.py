r"""The README is where a new user starts, and every example of README.md and docs/*.md runs as
written: this test collects every fenced block of those files (also of pages added later) and
runs it by the rules of README.md, "Examples in the documentation":

- ```python: a script, run with Python in an empty directory; it must end with exit code 0.
- ```console: a session: ``$ COMMAND`` lines are run in order, the lines after one are (some
  of) what it prints on stdout or stderr - each must be one of its lines; ``...`` stands for
  lines left out, text after two blanks and ``#`` is a comment, a pty path (``/dev/pts/7``)
  or the port of ``127.0.0.1:PORT`` stands for any, as does a time in milliseconds
  (``1.32 ms``). A command shown printing an error
  (``uss NAME: ...``) must fail, the others succeed. ``$ COMMAND &`` runs in the background:
  the lines shown are the first it prints, and what it really printed replaces them (device
  paths, URLs and their HOST:PORT) in the commands that follow.
- ```sh: commands, one per line (``#`` comments, ``\`` at the end continues a line), run as
  in a console session.
- ```toml: parsed; a parameter file (with ``[profile]``) is read as the simulator reads it.
- ```text: output, a file format, a synopsis: not run.

Commands that serve until stopped (``uss simulate``, ``uss bus``, ``uss bass ring``,
``uss ksvario simulate``, ``uss web``, ``uss gateway``, ``uss monitor`` on a port, ``uss run``
and ``uss log`` without ``--duration`` or ``--count``) get Ctrl+C (SIGINT) once they have
printed something, and must then end with 0 or 130; background
commands get it when the block is done. Everything runs in an empty temporary directory, with
``HOME`` there too (``uss wireshark install`` writes below it).

An HTML comment on the line(s) before a block changes how it runs:

- ``<!-- run with /dev/ttyUSB0 = COMMAND -->``: COMMAND starts in the background before the
  block and the first line it prints (a simulator's pty) replaces ``/dev/ttyUSB0`` in the
  block - for examples written for the user's own adapter.
- ``<!-- run by tests/PATH.py -->``: another test runs the block (and names the page); on a
  line of its own anywhere on the page, ``<!-- page run by tests/PATH.py -->`` leaves every
  block of the page to that test (a session that runs through several blocks).
- ``<!-- not run: REASON -->``: the block cannot run in a test (real hardware); kept rare.
"""

from __future__ import annotations

import os
import queue
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import pytest

ROOT = Path(__file__).resolve().parents[1]
KINDS = ("python", "console", "sh", "toml", "text")
TIMEOUT = 120.0
"""Longest a command or script may take."""
SETTLE = 1.0
"""How long a command that serves until stopped runs after its first output."""

_FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```[ \t]*$", re.S | re.M)
_COMMENT = re.compile(r"^<!--\s*(.*?)\s*-->\s*$")
_RUN_WITH = re.compile(r"run with (\S+) = (.+)")
_PAGE_RUN_BY = re.compile(r"^<!--\s*page run by (tests/\S+)\s*-->\s*$", re.M)
_SHOWN_COMMENT = re.compile(r"\s{2,}#.*$")
_ERROR_SHOWN = re.compile(r"^uss [a-z]+( [a-z]+)?: ")


# -- collecting ---------------------------------------------------------------------------------


@dataclass
class Example:
    path: Path
    line: int
    kind: str
    code: str
    directives: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def examples(path: Path) -> list[Example]:
    text = path.read_text(encoding="utf-8")
    page = _PAGE_RUN_BY.search(text)
    found = []
    for match in _FENCE.finditer(text):
        line = text.count("\n", 0, match.start()) + 1
        before = text[: match.start()].splitlines()
        directives: list[str] = []
        while before and (comment := _COMMENT.match(before[-1].strip())):
            directives.insert(0, comment.group(1))
            before.pop()
        if page is not None:
            directives.append(f"run by {page.group(1)}")
        found.append(Example(path, line, match.group(1).strip(), match.group(2), directives))
    return found


ALL = [example for page in pages() for example in examples(page)]
RUN = [example for example in ALL if example.kind != "text"]


def needs(example: Example) -> list[pytest.MarkDecorator]:
    """What the system must have to run ``example``: a session, or a command started before
    the block, runs as from a terminal (`_as_from_a_terminal`, SIGINT: POSIX); a ``--pty``
    needs a pty."""
    marks = []
    if example.kind in ("console", "sh") or any(_RUN_WITH.fullmatch(d) for d in example.directives):
        marks.append(pytest.mark.posix("runs the commands as a terminal does (preexec_fn, SIGINT)"))
    if "--pty" in example.code or any("--pty" in d for d in example.directives):
        marks.append(pytest.mark.pty)
    return marks


def test_readme_lists_every_docs_page_once_under_one_heading() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert text.count("\n## Documentation\n") == 1
    section = text.split("\n## Documentation\n", 1)[1].split("\n## ", 1)[0]
    listed = re.findall(r"^- `(docs/[\w.-]+\.md)`", section, flags=re.MULTILINE)
    pages = sorted(f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md"))
    assert sorted(listed) == pages
    assert len(listed) == len(set(listed))


def test_every_block_says_what_it_is() -> None:
    """A block without one of the kinds would silently not run."""
    unknown = [f"{e.name} ```{e.kind}" for e in ALL if e.kind not in KINDS]
    assert not unknown, f"give these blocks one of {', '.join(KINDS)}: {unknown}"
    for example in ALL:
        for directive in example.directives:
            assert (
                _RUN_WITH.fullmatch(directive)
                or directive.startswith("run by tests/")
                or re.fullmatch(r"not run: \S.*", directive)
            ), f"{example.name}: unknown directive <!-- {directive} -->"


def test_the_rules_find_a_page_added_later(tmp_path: Path) -> None:
    page = tmp_path / "new.md"
    page.write_text("# New\n\n<!-- not run: needs hardware -->\n```sh\nuss read 5 52\n```\n")
    (found,) = examples(page)
    assert (found.kind, found.line, found.directives) == ("sh", 4, ["not run: needs hardware"])
    page.write_text(
        "# New\n\n<!-- page run by tests/new.py -->\n\n```console\n$ uss read 5 52\n```\n"
    )
    (found,) = examples(page)
    assert found.directives == ["run by tests/new.py"]


# -- running ------------------------------------------------------------------------------------


def _serves(words: list[str]) -> bool:
    """Whether ``uss WORDS`` runs until it is stopped."""
    if not words or words[0] != "uss":
        return False
    command = words[1:3]
    if command[:1] in (["simulate"], ["bus"]) or command in (["bass", "ring"],):
        return "--duration" not in words
    if command == ["ksvario", "simulate"] or command[:1] in (["web"], ["gateway"]):
        return True
    if command[:1] == ["log"]:
        return "--duration" not in words and "--count" not in words
    if command[:1] == ["monitor"]:
        return "--read" not in words and "--duration" not in words and "--count" not in words
    if command[:1] == ["run"]:
        return "--duration" not in words
    return False


class Shell:
    """Runs the commands of one block in ``cwd``; keeps background commands until `close`."""

    def __init__(self, cwd: Path) -> None:
        self.cwd = cwd
        self.env = {**os.environ, "HOME": str(cwd), "PYTHONUNBUFFERED": "1", "COLUMNS": "100"}
        self.background: list[_Process] = []
        self.replace: dict[str, str] = {}

    def substitute(self, text: str) -> str:
        """``text`` with what the example shows replaced by what really came, all at once
        (a real ``/dev/pts/8`` is not replaced again) and whole words only."""
        if not self.replace:
            return text
        shown = sorted(self.replace, key=len, reverse=True)
        pattern = "|".join(re.escape(s) for s in shown)
        return re.sub(rf"({pattern})(?![\w.])", lambda m: self.replace[m.group(1)], text)

    def words(self, command: str) -> list[str]:
        return shlex.split(self.substitute(command), comments=True)

    def argv(self, words: list[str]) -> list[str]:
        if words[0] == "uss":
            return [sys.executable, "-m", "pyuss.cli.main", *words[1:]]
        if words[0] == "python":
            return [sys.executable, *words[1:]]
        raise AssertionError(f"examples run uss and python only, not {words[0]!r}")

    def popen(self, words: list[str]) -> _Process:
        return _Process(
            subprocess.Popen(
                self.argv(words),
                cwd=self.cwd,
                env=self.env,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                preexec_fn=_as_from_a_terminal,
            )
        )

    def start(self, command: str, lines: int) -> list[str]:
        """Start ``command`` in the background; the first ``lines`` lines it prints on stdout
        (with 0: once it printed anything)."""
        process = self.popen(self.words(command))
        self.background.append(process)
        if lines == 0:
            assert process.first_output(TIMEOUT), f"{command}: printed nothing"
            return []
        return [process.stdout_line(TIMEOUT, command) for _ in range(lines)]

    def run(self, command: str) -> tuple[int, list[str]]:
        """Run ``command`` to its end (one that serves gets Ctrl+C once it printed); its exit
        code and the lines it printed on stdout and stderr."""
        words = self.words(command)
        process = self.popen(words)
        if _serves(words):
            assert process.first_output(TIMEOUT), f"{command}: printed nothing"
            time.sleep(SETTLE)
            process.popen.send_signal(signal.SIGINT)
        code = process.wait(TIMEOUT, command)
        return code, process.out + process.err

    def learn(self, shown: list[str], printed: list[str]) -> None:
        """What a background command printed replaces what the example shows it printing."""
        for doc, real in zip(shown, printed, strict=False):
            for doc_word, real_word in zip(doc.split(), real.split(), strict=False):
                if doc_word != real_word:
                    self.replace[doc_word] = real_word
                    if "://" in doc_word and "://" in real_word:
                        self.replace[doc_word.split("://", 1)[1]] = real_word.split("://", 1)[1]

    def close(self) -> None:
        for process in reversed(self.background):
            if process.popen.poll() is None:
                process.popen.send_signal(signal.SIGINT)
            process.wait(30, f"{process.popen.args} on Ctrl+C")


def _as_from_a_terminal() -> None:
    """In the child: Ctrl+C as a terminal delivers it, even when the tests run in the
    background of a script (where SIGINT starts out ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class _Process:
    """A command's process; threads collect the lines it prints, so none blocks on a full
    pipe and lines can be awaited one by one."""

    def __init__(self, popen: subprocess.Popen[str]) -> None:
        self.popen = popen
        self.out: list[str] = []
        self.err: list[str] = []
        self._lines: queue.Queue[str | None] = queue.Queue()
        self._any = threading.Event()
        assert popen.stdout is not None and popen.stderr is not None
        self._threads = [
            threading.Thread(target=self._read, args=(popen.stdout, self.out, True)),
            threading.Thread(target=self._read, args=(popen.stderr, self.err, False)),
        ]
        for thread in self._threads:
            thread.start()

    def _read(self, stream: IO[str], into: list[str], stdout: bool) -> None:
        for line in stream:
            into.append(line.rstrip("\n"))
            self._any.set()
            if stdout:
                self._lines.put(line.rstrip("\n"))
        self._any.set()
        if stdout:
            self._lines.put(None)

    def first_output(self, timeout: float) -> bool:
        return self._any.wait(timeout) and bool(self.out or self.err)

    def stdout_line(self, timeout: float, command: str) -> str:
        try:
            line = self._lines.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"{command}: printed only {self.out}") from None
        assert line is not None, f"{command}: ended after {self.out}: {self.err}"
        return line

    def wait(self, timeout: float, command: str) -> int:
        try:
            code = self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self.popen.wait()
            raise AssertionError(f"{command}: still running after {timeout:g} s") from None
        finally:
            for thread in self._threads:
                thread.join(30)
        return code


def _shown(line: str) -> str | None:
    """A line of shown output as a pattern (None for ``...`` and blank lines)."""
    line = _SHOWN_COMMENT.sub("", line).rstrip()
    if not line.strip() or line.strip() == "...":
        return None
    pattern = re.escape(line)
    pattern = re.sub(r"/dev/pts/\d+", r"/dev/pts/\\d+", pattern)
    # a time measured, and the blanks after it in a table
    pattern = re.sub(r"\d+\\\.\d+\\ ms(\\ )*", r"\\d+\\.\\d+\\ ms\\ *", pattern)
    return re.sub(r"127\\\.0\\\.0\\\.1:\d+", r"127\\.0\\.0\\.1:\\d+", pattern)


def _session(example: Example) -> list[tuple[str, list[str]]]:
    steps: list[tuple[str, list[str]]] = []
    for line in re.sub(r"\\\n\s*", " ", example.code).splitlines():
        if example.kind == "sh":
            if line.split("#", 1)[0].strip():
                steps.append((line.strip(), []))
        elif line.startswith("$ "):
            steps.append((line[2:].strip(), []))
        elif line.strip():
            assert steps, f"{example.name}: output before the first '$ ' command: {line!r}"
            steps[-1][1].append(line)
    return steps


def _run_session(example: Example, shell: Shell) -> None:
    for command, shown in _session(example):
        patterns = [p for p in map(_shown, shown) if p is not None]
        bare = _SHOWN_COMMENT.sub("", command).rstrip()
        if bare.endswith("&"):
            printed = shell.start(bare[:-1].rstrip(), len(patterns))
            shell.learn([_SHOWN_COMMENT.sub("", s).strip() for s in shown if _shown(s)], printed)
            continue
        code, lines = shell.run(command)
        words = shell.words(command)
        for pattern in patterns:
            assert any(re.fullmatch(pattern, line.rstrip()) for line in lines), (
                f"{example.name}: `{command}` did not print {pattern!r}; it printed:\n"
                + "\n".join(lines)
            )
        if _serves(words):
            assert code in (0, 130), f"{example.name}: `{command}` ended with {code}: {lines}"
        elif any(_ERROR_SHOWN.match(_SHOWN_COMMENT.sub("", s)) for s in shown):
            assert code != 0, f"{example.name}: `{command}` was shown failing but succeeded"
        else:
            assert code == 0, f"{example.name}: `{command}` ended with {code}:\n" + "\n".join(lines)


def _run_python(example: Example, shell: Shell) -> None:
    source = shell.cwd / "example.py"
    source.write_text(shell.substitute(example.code), encoding="utf-8")
    done = subprocess.run(
        [sys.executable, str(source)],
        cwd=shell.cwd,
        env=shell.env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    assert done.returncode == 0, f"{example.name}:\n{done.stdout}{done.stderr}"
    check = CHECKS.get(example.name.split(":")[0], {}).get(example.code.split("\n", 1)[0])
    if check is not None:
        check(done.stdout)


def _run_toml(example: Example) -> None:
    data = tomllib.loads(example.code)
    if "profile" in data:
        from pyuss.drive.loader import parse_database

        parse_database(example.code, example.name)


def _after_ramping_up(out: str) -> None:
    """The README's script waits until the drive has ramped up, not only until it answers."""
    state, percent = out.splitlines()[-1].rsplit(" ", 1)
    assert state == "operation enabled" and float(percent) >= 49.9, out


CHECKS = {"README.md": {"import asyncio": _after_ramping_up}}
"""Further checks of a script's output: page, first line of the script -> check."""


@pytest.mark.parametrize("example", [pytest.param(e, marks=needs(e), id=e.name) for e in RUN])
def test_the_example_runs_as_written(example: Example, tmp_path: Path) -> None:
    for directive in example.directives:
        if directive.startswith("not run: "):
            pytest.skip(directive)
        if directive.startswith("run by "):
            runner = ROOT / directive.removeprefix("run by ")
            assert runner.is_file(), f"{example.name}: {runner} does not exist"
            assert example.path.name in runner.read_text(encoding="utf-8")
            pytest.skip(directive)
    if example.kind == "toml":
        _run_toml(example)
        return
    shell = Shell(tmp_path)
    try:
        for directive in example.directives:
            match = _RUN_WITH.fullmatch(directive)
            assert match is not None
            (device,) = shell.start(match.group(2), 1)
            shell.replace[match.group(1)] = device.strip()
        if example.kind == "python":
            _run_python(example, shell)
        else:
            _run_session(example, shell)
    finally:
        shell.close()
