"""``uss scan --baud auto`` and ``--save`` as a user runs them: the rate found among the usual
ones, the line written down as ``uss.toml`` that ``uss read`` then takes bare, what to check
when nothing answers, and a file there already kept unless ``--force``."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest

from pyuss.lines import load
from support.paths import ROOT
from support.processes import simulator, simulator_bus
from support.userconfig import environment

USS = [sys.executable, "-m", "pyuss.cli.main"]
V20 = ("--profile", "sinamics-v20", "--address", "5")
"""A SINAMICS V20 at address 5: it shows its family (r0964, P2023) and firmware (r0018)."""


@pytest.fixture(scope="module")
def bus_19200() -> Iterator[str]:
    """`V20` on a virtual bus running at 19200 baud: its ``bus://`` URL."""
    with simulator_bus(*V20, "--baud", "19200") as url:
        yield url


@pytest.fixture(scope="module")
def tcp_v20() -> Iterator[str]:
    """`V20` behind TCP: its ``tcp://`` URL."""
    with simulator(*V20) as url:
        yield url


@pytest.fixture
def work(tmp_path: Path) -> Path:
    """An empty working directory for the commands."""
    folder = tmp_path / "work"
    folder.mkdir()
    return folder


def uss(work: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    """``uss ARGV`` in ``work``, where no configuration file of the user's is found."""
    env = {k: v for k, v in os.environ.items() if k != "USS_CONFIG"}
    env.update(environment(work / "home"))
    return subprocess.run(
        [*USS, *argv], cwd=work, env=env, capture_output=True, text=True, timeout=180
    )


def test_auto_finds_the_drive_at_19200_and_says_who_it_is(bus_19200: str, work: Path) -> None:
    done = uss(work, "scan", "--port", bus_19200, "--baud", "auto", "--address", "4-5")
    assert done.returncode == 0, done.stderr
    header, row = done.stdout.splitlines()
    assert header.split() == [
        "address", "baud", "layout", "status", "response", "profile", "firmware", "family"
    ]  # fmt: skip
    address, baud, layout, *_ = row.split()
    assert (address, baud, layout) == ("5", "19200", "v,2")
    assert row.split()[-4:] == ["sinamics-v20", "0.00", "SINAMICS", "V20"]
    # 9600 was tried first: the bus refused it, and the other usual rates after 19200
    for rate in ("9600", "38400", "57600", "115200", "187500"):
        assert f"uss scan: {rate} baud not probed" in done.stderr


def test_save_writes_the_line_that_uss_read_takes_bare(bus_19200: str, work: Path) -> None:
    done = uss(work, "scan", "--port", bus_19200, "--baud", "auto", "--address", "5", "--save")
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "uss.toml: line line1, 19200 baud, 1 drive (drive5)"
    data = tomllib.loads((work / "uss.toml").read_text(encoding="utf-8"))
    assert data == {
        "bus": [
            {
                "name": "line1",
                "port": bus_19200,
                "baud": 19200,
                "profile": "sinamics-v20",
                "layout": "v,2",
                "drive": [{"name": "drive5", "address": 5, "profile": "sinamics-v20"}],
            }
        ]
    }
    assert load(work / "uss.toml").names == ["line1"]  # the lines' reader takes it
    read = uss(work, "read", "5", "P1120")
    assert read.returncode == 0, read.stderr
    assert read.stdout.strip() == "P1120 = [10.00, 10.00, 10.00] s (Ramp-up time)"
    by_name = uss(work, "read", "drive5", "P1120.0")
    assert by_name.stdout.strip() == "P1120.0 = 10.00 s (Ramp-up time)", by_name.stderr


def test_save_over_tcp_then_a_bare_read(tcp_v20: str, work: Path) -> None:
    done = uss(work, "scan", "--port", tcp_v20, "--address", "5", "--save", "plant.toml")
    assert done.returncode == 0, done.stderr
    read = uss(work, "read", "5", "P1120", "--config", "plant.toml")
    assert read.stdout.strip() == "P1120 = [10.00, 10.00, 10.00] s (Ramp-up time)", read.stderr
    assert not (work / "uss.toml").exists()


def test_nothing_found_says_what_was_tried_and_what_to_check(bus_19200: str, work: Path) -> None:
    done = uss(work, "scan", "--port", bus_19200, "--baud", "19200", "--address", "1-2", "--save")
    assert done.returncode == 1
    assert done.stdout == "no drive answered\n"
    hint = done.stderr.splitlines()
    assert hint[0] == (
        "uss scan: no drive answered at 19200 baud, addresses 1-2, layouts 3,2 4,2 0,2 4,0 3,0 "
        "4,6; check:"
    )
    assert hint[1] == "  - each drive's bus baud rate and address, set on the drive:"
    # the families' bus parameters, from their parameter files
    assert "      nord, nord-sk500e: P511 baud rate, P512 address" in hint
    assert any(line.endswith("sinamics-v20: P2010.0 baud rate, P2011.0 address") for line in hint)
    assert "A to A and B to B" in done.stderr and "120 ohm at both ends" in done.stderr
    assert (
        hint[-1] == "  - other rates: --baud auto tries 9600, 19200, 38400, 57600, 115200, 187500"
    )
    assert not (work / "uss.toml").exists()  # nothing found, nothing written


def test_with_a_profile_only_its_bus_parameters_are_named(bus_19200: str, work: Path) -> None:
    done = uss(
        work, "scan", "--port", bus_19200, "--baud", "auto", "--address", "1", "--profile",
        "nord-sk500e",
    )  # fmt: skip
    assert done.returncode == 1
    assert (
        "  - each drive's bus baud rate and address, set on the drive: nord-sk500e: P511 baud "
        "rate, P512 address"
    ) in done.stderr.splitlines()
    assert "other rates" not in done.stderr  # auto tried them all


def test_a_file_there_is_kept_unless_force(bus_19200: str, work: Path) -> None:
    mine = work / "uss.toml"
    mine.write_text("# mine\n", encoding="utf-8")
    argv = ["scan", "--port", bus_19200, "--baud", "19200", "--address", "5", "--save"]
    done = uss(work, *argv)
    assert (done.returncode, done.stdout) == (2, "")  # refused before the scan
    assert (
        done.stderr
        == f"uss scan: {mine.name} exists: --force replaces it, or give another file name\n"
    )
    assert mine.read_text(encoding="utf-8") == "# mine\n"
    done = uss(work, *argv, "--force")
    assert done.returncode == 0, done.stderr
    assert 'name = "drive5"' in mine.read_text(encoding="utf-8")
    assert [p.name for p in work.iterdir() if p.name != "home"] == ["uss.toml"]  # no temporary


def test_force_without_save_is_refused(bus_19200: str, work: Path) -> None:
    done = uss(work, "scan", "--port", bus_19200, "--address", "5", "--force")
    assert done.returncode == 2
    assert done.stderr == "uss scan: --force belongs to --save (replace the file it names)\n"


def _section(title: str) -> str:
    text = (ROOT / "docs" / "lines.md").read_text(encoding="utf-8")
    return text.split(f"\n## {title}\n", 1)[1].split("\n## ", 1)[0]


def _matches(want: str, got: str) -> bool:
    """Whether the printed line ``got`` is the docs' ``want``; a response time may differ."""
    pattern = re.sub(r"\d+\\\.\d\d\\ ms", r"\\d+\\.\\d\\d\\ ms", re.escape(want))
    return re.fullmatch(pattern, got) is not None


def test_the_example_of_the_docs_runs_as_written(work: Path) -> None:
    sessions = re.findall(r"```console\n(.*?)```", _section("Written by `uss scan --save`"), re.S)
    assert len(sessions) == 2
    steps = [
        re.split(r"\n", step.rstrip("\n"))
        for s in sessions
        for step in re.split(r"^\$ ", s, flags=re.M)[1:]
    ]
    (simulate, url), *steps = steps
    argv = shlex.split(simulate)
    assert argv[:2] == ["uss", "simulate"] and argv[-1] == "&"
    at = argv.index("--bus-tcp")
    assert url == f"bus://{argv[at + 1]}"
    with simulator_bus(*argv[2:at], *argv[at + 2 : -1]) as real:
        ran = 0
        for command, *shown in steps:
            argv = shlex.split(command.replace(url, real))
            if argv[0] == "cat":
                printed = (work / argv[1]).read_text(encoding="utf-8").splitlines()
                code = 0
            else:
                assert argv[0] == "uss"
                done = uss(work, *argv[1:])
                not_probed = re.compile(r"uss scan: \d+ baud not probed: ")
                err = [line for line in done.stderr.splitlines() if not not_probed.match(line)]
                printed, code = done.stdout.splitlines() + err, done.returncode
            shown = [line.replace(url, real) for line in shown]
            assert code == (1 if shown[:1] == ["no drive answered"] else 0), (command, printed)
            assert len(printed) == len(shown), (command, printed)
            for want, got in zip(shown, printed, strict=True):
                assert _matches(want, got), (command, want, got)
            ran += 1
    assert ran == 5


def test_with_json_the_list_alone(bus_19200: str, work: Path) -> None:
    argv = ["scan", "--port", bus_19200, "--baud", "19200", "--json"]
    none = uss(work, *argv, "--address", "1")
    assert (none.returncode, none.stdout, none.stderr) == (1, "[]\n", "")
    done = uss(work, *argv, "--address", "5", "--save")
    assert done.returncode == 0 and done.stderr == ""
    (found,) = json.loads(done.stdout)
    assert (found["profile"], found["firmware"], found["family"]) == (
        "sinamics-v20",
        "0.00",
        "SINAMICS V20",
    )
    assert 'name = "drive5"' in (work / "uss.toml").read_text(encoding="utf-8")
