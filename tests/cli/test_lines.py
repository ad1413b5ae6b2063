"""The configuration file of lines and drives (``uss.toml``, docs/lines.md) for real: drives
of ``uss simulate --tcp`` processes named in the file, the commands through their entry point
(``main`` in this process, or ``uss`` in a process of its own for web, gateway and log)."""

from __future__ import annotations

import json
import os
import re
import shlex
import signal
import subprocess
import sys
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from gateway.harness import free_port
from pyuss import system
from pyuss.cli.main import main
from support.paths import ROOT
from support.processes import simulator
from support.userconfig import empty_place
from test_userfile import bad_files, refuses

USS = [sys.executable, "-m", "pyuss.cli.main"]
BAUD = 38400


DRIVES = ("--profile", "generic", "--address", "5", "--address", "6", "--layout", "3,2")
"""Generic drives at addresses 5 and 6 (PKW 3, PZD 2), at `BAUD`."""
STOPPED = pytest.mark.posix("stops uss with SIGINT and checks it ended cleanly")


@pytest.fixture(scope="module")
def sim() -> Iterator[str]:
    """`DRIVES` on TCP: its ``tcp://`` URL."""
    with simulator(*DRIVES, "--baud", str(BAUD)) as url:
        yield url


@pytest.fixture(autouse=True)
def place(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty working directory and configuration directory, no USS_CONFIG: no file of the
    user's is found. Yields the working directory."""
    return empty_place(tmp_path, monkeypatch)


def line(name: str, port: str, *drives: tuple[int, str], baud: int = BAUD, extra: str = "") -> str:
    """A ``[[bus]]`` table with its drives."""
    text = f'[[bus]]\nname = "{name}"\nport = "{port}"\nbaud = {baud}\nlayout = "3,2"\n{extra}'
    for address, drive in drives:
        text += f'\n[[bus.drive]]\naddress = {address}\nname = "{drive}"\n'
    return text + "\n"


def uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_a_drive_by_name_and_a_line_by_name(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    Path("uss.toml").write_text(
        line("line1", sim, (5, "conveyor"), (6, "pump"), extra='profile = "generic"\n')
    )
    code, out, err = uss(capsys, "read", "conveyor", "52")
    assert (code, out.strip()) == (0, "P52 = 16384 (Load display)"), err
    code, out, err = uss(capsys, "read", "--line", "line1", "6", "683.1", "--json")
    assert code == 0, err
    assert json.loads(out)["parameters"][0]["value"] == 6  # the drive's own address
    code, out, err = uss(capsys, "read", "6", "683.1", "--json")  # the only line: the default
    assert code == 0 and json.loads(out)["parameters"][0]["value"] == 6, err
    code, out, err = uss(capsys, "write", "pump", "18", "7")
    assert (code, out.strip()) == (0, "P18 = 7 (Fixed setpoint)"), err
    code, out, err = uss(capsys, "status", "pump", "--json")
    assert code == 0 and json.loads(out)["address"] == 6, err
    code, out, err = uss(capsys, "describe", "conveyor", "52")
    assert code == 0 and out.startswith("P52: parameter description"), err
    code, out, err = uss(capsys, "mirror", "pump", "--count", "1", "--json")
    assert code == 0, err
    code, out, err = uss(capsys, "scan", "--address", "5", "--json")
    assert code == 0, err
    assert [(f["address"], f["baud"]) for f in json.loads(out)] == [(5, BAUD)]


def test_without_a_profile_in_the_file_the_drive_is_of_unknown_kind(
    sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    Path("uss.toml").write_text(line("line1", sim, (5, "conveyor")))
    code, out, err = uss(capsys, "read", "conveyor", "52")
    assert (code, out.strip()) == (0, "P52 = 16384 (4000h)"), err  # as `uss read 5 52 --port ...`


def test_options_given_win_over_the_file(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    Path("uss.toml").write_text(line("line1", "/dev/nonexistent-port", (5, "conveyor")))
    code, _, err = uss(capsys, "read", "conveyor", "52")
    assert code == 1 and "nonexistent-port" in err  # the file's port is used ...
    code, out, err = uss(capsys, "read", "conveyor", "52", "--port", sim)
    assert (code, out.strip()) == (0, "P52 = 16384 (4000h)"), err  # ... unless --port given
    code, out, err = uss(capsys, "read", "conveyor", "52", "--port", sim, "--profile", "generic")
    assert (code, out.strip()) == (0, "P52 = 16384 (Load display)"), err
    code, _, err = uss(capsys, "read", "conveyor", "52", "--port", sim, "--baud", "1234")
    assert code == 2 and "1234 is not a USS baud rate" in err, err
    code, _, err = uss(capsys, "read", "conveyor", "52", "--port", sim, "--layout", "9,9")
    assert code == 2 and "PKW count" in err


def test_the_order_of_the_files(
    sim: str, capsys: pytest.CaptureFixture[str], place: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config_home = system.config_folder()  # the platform's, in the test's own home
    assert config_home is not None
    config_home.mkdir(parents=True)
    (config_home / "uss.toml").write_text(line("home", sim, (5, "in-home")))
    assert uss(capsys, "read", "in-home", "52")[0] == 0
    Path("uss.toml").write_text(line("here", sim, (5, "in-here")))
    code, _, err = uss(capsys, "read", "in-home", "52")
    assert code == 2
    assert err.strip() == "uss read: no drive named 'in-home' in uss.toml (drives: here: in-here)"
    assert uss(capsys, "read", "in-here", "52")[0] == 0
    named = place / "named.toml"
    named.write_text(line("env", sim, (5, "in-env")))
    monkeypatch.setenv("USS_CONFIG", str(named))
    assert uss(capsys, "read", "in-env", "52")[0] == 0
    assert "no drive named 'in-here'" in uss(capsys, "read", "in-here", "52")[2]
    given = place / "given.toml"
    given.write_text(line("given", sim, (5, "in-given")))
    assert uss(capsys, "read", "in-given", "52", "--config", str(given))[0] == 0
    code, _, err = uss(capsys, "read", "in-env", "52", "--config", str(given))
    assert code == 2 and "no drive named 'in-env'" in err


@pytest.mark.skipif(
    sys.platform in ("win32", "darwin"), reason="the XDG rule: Linux and the other Unix systems"
)
def test_without_xdg_config_home_the_file_is_in_the_home_folder(
    sim: str, capsys: pytest.CaptureFixture[str], place: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("XDG_CONFIG_HOME")
    monkeypatch.setenv("HOME", str(place.parent))
    code, _, err = uss(capsys, "read", "in-home", "52")
    assert code == 2 and f"{place.parent}/.config/pyuss/uss.toml" in err  # where it looked
    folder = place.parent / ".config" / "pyuss"
    folder.mkdir(parents=True)
    (folder / "uss.toml").write_text(line("home", sim, (5, "in-home")))
    assert uss(capsys, "read", "in-home", "52")[0] == 0


def test_unknown_and_ambiguous_names_are_refused_with_the_files_names(
    capsys: pytest.CaptureFixture[str],
) -> None:
    Path("uss.toml").write_text(
        line("line1", "/dev/nonexistent-1", (5, "conveyor"), (6, "pump"))
        + line("line2", "/dev/nonexistent-2", (7, "pump"))
    )
    refusals = {
        ("read", "mixer", "52"): "uss read: no drive named 'mixer' in uss.toml "
        "(drives: line1: conveyor, pump; line2: pump)",
        ("read", "pump", "52"): "uss read: drive 'pump' is on lines line1 and line2 of "
        "uss.toml: give --line NAME",
        ("read", "--line", "line3", "5", "52"): "uss read: --line line3: uss.toml has no line "
        "of that name (lines: line1, line2)",
        ("read", "5", "52"): "uss read: uss.toml has lines line1, line2: give --line NAME "
        "(or --port)",
        ("read", "--line", "line2", "conveyor", "52"): "uss read: no drive named 'conveyor' on "
        "line line2 (drives: line2: pump)",
        ("log", "mixer", "status", "-o", "x.csv"): "uss log: no drive named 'mixer' in "
        "uss.toml (drives: line1: conveyor, pump; line2: pump)",
    }
    for argv, message in refusals.items():
        code, out, err = uss(capsys, *argv)
        assert (code, out, err.strip()) == (2, "", message), argv
    code, out, _ = uss(capsys, "read", "pump", "52", "--json")
    assert code == 2 and "give --line NAME" in json.loads(out)["error"]["message"]
    assert not Path("x.csv").exists()


def test_no_file_is_todays_behaviour_and_a_bad_file_one_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, _, err = uss(capsys, "read", "5", "52")
    assert code == 2 and err.startswith("uss read: --port: give the line's port URL")
    code, _, err = uss(capsys, "read", "conveyor", "52")
    assert code == 2 and "'conveyor' is no address 0..31" in err and "uss.toml" in err
    code, _, err = uss(capsys, "read", "--line", "line1", "5", "52")
    assert code == 2 and "--line line1: no configuration file found" in err
    with pytest.raises(SystemExit) as exit_info:
        main(["read", "40", "52", "--port", "/dev/null"])
    assert exit_info.value.code == 2
    capsys.readouterr()
    Path("uss.toml").write_text('[[bus]]\nname = "line1"\nport = "/dev/x"\nbaud = 1234\n')
    code, _, err = uss(capsys, "read", "5", "52")
    assert (
        code == 2
        and err.startswith("uss read: uss.toml, line 4: bus[0].baud: ")
        and err.count("\n") == 1
    )
    Path("uss.toml").write_text(line("line1", "/dev/x", (5, "a")) + "[nonsense]\n")
    code, _, err = uss(capsys, "read", "a", "52")
    assert code == 2 and re.search(r"uss\.toml, line \d+: nonsense: unknown key", err)
    # with --port and an address the file is not read: a broken one is no hindrance
    code, _, err = uss(capsys, "read", "5", "52", "--port", "/dev/nonexistent-port")
    assert code == 1 and "nonexistent-port" in err


def test_a_file_no_reader_takes_is_one_line_naming_it(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    folder = tmp_path / "bad"
    folder.mkdir()
    for path, message in bad_files(folder, "the configuration"):
        code, out, err = uss(capsys, "read", "conveyor", "52", "--config", str(path))
        assert (code, out) == (2, ""), path
        (text,) = err.splitlines()
        assert refuses(text.removeprefix("uss read: "), path, message), text


def test_params_and_diff_take_a_drive_by_name(
    sim: str, capsys: pytest.CaptureFixture[str], place: Path
) -> None:
    Path("uss.toml").write_text(line("line1", sim, (5, "conveyor"), extra='profile = "generic"\n'))
    code, out, err = uss(capsys, "params", "conveyor", "52", "--values")
    assert code == 0 and "= 16384" in out, err
    code, out, err = uss(capsys, "params", "52")  # no drive named: the profile's file
    assert code == 0 and out.startswith("P52") and "=" not in out, err
    backup = place / "b.toml"
    uss(capsys, "backup", "conveyor", "-o", str(backup))  # some parameters PKW 3 cannot carry
    code, out, err = uss(capsys, "diff", "conveyor", str(backup))
    # those are read on neither side: not compared, and no agreement
    lines = out.splitlines()
    assert code == 1 and lines[1].startswith("not compared, read on neither side: P4 ("), err
    assert lines[-2] == f"drive 5 and {backup} agree in the parameters both hold"


def test_uss_log_reads_the_file(sim: str, place: Path) -> None:
    named = place / "plant.toml"
    named.write_text(line("line1", sim, (5, "conveyor")))
    done = subprocess.run(
        [*USS, "log", "conveyor", "status", "--count", "2", "-o", "run.csv"],
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, "USS_CONFIG": str(named)},
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "logging drive 5 to run.csv" in done.stderr
    assert len((place / "run.csv").read_text().splitlines()) == 3  # header and two rows


def serve(argv: list[str], first: str) -> tuple[subprocess.Popen[str], list[str]]:
    """``uss ARGV`` until it prints a line starting with ``first``: the process and its lines."""
    process = subprocess.Popen(
        [*USS, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert process.stdout is not None
    lines: list[str] = []
    while not any(text.startswith(first) for text in lines):
        text = process.stdout.readline()
        if not text:
            process.wait(30)
            raise AssertionError(f"{lines}; {process.stderr.read() if process.stderr else ''}")
        lines.append(text.strip())
    return process, lines


def stop(process: subprocess.Popen[str]) -> int:
    process.send_signal(signal.SIGINT)
    try:
        return process.wait(30)
    finally:
        if process.poll() is None:  # pragma: no cover
            process.kill()


@STOPPED
def test_uss_gateway_serves_the_file_found(sim: str) -> None:
    port = free_port()
    Path("uss.toml").write_text(
        line("line1", sim, (5, "conveyor")) + f'[modbus]\nlisten = "127.0.0.1:{port}"\n'
    )
    process, lines = serve(["gateway"], "ready")
    assert stop(process) == 0
    assert f"bus line1: {sim} at {BAUD} baud, drives conveyor=5" in lines
    assert f"modbus: modbus://127.0.0.1:{port}" in lines


def page_bus(url: str) -> dict[str, object]:
    with urllib.request.urlopen(url.split("?")[0] + "api/bus", timeout=30) as reply:
        data: dict[str, object] = json.load(reply)
    return data


@STOPPED
def test_uss_web_shows_the_drives_of_the_files_line(sim: str) -> None:
    pytest.importorskip("aiohttp")
    Path("uss.toml").write_text(line("line1", sim, (5, "conveyor"), (6, "pump")))
    process, lines = serve(["web", "--listen", "127.0.0.1:0"], "http://")
    try:
        bus = page_bus(lines[-1])
    finally:
        assert stop(process) == 0
    assert (bus["port"], bus["baud"]) == (sim, BAUD)
    drives = bus["drives"]
    assert isinstance(drives, list)
    # the file names no profile: drives of unknown kind, no family's facts put on them
    assert [(d["address"], d["profile"], d["layout"]) for d in drives] == [
        (5, "unknown", "3,2"),
        (6, "unknown", "3,2"),
    ]
    process, lines = serve(["web", "--address", "pump", "--listen", "127.0.0.1:0"], "http://")
    try:
        bus = page_bus(lines[-1])
    finally:
        assert stop(process) == 0
    drives = bus["drives"]
    assert isinstance(drives, list) and [d["address"] for d in drives] == [6]


def page_scan_profile(argv: list[str]) -> str:
    """The profile the page of ``uss web ARGV`` scans by at first (``/api/config``)."""
    process, lines = serve(["web", *argv, "--listen", "127.0.0.1:0"], "http://")
    try:
        with urllib.request.urlopen(lines[-1].split("?")[0] + "api/config", timeout=30) as reply:
            config = json.load(reply)
    finally:
        assert stop(process) == 0
    assert config["scan_profile"] in config["profiles"]
    return str(config["scan_profile"])


@STOPPED
def test_the_pages_scan_probes_by_the_lines_profile(sim: str) -> None:
    pytest.importorskip("aiohttp")
    Path("uss.toml").write_text(line("line1", sim, (5, "conveyor"), extra='profile = "nord"\n'))
    assert page_scan_profile([]) == "nord"  # the line's, as the file names it
    assert page_scan_profile(["--profile", "micromaster4"]) == "micromaster4"  # --profile wins
    drives = "".join(
        f'[[bus.drive]]\naddress = {a}\nname = "d{a}"\nprofile = "nord"\n' for a in (5, 6)
    )
    Path("uss.toml").write_text(line("line1", sim) + drives)  # as uss scan --save writes it
    assert page_scan_profile([]) == "nord"  # the profile all the line's drives have
    Path("uss.toml").write_text(line("line1", sim, (5, "conveyor")))
    assert page_scan_profile([]) == "generic"  # none named


def auto_page(profile: str, address: str) -> tuple[list[dict[str, object]], str]:
    """The drives `uss web --profile auto` shows of a simulated ``profile`` drive, and its
    stderr."""
    with simulator("--profile", profile, "--address", address, "--baud", "9600") as url:
        argv = ["web", "--port", url, "--address", address, "--profile", "auto"]
        process, lines = serve([*argv, "--timeout", "0.5", "--listen", "127.0.0.1:0"], "http://")
        try:
            bus = page_bus(lines[-1])
        finally:
            assert stop(process) == 0
    drives = bus["drives"]
    assert isinstance(drives, list) and process.stderr is not None
    return drives, process.stderr.read()


@STOPPED
def test_uss_web_profile_auto_asks_each_drive_its_family() -> None:
    pytest.importorskip("aiohttp")
    drives, _ = auto_page("sinamics-v20", "2")
    assert [(d["address"], d["profile"]) for d in drives] == [(2, "sinamics-v20")]
    # a drive that shows no family: one of unknown kind, and the page says so on stderr
    drives, stderr = auto_page("generic", "3")
    assert [(d["address"], d["profile"]) for d in drives] == [(3, "unknown")]
    assert "address 3: the drive shows no family known here" in stderr
    # one that shows only its kind: read with its kind's file, and the page says so
    drives, stderr = auto_page("sinamics-g120", "4")
    assert [(d["address"], d["profile"]) for d in drives] == [(4, "micromaster4")]
    assert "address 4: Siemens, MICROMASTER 4 kind" in stderr
    assert "taken from the micromaster4 profile's file, not from the drive" in stderr
    done = subprocess.run(
        [*USS, "web", "--port", "/dev/null", "--profile", "auto", "--listen", "127.0.0.1:0"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2 and "--profile auto: give the drives" in done.stderr


def test_the_example_of_the_docs_runs_as_written(sim: str) -> None:
    text = (ROOT / "docs" / "lines.md").read_text(encoding="utf-8")
    text = text.split("\n## Written by `uss scan --save`")[0]  # tests/cli/test_scan_save.py
    (toml,) = re.findall(r"```toml\n(.*?)```", text, re.S)
    (session,) = re.findall(r"```console\n(.*?)```", text, re.S)
    Path("uss.toml").write_text(toml.replace("/dev/ttyUSB0", sim))
    steps = re.split(r"^\$ ", session, flags=re.M)[1:]
    assert len(steps) == 4
    for step in steps:
        command, *shown = step.rstrip("\n").split("\n")
        argv = shlex.split(command)
        assert argv[0] == "uss"
        done = subprocess.run(
            [*USS, *argv[1:]], capture_output=True, text=True, timeout=60, check=False
        )
        printed = (done.stdout + done.stderr).splitlines()
        fails = any(s.startswith("uss ") for s in shown)
        assert (done.returncode != 0) == fails, (command, printed)
        for want in shown:
            assert want == "..." or want in printed, (command, want, printed)
