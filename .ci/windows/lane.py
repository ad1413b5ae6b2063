"""The Windows lane: pyuss installed from its wheel into Windows CPython 3.13 under Wine, and
run as a Windows user runs it, against and beside pyuss on Linux (docs/windows-lane.md).

    .venv/bin/python .ci/windows/lane.py            # what make test-windows runs
    .venv/bin/python .ci/windows/lane.py -k master  # only the checks whose name has "master"
    .venv/bin/python .ci/windows/lane.py --no-prepare   # Windows Python as it is in build/wine
    .venv/bin/python .ci/windows/lane.py --linux    # the checks with Linux processes only:
                                                    # checks the lane itself, no Wine

One line per check, PASS NAME or FAIL NAME: REASON (then the command and the last lines of
its output, indented), and at the end "N passed, N failed"; exit code 1 when any failed.
Every process is bounded by a timeout, and every address is on 127.0.0.1.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import contextlib
import json
import os
import re
import select
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import tomllib
import urllib.request
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import wine

LINUX_USS = str(Path(sys.executable).with_name("uss"))
INTERRUPT = wine.HERE / "interrupt.py"
RUN_TIMEOUT = 90.0  # one Windows command, start of Wine and of Python included
FIRST_LINE_TIMEOUT = 60.0  # a server's first line
STOP_TIMEOUT = 20.0  # a server's end after its Ctrl+C or SIGINT
WORK_DIR = r"C:\pyuss lane"  # the Windows processes' working folder, and their files
SIM_ARGS = ["--address", "5", "--layout", "v,2"]
LINE = ["--layout", "v,2"]
GENERIC = [*LINE, "--profile", "generic"]  # backup, diff, restore: a drive of known kind


class Failed(Exception):
    """A check's failure: the reason, and the command with its output when there is one."""

    def __init__(self, reason: str, command: list[str] | None = None, output: str = "") -> None:
        super().__init__(reason)
        self.reason = reason
        self.command = command
        self.output = output


def expect(ok: object, reason: str, done: Done | None = None) -> None:
    if not ok:
        if done is not None:
            raise Failed(reason, done.command, done.output)
        raise Failed(reason)


@dataclass
class Done:
    """A command that ran to its end."""

    command: list[str]
    returncode: int
    stdout: str
    stderr: str

    @property
    def output(self) -> str:
        return self.stdout + ("\n" if self.stdout and self.stderr else "") + self.stderr


def decode(data: bytes) -> str:
    """Windows Python writes to a pipe in the ANSI code page (cp1252 here), pyuss on Linux
    in UTF-8."""
    try:
        return data.decode()
    except UnicodeDecodeError:
        return data.decode("cp1252", errors="replace")


# --- how the "Windows" side runs: under Wine, or (--linux) natively --------------------------

LINUX_ONLY = False


def windows_uss() -> list[str]:
    return [LINUX_USS] if LINUX_ONLY else [str(wine.uss_exe())]


def windows_python() -> list[str]:
    return [sys.executable] if LINUX_ONLY else [str(wine.python_exe())]


def windows_file(path: str) -> tuple[str, Path]:
    """A file of the Windows processes: its name for them (C:\\pyuss lane\\...) and for Linux."""
    if LINUX_ONLY:
        linux = wine.BUILD / "linux-only" / path.split("\\")[-1]
        return str(linux), linux
    return path, wine.linux_path(path)


def work_dir() -> Path:
    return windows_file(WORK_DIR + "\\x")[1].parent


def start_windows(args: list[str], stdin: int = subprocess.DEVNULL) -> subprocess.Popen[bytes]:
    work_dir().mkdir(parents=True, exist_ok=True)
    if LINUX_ONLY:
        return subprocess.Popen(
            args, stdin=stdin, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=work_dir()
        )
    return wine.popen(args, stdin=stdin, cwd=work_dir())


def run_windows(args: list[str], timeout: float = RUN_TIMEOUT) -> Done:
    proc = start_windows(args)
    out, err, ended = wine.drain_both(proc, timeout)
    done = Done(args, proc.returncode, decode(out), decode(err))
    if not ended:
        raise Failed(f"no end within {timeout:.0f} s (killed)", args, done.output)
    return done


def run_linux(args: list[str], timeout: float = RUN_TIMEOUT) -> Done:
    try:
        proc = subprocess.run(
            args,
            capture_output=True,
            timeout=timeout,
            cwd=wine.BUILD,
            stdin=subprocess.DEVNULL,
            check=False,
        )
    except subprocess.TimeoutExpired as e:
        output = decode((e.stdout or b"") + (e.stderr or b""))
        raise Failed(f"no end within {timeout:.0f} s (killed)", args, output) from None
    return Done(args, proc.returncode, decode(proc.stdout), decode(proc.stderr))


def uss_win(*args: str, timeout: float = RUN_TIMEOUT) -> Done:
    return run_windows([*windows_uss(), *args], timeout)


def uss_linux(*args: str, timeout: float = RUN_TIMEOUT) -> Done:
    return run_linux([LINUX_USS, *args], timeout)


def no_traceback(done: Done) -> None:
    expect("Traceback (most recent call last)" not in done.output, "a traceback", done)


# --- servers --------------------------------------------------------------------------------


@dataclass
class Server:
    """A long-running command: its output lines as they come, stopped at the end."""

    command: list[str]
    proc: subprocess.Popen[bytes]
    windows: bool
    stdout: list[str] = field(default_factory=list)
    stderr: list[str] = field(default_factory=list)
    result: dict[str, object] | None = None
    _cond: threading.Condition = field(default_factory=threading.Condition)
    _threads: list[threading.Thread] = field(default_factory=list)

    def output(self) -> str:
        with self._cond:
            return "\n".join([*self.stdout, *self.stderr])

    def wait_line(self, pattern: str, timeout: float = FIRST_LINE_TIMEOUT) -> re.Match[str]:
        """The first line of stdout matching pattern (a regular expression)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            seen = 0
            while True:
                for line in self.stdout[seen:]:
                    found = re.search(pattern, line)
                    if found:
                        return found
                seen = len(self.stdout)
                left = deadline - time.monotonic()
                if left <= 0 or self._ended():
                    break
                self._cond.wait(min(left, 0.2))
        reason = "ended" if self._ended() else f"printed nothing within {timeout:.0f} s"
        raise Failed(f"no line like {pattern!r}: it {reason}", self.command, self.output())

    def _ended(self) -> bool:
        return self.proc.poll() is not None and all(not t.is_alive() for t in self._threads)

    def stop(self) -> None:
        """Ctrl+C (Windows, through interrupt.py) or SIGINT (Linux), then wait for the end."""
        if self.windows:
            with contextlib.suppress(OSError):
                assert self.proc.stdin is not None
                self.proc.stdin.write(b"stop\n")
                self.proc.stdin.close()
        elif self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout=STOP_TIMEOUT + 15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for thread in self._threads:
            thread.join(timeout=5)
        if not self.windows:
            self.result = {"returncode": self.proc.returncode, "killed": False}


def _reader(server: Server, stream: object, lines: list[str], relayed: bool) -> None:
    """Lines of a pipe into a list; interrupt.py's relayed lines into stdout/stderr/result.

    Until the pipe's end, or until the process has exited and the pipe is empty: Wine's
    own processes may keep a pipe open past the program's end."""
    fd = stream.fileno()  # type: ignore[attr-defined]
    buffer = b""
    while True:
        readable, _, _ = select.select([fd], [], [], 0.2)
        data = b""
        if readable:
            try:
                data = os.read(fd, 65536)
            except OSError:
                data = b""
        elif server.proc.poll() is None:
            continue
        ended = not data
        buffer += data
        parts = buffer.split(b"\n")
        buffer = b"" if ended else parts.pop()
        if ended and parts[-1:] == [b""]:
            parts.pop()
        with server._cond:
            for raw in parts:
                line = decode(raw).rstrip("\r")
                if not relayed:
                    lines.append(line)
                elif line.startswith("out: "):
                    server.stdout.append(line[5:])
                elif line.startswith("err: "):
                    server.stderr.append(line[5:])
                elif line.startswith("result: "):
                    server.result = json.loads(line[8:])
                else:
                    server.stderr.append(line)
            server._cond.notify_all()
        if ended:
            return


@contextlib.contextmanager
def windows_server(*args: str) -> Iterator[Server]:
    """A uss command under Windows Python, run by interrupt.py: stopped with Ctrl+C."""
    command = [*windows_uss(), *args]
    if LINUX_ONLY:
        with linux_server(*args) as server:
            yield server
        return
    wrapper = [
        *windows_python(),
        wine.windows_path(INTERRUPT),
        "--timeout",
        str(STOP_TIMEOUT),
        "--",
        *command,
    ]
    proc = start_windows(wrapper, stdin=subprocess.PIPE)
    server = Server(command, proc, windows=True)
    _start_readers(server, relayed=True)
    try:
        yield server
    finally:
        server.stop()


@contextlib.contextmanager
def linux_server(*args: str) -> Iterator[Server]:
    command = [LINUX_USS, *args]
    proc = subprocess.Popen(
        command,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=wine.BUILD,
    )
    server = Server(command, proc, windows=False)
    _start_readers(server, relayed=False)
    try:
        yield server
    finally:
        server.stop()


def _start_readers(server: Server, relayed: bool) -> None:
    streams = [(server.proc.stdout, server.stdout)]
    if not relayed:
        streams.append((server.proc.stderr, server.stderr))
    else:
        # interrupt.py itself writes nothing on stderr but a failure of its own
        streams.append((server.proc.stderr, server.stderr))
    for stream, lines in streams:
        thread = threading.Thread(
            target=_reader, args=(server, stream, lines, relayed), daemon=True
        )
        thread.start()
        server._threads.append(thread)


@contextlib.contextmanager
def linux_simulator(*args: str) -> Iterator[str]:
    """uss simulate on Linux serving TCP on 127.0.0.1: its tcp:// URL."""
    with linux_server("simulate", "--tcp", "127.0.0.1:0", *(args or SIM_ARGS)) as server:
        yield server.wait_line(r"^tcp://127\.0\.0\.1:\d+$").group(0)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def stopped_cleanly(server: Server, expected: int) -> None:
    """The result of a Windows server's Ctrl+C: the exit code expected, no traceback."""
    result = server.result
    output = server.output()
    if result is None:
        raise Failed("interrupt.py gave no result", server.command, output)
    if result.get("exited_before_stop"):
        raise Failed(
            f"ended before the Ctrl+C, exit code {result.get('returncode')}", server.command, output
        )
    if result.get("killed"):
        raise Failed(
            f"still running {STOP_TIMEOUT:.0f} s after Ctrl+C (killed)", server.command, output
        )
    code = result.get("returncode")
    if code != expected:
        shown = f"{code} ({code & 0xFFFFFFFF:#x})" if isinstance(code, int) else str(code)
        raise Failed(f"exit code {shown} after Ctrl+C, expected {expected}", server.command, output)
    if "Traceback (most recent call last)" in WAKEUP_FULL.sub("", output):
        raise Failed("a traceback after Ctrl+C", server.command, output)


WAKEUP_FULL = re.compile(
    r"Exception ignored when trying to send to the signal wakeup fd:\r?\n"
    r"Traceback \(most recent call last\):\r?\n(?:  .*\r?\n)*?"
    r"BlockingIOError: \[WinError 10035\][^\n]*\n?"
)
"""CPython's warning when its signal handler finds the event loop's wake-up socket full,
which Wine's small socket buffers make happen at a Ctrl+C (a Wine shim, docs/windows-lane.md):
not counted as a traceback of pyuss's."""


# --- the checks -------------------------------------------------------------------------------

CHECKS: list[tuple[str, Callable[[], None]]] = []

KNOWN = {
    "Windows uss bus, Linux simulator and master on it; Ctrl+C stops it (exit 0)": (
        "under Wine the characters a Windows uss bus hands on reach a raw TCP station 14 ms "
        "apart (Wine completes a proactor send late), so the simulator takes no telegram "
        "whole (docs/windows-lane.md)"
    ),
    "Windows uss simulate --bus-tcp, Linux uss read over bus://; Ctrl+C stops it (exit 0)": (
        "under Wine the answers of a Windows bus reach a bus:// station 150-200 ms late "
        "(Wine completes a proactor send late: docs/windows-lane.md)"
    ),
}
"""Checks that fail for a reason written down and not yet mended: reported as KNOWN with it,
and counted as skipped, so the lane holds every other check on every change."""


def check(name: str) -> Callable[[Callable[[], None]], Callable[[], None]]:
    def register(fn: Callable[[], None]) -> Callable[[], None]:
        CHECKS.append((name, fn))
        return fn

    return register


def wheel_modules() -> list[str]:
    """The modules of the pyuss wheel, from its file list."""
    (wheel,) = wine.DIST.glob("pyuss-*.whl")
    names = []
    with zipfile.ZipFile(wheel) as whl:
        for name in whl.namelist():
            if name.startswith("pyuss/") and name.endswith(".py"):
                module = name[:-3].replace("/", ".")
                names.append(module.removesuffix(".__init__"))
    return sorted(set(names) - {"pyuss"})


IMPORT_ALL = r"""
import importlib, json, pkgutil, sys, traceback
import pyuss
failed, names = {}, []
def onerror(name):
    failed[name] = traceback.format_exc()
for info in pkgutil.walk_packages(pyuss.__path__, "pyuss.", onerror=onerror):
    names.append(info.name)
    try:
        importlib.import_module(info.name)
    except BaseException:
        failed[info.name] = traceback.format_exc()
print(json.dumps({"file": pyuss.__file__, "names": names, "failed": failed}))
"""


@check("import every pyuss module")
def _imports() -> None:
    done = run_windows([*windows_python(), "-c", IMPORT_ALL], timeout=180)
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    if not LINUX_ONLY:
        expect("site-packages" in report["file"], f"pyuss from {report['file']}", done)
    missing = sorted(set(wheel_modules()) - set(report["names"]))
    # pyuss.system has a module per platform; the other platform's one refuses to import
    other = "._windows" if LINUX_ONLY else "._posix"
    failed = {k: v for k, v in report["failed"].items() if not k.endswith(other)}
    if failed or missing:
        lines = [f"{name}: {tb.strip().splitlines()[-1]}" for name, tb in failed.items()]
        details = "\n".join(tb for tb in failed.values())
        raise Failed(
            f"{len(failed)} of {len(report['names'])} modules do not import"
            + (f" ({', '.join(missing)} not found)" if missing else "")
            + (": " + "; ".join(lines) if lines else ""),
            ["python", "-c", "<import every module of pkgutil.walk_packages(pyuss.__path__)>"],
            details,
        )


@check("python -m pyuss --version")
def _version() -> None:
    linux = uss_linux("--version")
    done = run_windows([*windows_python(), "-m", "pyuss", "--version"])
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect(
        done.stdout.strip() == linux.stdout.strip(),
        f"printed {done.stdout.strip()!r}, Linux {linux.stdout.strip()!r}",
        done,
    )


def commands(help_text: str, path: list[str]) -> list[list[str]]:
    """The commands (or a command's actions) that a uss --help on Linux lists."""
    found: list[list[str]] = []
    section = re.search(r"positional arguments:\n  [A-Z]+\n((?:    .*\n|      .*\n)+)", help_text)
    if section:
        for line in section.group(1).splitlines():
            name = re.match(r"^    ([a-z][a-z0-9-]*)(?:\s|$)", line)
            if name:
                found.append([*path, name.group(1)])
    return found


@check("uss COMMAND --help, every command")
def _help() -> None:
    names = commands(uss_linux("--help").stdout, [])
    expect(len(names) >= 10, f"uss --help on Linux lists {len(names)} commands")
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        helps = list(pool.map(lambda c: uss_linux(*c, "--help").stdout, names))
    for command, text in zip(list(names), helps, strict=True):
        names.extend(commands(text, command))

    def one(command: list[str]) -> tuple[list[str], Done]:
        return command, uss_win(*command, "--help")

    failures = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=3) as pool:
        for command, done in pool.map(one, names):
            usage = f"usage: uss {' '.join(command)}"
            if done.returncode != 0 or not done.stdout.startswith(usage) or done.stderr.strip():
                failures.append((command, done))
    if failures:
        command, done = failures[0]
        listed = ", ".join(" ".join(c) for c, _ in failures)
        raise Failed(
            f"{len(failures)} of {len(names)} fail ({listed}); first: exit code {done.returncode}",
            done.command,
            done.output,
        )


def profiles() -> list[str]:
    """The drive profiles uss simulate --help names on Linux."""
    # argparse may wrap a name at its hyphen ("nord-" / "sk500e"): such a break joins up again
    wrapped = re.sub(r"-\n\s*", "-", uss_linux("simulate", "--help").stdout)
    text = " ".join(wrapped.split())
    found = re.search(r"--profile NAME the drive family to simulate: ([a-z0-9, -]+?) \(", text)
    expect(found, "no profile list in uss simulate --help")
    assert found
    return [p.strip() for p in found.group(1).split(",") if p.strip()]


@check("uss params, every profile (output in the ANSI code page)")
def _params() -> None:
    names = [p for p in profiles() if p not in ("ksvario", "bass")]
    expect(len(names) >= 5, f"{len(names)} profiles found")

    def one(profile: str) -> tuple[Done, Done]:
        return uss_win("params", "--profile", profile), uss_linux("params", "--profile", profile)

    with concurrent.futures.ThreadPoolExecutor(max_workers=3) as pool:
        for done, linux in pool.map(one, names):
            expect(done.returncode == 0, f"exit code {done.returncode}", done)
            no_traceback(done)
            expect(
                done.stdout.splitlines() == linux.stdout.splitlines(),
                "not the lines uss params prints on Linux",
                done,
            )


@check("uss demo")
def _demo() -> None:
    done = uss_win("demo", timeout=180)
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    no_traceback(done)


# --- the master on Windows, drives simulated on Linux ----------------------------------------

MASTER: dict[str, object] = {}
BACKUP = WORK_DIR + "\\Ünïcode backup.toml"


@contextlib.contextmanager
def master_line() -> Iterator[str]:
    with linux_simulator() as url:
        MASTER["url"] = url
        yield url


def _master_url() -> str:
    error = MASTER.get("error")
    if isinstance(error, Failed):
        raise Failed("no Linux simulator: " + error.reason, error.command, error.output)
    return str(MASTER["url"])


@check("master tcp:// uss read")
def _read() -> None:
    done = uss_win("read", "5", "52", "18", "--port", _master_url(), *LINE)
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect(done.stdout.startswith("P52 = 16384 (4000h)"), "not P52 = 16384 (4000h)", done)
    expect("P18 = " in done.stdout, "no P18", done)


@check("master tcp:// uss write --verify")
def _write() -> None:
    done = uss_win("write", "5", "18", "0x7000", "--verify", "--port", _master_url(), *LINE)
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect("P18 = 28672 (7000h)" in done.stdout, "not P18 = 28672 (7000h)", done)
    back = uss_linux("read", "5", "18", "--port", _master_url(), *LINE)
    expect("P18 = 28672" in back.stdout, "Linux reads back another P18", back)


BLOCKING = """
from pyuss.master.blocking import Master
with Master({url!r}, baud=9600) as bus:
    drive = bus.drive(5, layout="v,2")
    print(drive.read(52), drive.write(18, 0x7000), drive.read(18), bus.exchange(5).address)
"""


@check("master tcp:// pyuss.master.blocking over socket:// (pyserial, the calling thread)")
def _blocking() -> None:
    url = _master_url().replace("tcp://", "socket://")
    done = run_windows([*windows_python(), "-c", BLOCKING.format(url=url)])
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect(done.stdout.split() == ["16384", "28672", "28672", "5"], "not 16384 28672 28672 5", done)


@check("master tcp:// uss status")
def _status() -> None:
    done = uss_win("status", "5", "--port", _master_url(), *LINE)
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect(re.search(r"^drive 5: ", done.stdout, re.M), "no 'drive 5:' line", done)
    expect("status word " in done.stdout, "no status word", done)


@check("master tcp:// uss scan")
def _scan() -> None:
    done = uss_win("scan", "--address", "4-6", "--port", _master_url())
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect(re.search(r"^\s+5\s+9600\s+v,2\s", done.stdout, re.M), "drive 5 not found", done)


@check("master tcp:// uss backup to C:\\ (space, non-ASCII)")
def _backup() -> None:
    name, linux = windows_file(BACKUP)
    linux.unlink(missing_ok=True)
    done = uss_win("backup", "5", "-o", name, "--port", _master_url(), *GENERIC)
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect(linux.is_file(), f"no file {linux}", done)
    try:
        data = tomllib.loads(linux.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise Failed(f"{linux}: not UTF-8 TOML: {e}", done.command, done.output) from None
    expect("28672" in json.dumps(data), "P18 = 28672 (written before) not in the backup", done)
    leftovers = [
        p.name
        for p in linux.parent.iterdir()
        if p.name.startswith(linux.name + ".") or p.name.startswith("." + linux.name)
    ]
    expect(not leftovers, f"files left beside the backup: {leftovers}", done)
    MASTER["backup"] = name


@check("master tcp:// uss diff with the backup")
def _diff() -> None:
    backup = MASTER.get("backup")
    expect(backup, "no backup (see the backup check)")
    same = uss_win("diff", "5", str(backup), "--port", _master_url(), *GENERIC)
    expect(same.returncode == 0, f"exit code {same.returncode} before any change", same)
    changed = uss_linux("write", "5", "18", "0x1234", "--port", _master_url(), *LINE)
    expect(changed.returncode == 0, "Linux uss write P18 failed", changed)
    differs = uss_win("diff", "5", str(backup), "--port", _master_url(), *GENERIC)
    expect(differs.returncode == 1, f"exit code {differs.returncode} with P18 changed", differs)
    expect("18" in differs.stdout, "P18 not shown as different", differs)


@check("master tcp:// uss restore from the backup")
def _restore() -> None:
    backup = MASTER.get("backup")
    expect(backup, "no backup (see the backup check)")
    uss_linux("write", "5", "18", "0x1234", "--port", _master_url(), *LINE)
    done = uss_win("restore", "5", str(backup), "--yes", "--port", _master_url(), *GENERIC)
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    back = uss_linux("read", "5", "18", "--port", _master_url(), *LINE)
    expect("P18 = 28672" in back.stdout, "P18 not restored (Linux reads another value)", back)


# --- servers on Windows, clients on Linux ------------------------------------------------------


@check("Windows uss simulate, Linux uss read; Ctrl+C stops it (exit 0)")
def _windows_simulate() -> None:
    with windows_server("simulate", "--tcp", "127.0.0.1:0", "--address", "7", *LINE) as server:
        url = server.wait_line(r"^tcp://127\.0\.0\.1:\d+$").group(0)
        done = uss_linux("read", "7", "52", "--port", url, *LINE)
        expect(
            done.returncode == 0 and done.stdout.startswith("P52 = 16384"),
            f"Linux uss read: exit code {done.returncode}",
            done,
        )
    stopped_cleanly(server, 0)
    expect(
        re.search(r"([1-9]\d*) telegrams received, \1 answered", server.output()),
        "no summary 'N telegrams received, N answered'",
        Done(server.command, 0, "", server.output()),
    )


def with_outputs(error: Failed, *servers: Server | None) -> Failed:
    """The failure with the output of the servers of the check (after their stop) added."""
    for server in servers:
        if server is not None:
            error.output += "\n-- " + subprocess.list2cmdline(server.command) + "\n"
            error.output += server.output()
    return error


@check("Windows uss bus, Linux simulator and master on it; Ctrl+C stops it (exit 0)")
def _windows_bus() -> None:
    bus = sim = None
    try:
        with windows_server("bus", "--tcp", "127.0.0.1:0", "--bus-tcp", "127.0.0.1:0") as bus:
            tcp = bus.wait_line(r"^tcp://127\.0\.0\.1:\d+$").group(0)
            station = bus.wait_line(r"^bus://127\.0\.0\.1:\d+$").group(0)
            with linux_server(
                "simulate", "--bus", station.removeprefix("bus://"), "--address", "9", *LINE
            ) as sim:
                sim.wait_line(r"^bus://")
                done = uss_linux("read", "9", "52", "--port", tcp, *LINE)
                expect(
                    done.returncode == 0 and done.stdout.startswith("P52 = 16384"),
                    f"Linux uss read over the Windows bus: exit code {done.returncode}",
                    done,
                )
    except Failed as e:
        raise with_outputs(e, sim, bus) from None
    stopped_cleanly(bus, 0)


@check("Windows uss simulate --bus-tcp, Linux uss read over bus://; Ctrl+C stops it (exit 0)")
def _windows_simulate_bus() -> None:
    server = None
    try:
        with windows_server(
            "simulate", "--bus-tcp", "127.0.0.1:0", "--address", "11", *LINE
        ) as server:
            url = server.wait_line(r"^bus://127\.0\.0\.1:\d+$").group(0)
            done = uss_linux("read", "11", "52", "--port", url, *LINE)
            expect(
                done.returncode == 0 and done.stdout.startswith("P52 = 16384"),
                f"Linux uss read: exit code {done.returncode}",
                done,
            )
    except Failed as e:
        raise with_outputs(e, server) from None
    stopped_cleanly(server, 0)


@check("Windows uss gateway, Modbus TCP read from Linux; Ctrl+C stops it (exit 0)")
def _gateway() -> None:
    from pymodbus.client import ModbusTcpClient

    port = free_port()
    with (
        linux_simulator() as url,
        windows_server(
            "gateway", "--port", url, "--address", "5", *LINE, "--modbus", f"127.0.0.1:{port}"
        ) as gateway,
    ):
        gateway.wait_line(r"^ready$")
        client = ModbusTcpClient("127.0.0.1", port=port, timeout=5)
        try:
            expect(client.connect(), f"no Modbus connection to 127.0.0.1:{port}")  # type: ignore[no-untyped-call]
            deadline = time.monotonic() + 30
            state = 0
            while time.monotonic() < deadline:
                answer = client.read_input_registers(0, count=2, device_id=5)
                expect(not answer.isError(), f"Modbus read refused: {answer}")
                status, state = answer.registers
                if state:
                    break
                time.sleep(0.3)
            expect(
                state,
                "input register 1 (state) stays 0: the drive never answered the gateway",
                Done(gateway.command, 0, "", gateway.output()),
            )
            expect(status & 0x0200, f"status word {status:04X}h without bit 9 (control requested)")
            # the mailbox: read P52 as the drive's word (format 1)
            client.write_registers(200, [52, 0xFFFF, 1, 0, 0, 1], device_id=5)
            deadline = time.monotonic() + 15
            while time.monotonic() < deadline:
                box = client.read_holding_registers(206, count=5, device_id=5).registers
                if box[0]:
                    break
                time.sleep(0.2)
            expect(
                box[0] == 1, f"mailbox status {box[0]} (1 done), response {box[1]}, error {box[2]}"
            )
            expect(box[4] == 16384, f"mailbox P52 = {box[3:]} not 16384")
        finally:
            client.close()  # type: ignore[no-untyped-call]
    stopped_cleanly(gateway, 0)


@check("Windows uss web, fetched from Linux; Ctrl+C stops it (exit 0)")
def _web() -> None:
    with (
        linux_simulator() as url,
        windows_server(
            "web", "--port", url, "--address", "5", *LINE, "--listen", "127.0.0.1:0"
        ) as web,
    ):
        page = web.wait_line(r"^http://127\.0\.0\.1:\d+/\S*$").group(0)
        with urllib.request.urlopen(page, timeout=20) as response:
            html = response.read().decode()
        expect(response.status == 200 and "<html" in html.lower(), "no HTML page at " + page)
        api = page.split("?")[0].rstrip("/") + "/api/bus"
        deadline = time.monotonic() + 30
        bus = {}
        while time.monotonic() < deadline:
            with urllib.request.urlopen(api, timeout=20) as response:
                bus = json.loads(response.read())
            if '"status": 576' in json.dumps(bus) or "0240" in json.dumps(bus).lower():
                break
            time.sleep(0.5)
        text = json.dumps(bus)
        expect(
            '"status": 576' in text or "0240" in text.lower(),
            f"/api/bus never shows drive 5's status word 0240h: {text[:300]}",
        )
    stopped_cleanly(web, 0)


@check("Windows uss log CSV to C:\\ for 4 s, read on Linux")
def _log() -> None:
    name, linux = windows_file(WORK_DIR + "\\Ünïcode log.csv")
    linux.unlink(missing_ok=True)
    with linux_simulator() as url:
        done = uss_win(
            "log",
            "5",
            "status",
            "actual",
            "P52",
            "--rate",
            "4",
            "--duration",
            "4",
            "-o",
            name,
            "--port",
            url,
            *LINE,
        )
    expect(done.returncode == 0, f"exit code {done.returncode}", done)
    expect(linux.is_file(), f"no file {linux}", done)
    rows = [r for r in linux.read_text(encoding="utf-8").splitlines() if r and r[0] != "#"]
    expect(len(rows) >= 6, f"{len(rows) - 1} rows in 4 s at 4 Hz", done)
    header, *data = rows
    expect("P52" in header, f"header {header!r} without P52", done)
    ok = [r for r in data if r.endswith(",ok") and "16384" in r]
    expect(
        len(ok) >= len(data) - 1,
        f"{len(data) - len(ok)} of {len(data)} rows not ok with P52 = 16384: {data[:3]}",
        done,
    )
    expect(
        re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d", data[0]),
        f"first column not an ISO 8601 time: {data[0]!r}",
        done,
    )


PTY_OPTIONS = [
    ["simulate", "--pty"],
    ["bus", "--pty", "1"],
    ["bass", "ring", "--pty"],
    ["ksvario", "simulate", "--pty"],
]


@check("--pty on Windows: one line saying what to use instead, no traceback")
def _pty() -> None:
    if LINUX_ONLY:
        return  # ptys exist on Linux
    for args in PTY_OPTIONS:
        done = uss_win(*args, timeout=60)
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        expect(
            done.returncode == 2,  # bad input, on every command (docs/platforms.md)
            f"uss {' '.join(args)}: exit code {done.returncode}, not 2",
            done,
        )
        no_traceback(done)
        expect(
            len(lines) == 1, f"uss {' '.join(args)}: {len(lines)} lines on stderr, not one", done
        )
        expect(
            re.search(r"--tcp|--bus-tcp|--serial|--listen|--port|COM\d", lines[0]),
            f"uss {' '.join(args)}: the message names nothing to use instead",
            done,
        )


@check("Ctrl+C on Windows uss scan: the drives found so far, exit 130")
def _scan_interrupted() -> None:
    with (
        linux_simulator("--address", "1", *LINE) as url,
        windows_server("scan", "--port", url, "--address", "0-31") as scan,
    ):
        scan.wait_line(r"^\s+1\s+9600\s")
    stopped_cleanly(scan, 130)


@check("Ctrl+C on Windows uss run: the drive switched off, exit 130")
def _run_interrupted() -> None:
    with linux_simulator() as url:
        with windows_server("run", "5", "--setpoint", "20", "--port", url, *LINE) as run:
            run.wait_line(r"\S")
            time.sleep(2)
        stopped_cleanly(run, 130)
        status = uss_linux("status", "5", "--port", url, *LINE)
        expect(
            "operation enabled" not in status.stdout.splitlines()[0],
            "the drive still runs after Ctrl+C on uss run",
            status,
        )


# --- the lane ---------------------------------------------------------------------------------


def report(name: str, error: Failed | None) -> None:
    if error is None:
        print(f"PASS {name}", flush=True)
        return
    reason = error.reason.replace("\n", " ")
    print(f"FAIL {name}: {reason}", flush=True)
    if error.command:
        print("    command: " + subprocess.list2cmdline(error.command), flush=True)
    tail = [line for line in error.output.splitlines() if line.strip()][-25:]
    for line in tail:
        print("    | " + line, flush=True)


def main() -> int:
    global LINUX_ONLY
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-k", dest="pattern", help="run only the checks whose name has this")
    parser.add_argument(
        "--no-prepare", action="store_true", help="take Windows Python as it is in build/wine"
    )
    parser.add_argument(
        "--linux",
        action="store_true",
        help="run the Windows side natively on Linux (checks the lane itself)",
    )
    args = parser.parse_args()
    LINUX_ONLY = args.linux
    started = time.monotonic()
    passed = failed = known = 0
    try:
        try:
            if not LINUX_ONLY:
                if args.no_prepare:
                    wine.boot()
                else:
                    wine.prepare()
            elif not any(wine.DIST.glob("pyuss-*.whl")):
                wine.pyuss_wheel()
        except Exception as e:  # no Windows Python: one failure, said as the checks are
            report("prepare Windows Python", Failed(str(e).splitlines()[0], None, str(e)))
            failed += 1
            checks = []
        else:
            checks = [(n, f) for n, f in CHECKS if not args.pattern or args.pattern in n]
            shutil.rmtree(work_dir(), ignore_errors=True)
            work_dir().mkdir(parents=True)
            wine.log("checks")
        master = contextlib.ExitStack()
        for name, fn in checks:
            if name.startswith("master tcp://") and not MASTER:
                try:
                    master.enter_context(master_line())
                except Failed as e:
                    MASTER["error"] = e
            elif not name.startswith("master tcp://"):
                master.close()  # the master checks are over: their simulator stops
            check_started = time.monotonic()
            try:
                fn()
                error = None
            except Failed as e:
                error = e
            except Exception as e:  # a check's own bug is its failure, not the lane's end
                error = Failed(f"{type(e).__name__}: {e}")
            took = time.monotonic() - check_started
            if error is not None and name in KNOWN and not LINUX_ONLY:
                print(f"KNOWN {name}: {KNOWN[name]} ({error.reason.splitlines()[0]})")
                known += 1
                continue
            report(name, error)
            if took > 30:
                print(f"    ({took:.0f} s)", flush=True)
            passed, failed = passed + (error is None), failed + (error is not None)
        master.close()
    finally:
        if not LINUX_ONLY:
            wine.shutdown()
    wine.log(f"done in {time.monotonic() - started:.0f} s")
    print(f"{passed} passed, {failed} failed, {known} skipped", flush=True)
    return 1 if failed or not passed else 0


if __name__ == "__main__":
    sys.exit(main())
