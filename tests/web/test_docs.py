"""Every shell example of docs/web.md runs as written (with bash: POSIX systems). `uss web`
examples run until their first line (the page's address) answers, then get Ctrl+C (SIGINT);
/dev/ttyUSB0 is a simulator's TCP port (``tcp://127.0.0.1:PORT``) serving drives 5 and 7 at
19200 baud."""

from __future__ import annotations

import contextlib
import csv
import os
import re
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest

from support.network import holding

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "web.md"
BIN = Path(sys.executable).parent
SIMULATOR = [
    *("uss", "simulate", "--tcp", "127.0.0.1:0", "--address", "5", "--address", "7"),
    *("--layout", "3,2", "--baud", "19200"),
]


def blocks() -> list[str]:
    text = DOC.read_text(encoding="utf-8")
    return re.findall(r"^```sh\n(.*?)^```", text, flags=re.MULTILINE | re.DOTALL)


def env() -> dict[str, str]:
    return {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}


def test_the_doc_has_its_examples() -> None:
    found = blocks()
    assert sum(b.startswith("uss web") for b in found) >= 3
    assert any("uss log" in b for b in found)


@pytest.mark.posix("runs the example with bash and stops it with SIGINT")
@pytest.mark.parametrize("block", [b for b in blocks() if b.startswith("uss web")])
def test_uss_web_examples(block: str, tmp_path: Path) -> None:
    assert block.count("\n") == 1
    command = block.strip()
    with contextlib.ExitStack() as stack:
        if "--listen" not in command:  # the default 8420, which other tests run as written too
            stack.enter_context(holding(8420))
        _run_web_example(command, tmp_path)


def _run_web_example(command: str, tmp_path: Path) -> None:
    sim = None
    try:
        if "/dev/ttyUSB0" in command:
            sim = subprocess.Popen(
                SIMULATOR,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                text=True,
                env=env(),
            )
            assert sim.stdout is not None
            command = command.replace("/dev/ttyUSB0", sim.stdout.readline().strip())
        web = subprocess.Popen(
            ["bash", "-c", f"exec {command}"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=tmp_path,
            env=env(),
        )
        try:
            assert web.stdout is not None
            url = web.stdout.readline().strip()
            assert re.fullmatch(r"http://127\.0\.0\.1:\d+/", url), (url, web.stderr)
            if "--listen" not in command:
                assert url == "http://127.0.0.1:8420/"
            with urllib.request.urlopen(url + "api/bus", timeout=30) as reply:
                assert reply.status == 200
            with urllib.request.urlopen(url + "api/config", timeout=30) as reply:
                assert (b'"read_only": true' in reply.read()) == ("--read-only" in command)
            web.send_signal(signal.SIGINT)
            _, err = web.communicate(timeout=30)
            assert web.returncode == 0, err
        finally:
            if web.poll() is None:
                web.kill()
                web.wait()
    finally:
        if sim is not None:
            sim.terminate()
            sim.wait(30)


@pytest.mark.posix("runs the example with bash")
def test_uss_log_example(tmp_path: Path) -> None:
    (block,) = [b for b in blocks() if "uss log" in b]
    done = subprocess.run(
        ["bash", "-e", "-c", block], cwd=tmp_path, env=env(), capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "drive5.csv", newline="", encoding="utf-8") as file:
        # a "#" comment row (the rate reached, on a line too slow for it) is no sample
        rows = [row for row in csv.reader(file) if not row[0].startswith("#")]
    assert len(rows) == 21
    assert rows[0][-2:] == ["P352 Reference freq. [Hz]", "comm"]
    assert all(row[-1] == "ok" for row in rows[1:])


def test_every_picture_of_the_doc_is_one_the_browser_tests_take() -> None:
    shown = re.findall(r"\]\(images/([a-z-]+)\.png\)", DOC.read_text(encoding="utf-8"))
    tests = ("tests/web/test_page.py", "tests/web/test_plant.py")
    taken = [
        name
        for test in tests
        for name in re.findall(r'screenshot\(\s*page,\s*"([a-z-]+)"', (ROOT / test).read_text())
    ]
    assert shown and sorted(set(shown)) == sorted(set(taken))
    for name in shown:
        assert (ROOT / "docs" / "images" / f"{name}.png").is_file(), name
