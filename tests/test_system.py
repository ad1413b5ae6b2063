"""`pyuss.system`: the one place where Windows, macOS and Linux differ, seen from each caller.

The Windows side runs for real in the Windows lane (`make test-windows`, docs/windows-lane.md);
here each rule is held on the platform the suite runs on, and the choices every platform
shares (the fallback loop, the stop handler, the error texts) are driven directly."""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pyuss import __version__, system
from pyuss import loop as fine
from pyuss._lazy import not_installed
from pyuss.cli.main import main
from pyuss.errors import ConfigError

POSIX = system.NAME != "win32"


def test_the_line_clock_keeps_microseconds_and_one_base_across_processes() -> None:
    assert system.CLOCK_RESOLUTION <= system.FINE_ENOUGH
    here = system.clock()
    there = float(
        subprocess.run(
            [sys.executable, "-c", "from pyuss import system; print(repr(system.clock()))"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    )
    assert here <= there <= system.clock()  # another process reads the same time base


def test_a_coarse_clock_is_said_with_its_figure(monkeypatch: pytest.MonkeyPatch) -> None:
    assert system.clock_warning(187500) is None
    monkeypatch.setattr(system, "CLOCK_RESOLUTION", 0.015625)  # Windows' monotonic before 3.13
    text = system.clock_warning(19200)
    assert text is not None and "15.6 ms" in text and "19200 baud (0.573 ms)" in text
    assert system.clock_warning(300) is None  # a character at 300 baud is 36.7 ms


def test_without_a_fine_selector_the_loop_is_the_platforms_own_and_never_recurses(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(system, "fine_selector", lambda: None)  # as on Windows

    async def answer() -> int:
        await asyncio.sleep(0.001)
        return 42

    with fine.installed(least_slack=False):
        loop = asyncio.new_event_loop()  # through the policy, which calls new_event_loop
        try:
            assert not fine.fine_timers(loop)
            assert loop.run_until_complete(answer()) == 42
        finally:
            loop.close()
        assert asyncio.run(answer()) == 42


def test_a_stop_signal_sets_the_event_tells_its_number_and_the_old_handler_comes_back() -> None:
    before = signal.getsignal(signal.SIGINT)
    seen: list[int] = []

    async def body() -> bool:
        with system.stop_on_signals(seen.append) as stop:
            asyncio.get_running_loop().call_later(0.01, signal.raise_signal, signal.SIGINT)
            async with asyncio.timeout(5):
                await stop.wait()
            return stop.is_set()

    assert fine.run(body()) is True
    assert seen == [signal.SIGINT]
    assert signal.getsignal(signal.SIGINT) == before  # Ctrl+C works as before afterwards


def test_the_install_command_is_this_pythons_own_pip() -> None:
    command = system.install_command("pyuss[web]")
    assert command.startswith(system.quote(sys.executable))
    assert command.endswith(" -m pip install " + system.quote("pyuss[web]", always=True))
    assert "pyuss[web]" in command and command.count("pyuss[web]") == 1


def test_a_missing_extra_and_a_failing_one_are_told_apart() -> None:
    missing = ModuleNotFoundError("No module named 'aiohttp'", name="aiohttp")
    assert not_installed(missing, "aiohttp")
    assert not_installed(ModuleNotFoundError("...", name="asyncua"), "asyncua.common")
    inner = ModuleNotFoundError("No module named 'yarl'", name="yarl")  # aiohttp's own import
    assert not not_installed(inner, "aiohttp")
    dll = ImportError("DLL load failed while importing _rust: the procedure was not found")
    assert not not_installed(dll, "cryptography")

    from pyuss.web import missing_extra

    assert "pip install" in str(missing_extra(missing))
    shown = str(missing_extra(inner))
    assert "fails to load" in shown and "yarl" in shown and "pip install" not in shown


@pytest.mark.skipif(not POSIX, reason="XDG folders are the Linux rule")
def test_the_configuration_folder_follows_the_platform(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    folder = system.config_folder()
    if sys.platform == "darwin":
        assert folder == Path.home() / "Library" / "Application Support" / "pyuss"
    else:
        assert folder == tmp_path / "pyuss"
        from pyuss import lines

        assert lines.candidates() == [Path("uss.toml"), tmp_path / "pyuss" / "uss.toml"]


@pytest.mark.parametrize(
    "command",
    [
        ["simulate", "--pty", "--duration", "1"],
        ["bus", "--pty", "1", "--duration", "1"],
        ["bass", "ring", "--pty", "--duration", "1"],
        ["ksvario", "simulate", "--pty"],
    ],
    ids=" ".join,
)
def test_a_pty_where_the_system_has_none_says_what_to_use(
    command: list[str], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(system, "HAS_PTY", False)
    from pyuss.transport.pty import PtyPort

    with pytest.raises(ConfigError, match=r"--tcp HOST:PORT.*tcp://.*bus://.*COM port.*com0com"):
        PtyPort()
    code = main(command)
    err = capsys.readouterr().err
    assert code == 2, err  # bad input, as on every command (docs/platforms.md)
    assert err.count("\n") == 1 and "com0com" in err and "Traceback" not in err


def test_a_port_that_is_not_there_is_named_with_the_ports_that_are(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(["read", "--port", "COM99", "1", "P0003"])
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and "COM99" in err and "no such port" in err
    assert "serial ports here:" in err or "lists no serial ports" in err


def test_python_dash_m_pyuss_is_the_uss_command() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pyuss", "--version"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert __version__ in done.stdout


@pytest.mark.skipif(not POSIX, reason="flock; the Windows lane holds msvcrt's lock")
def test_a_lock_is_refused_to_a_second_holder(tmp_path: Path) -> None:
    path = tmp_path / "locked"
    path.write_bytes(b"x")
    first = os.open(path, os.O_RDWR)
    second = os.open(path, os.O_RDWR)
    try:
        system.try_lock(first)
        with pytest.raises(OSError):
            system.try_lock(second)
    finally:
        os.close(first)
    system.try_lock(second)  # the first holder gone: free again
    os.close(second)


def test_replace_retries_a_rename_held_for_a_moment(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    if POSIX:
        pytest.skip("POSIX renames at once: the retry is Windows' (system._windows.replace)")
    source, target = tmp_path / "new", tmp_path / "old"
    source.write_text("new")
    target.write_text("old")
    real, calls = os.replace, []

    def held(a: object, b: object) -> None:
        calls.append(time.monotonic())
        if len(calls) < 3:
            raise PermissionError(13, "Access is denied")
        real(a, b)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "replace", held)
    system.replace(source, target)
    assert target.read_text() == "new" and len(calls) == 3


def test_both_sides_offer_the_same_names() -> None:
    # Read, not imported: each side imports only on its own platform.
    import ast

    def public(name: str) -> set[str]:
        source = (Path(system.__file__).parent / name).read_text(encoding="utf-8")
        names: set[str] = set()
        for node in ast.parse(source).body:
            if isinstance(node, ast.FunctionDef | ast.ClassDef):
                names.add(node.name)
            elif isinstance(node, ast.Assign | ast.AnnAssign):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                names |= {t.id for t in targets if isinstance(t, ast.Name)}
            elif isinstance(node, ast.If):  # a definition per kind of POSIX system
                names |= {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
        return {n for n in names if not n.startswith("_") and n not in ("log", "LINUX")}

    posix, windows = public("_posix.py"), public("_windows.py")
    assert posix - {"ASYNC_LOW_LATENCY"} == windows
    assert windows <= set(system.__all__)
