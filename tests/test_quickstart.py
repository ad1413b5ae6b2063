"""The README's quick start, run as written, as a newcomer runs it: the blocks of README.md
marked ``<!-- run by tests/test_quickstart.py -->`` one after the other in one directory (a
simulated SINAMICS V20 from the box: scan with ``--save``, read by name, write with
``--verify``, backup, the refused run, P0700 and P1000 set to 5, the ramp, the page, then the
gateway on the file the scan wrote), by the rules of tests/test_readme.py. Then what the
commands left behind is checked: the line file, the backup, and the page serving the drive."""

from __future__ import annotations

import json
import tomllib
import urllib.request
from pathlib import Path

import pytest

from pyuss.commission import backup
from support.network import holding
from test_readme import ALL, Shell, _run_session

MINE = [
    e
    for e in ALL
    if e.path.name == "README.md" and "run by tests/test_quickstart.py" in e.directives
]


@pytest.mark.posix("runs the commands as a terminal does (preexec_fn, SIGINT)")
def test_the_quick_start_runs_as_written(tmp_path: Path) -> None:
    assert [e.kind for e in MINE] == ["console", "console"], "the quick start and the gateway"
    shell = Shell(tmp_path)
    try:
        with holding(8420), holding(5020):  # `uss web` and `uss gateway --modbus` as written
            for example in MINE:
                _run_session(example, shell)
            line = tomllib.loads((tmp_path / "uss.toml").read_text(encoding="utf-8"))
            (bus,) = line["bus"]
            assert (bus["name"], bus["baud"], bus["profile"]) == ("line1", 19200, "sinamics-v20")
            assert [(d["name"], d["address"]) for d in bus["drive"]] == [("drive5", 5)]
            saved = backup.load(tmp_path / "v20.toml")
            assert saved.address == 5 and len(saved.entries) > 50
            web = shell.popen(["uss", "web"])
            try:
                url = web.stdout_line(60, "uss web")
                assert url == "http://127.0.0.1:8420/"
                with urllib.request.urlopen(url + "api/bus", timeout=30) as reply:
                    drives = json.load(reply)["drives"]
                assert [(d["address"], d["profile"]) for d in drives] == [(5, "sinamics-v20")]
            finally:
                web.popen.terminate()
                web.wait(30, "uss web")
    finally:
        shell.close()
