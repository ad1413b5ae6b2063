"""uss log against simulated drives: fresh rows, units in the header, and a drive that stops
answering written as such - never with its last values."""

from __future__ import annotations

import asyncio
import contextlib
import csv
import datetime as dt
import json
import os
import re
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from cli.test_simulate import _first_line, _start
from pyuss.bus import VirtualBus
from pyuss.datalog import NO_ANSWER, CsvLog, DataLogger, parse_values
from pyuss.datalog.logger import LogResult, rate_text
from pyuss.master import Master
from pyuss.master.testing import simulated_drives
from pyuss.protocol.layout import Layout

UV = [sys.executable, "-m", "pyuss.cli.main"]


def rows(path: Path) -> list[dict[str, str]]:
    """The rows of a log, without its ``#`` comment rows."""
    with open(path, newline="", encoding="utf-8") as file:
        return [row for row in csv.DictReader(file) if not row["time"].startswith("#")]


async def test_a_drive_that_stops_answering_is_logged_as_silent(tmp_path: Path) -> None:
    bus = VirtualBus(38400)
    path = tmp_path / "run.csv"
    try:
        async with (
            simulated_drives(bus, [(5, "generic", Layout(4, 2))]),
            Master(bus.attach("master"), profile="generic") as master,
        ):
            drive = master.drive(5, layout=Layout(4, 2))
            await drive.setpoint(25.0)
            await drive.on()
            logger = DataLogger(
                drive,
                parse_values(["status", "actual", "operation_enabled", "P352"]),
                rate=20,
                job_timeout=0.3,
            )
            await logger.prepare()
            log = CsvLog(path, logger.header())
            stop = asyncio.Event()
            task = asyncio.create_task(logger.run(log, stop))
            await asyncio.sleep(0.6)
            bus.make_dead("drive5", 1.5)  # the drive goes silent: power cut, cable pulled
            await asyncio.sleep(2.5)
            stop.set()
            result = await task
            log.close()
    finally:
        await bus.close()
    table = rows(path)
    assert list(table[0]) == [
        "time",
        "status word",
        "actual PZD2 [Hz]",
        "bit 2 operation enabled",
        "P352 Reference freq. [Hz]",
        "comm",
    ]
    comm = [row["comm"] for row in table]
    first_silent = comm.index(NO_ANSWER)
    back = comm.index("ok", first_silent)
    assert set(comm[:first_silent]) == {"ok"}
    assert set(comm[first_silent:back]) == {NO_ANSWER}
    assert result.no_answer == comm.count(NO_ANSWER) > 0
    # a silent drive gives a row every half second, not 20: the slots it skips are its own,
    # not those of a line too slow for the rate
    assert result.short and result.silent_skipped > 0
    said = rate_text(result)
    assert f"{result.silent_skipped} " in said and "while the drive did not answer" in said
    assert "the line is slower" not in rate_text(
        LogResult(rows=10, no_answer=5, rate=5, slots=30, silent_skipped=20)
    )
    for row in table:
        values = [row[name] for name in list(row)[1:-1]]
        if row["comm"] == NO_ANSWER:
            assert values == ["", "", "", ""]  # not the last values again
        else:
            assert all(values)
            assert row["P352 Reference freq. [Hz]"] == "50.00"
    times = [dt.datetime.fromisoformat(row["time"]) for row in table]
    assert all(t.tzinfo is not None for t in times)
    assert times == sorted(times)


@contextlib.contextmanager
def tcp_simulator() -> Iterator[tuple[subprocess.Popen[str], str]]:
    """``uss simulate`` with drive 5 on a TCP port, and the port's URL."""
    sim = subprocess.Popen(
        [*UV, "simulate", "--tcp", "127.0.0.1:0", "--address", "5", "--baud", "19200"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert sim.stdout is not None
        yield sim, sim.stdout.readline().strip()
    finally:
        if sim.poll() is None:
            sim.kill()
        sim.wait()


@pytest.mark.posix("stops uss log with SIGINT and checks it ended cleanly; waits with sleep")
def test_uss_log_writes_no_answer_once_the_simulator_is_gone(tmp_path: Path) -> None:
    with tcp_simulator() as (sim, url):
        log = None
        try:
            path = tmp_path / "drive5.csv"
            log = subprocess.Popen(
                [
                    *UV,
                    "log",
                    "5",
                    "status",
                    "state",
                    "P52",
                    "--rate",
                    "10",
                    "-o",
                    str(path),
                    "--port",
                    f"{url}?reconnect=1",
                    "--baud",
                    "19200",
                    "--timeout",
                    "0.3",
                ],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            deadline = 60.0
            while deadline > 0 and (not path.exists() or len(rows(path)) < 5):
                assert log.poll() is None, log.communicate()
                deadline -= 0.1
                subprocess.run(["sleep", "0.1"], check=True)
            sim.send_signal(signal.SIGTERM)  # the drive goes away
            sim.wait(30)
            deadline = 60.0
            while deadline > 0 and NO_ANSWER not in [r["comm"] for r in rows(path)[-3:]]:
                deadline -= 0.1
                subprocess.run(["sleep", "0.1"], check=True)
            log.send_signal(signal.SIGINT)
            out, err = log.communicate(timeout=30)
            assert log.returncode == 0, err
            table = rows(path)
            assert table[0]["comm"] == "ok" and table[0]["P52"] == "16384"
            silent = [r for r in table if r["comm"] == NO_ANSWER]
            assert silent, table[-5:]
            assert all(r["status word"] == r["state"] == r["P52"] == "" for r in silent)
            assert "rows" in out
        finally:
            if log is not None and log.poll() is None:
                log.kill()
                log.wait()


def _small_files(limit: int) -> Callable[[], None]:
    """For a child process: files may grow to ``limit`` bytes; a write beyond fails with
    EFBIG (the signal that would kill the process for it is ignored), as on a full disk."""

    def setup() -> None:
        import resource

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return setup


def _log_until_the_file_fails(
    path: Path, setup: Callable[[], None] | None = None
) -> subprocess.CompletedProcess[str]:
    values = ["status", "P52", "--rate", "50", "--count", "1000", "-o", str(path)]
    with tcp_simulator() as (_, url):
        return subprocess.run(
            [*UV, "log", "5", *values, "--port", url, "--baud", "19200", "--timeout", "0.3"],
            capture_output=True,
            text=True,
            timeout=120,
            preexec_fn=setup,
        )


def _one_line_and_whole_rows(done: subprocess.CompletedProcess[str], path: Path, why: str) -> None:
    assert done.returncode == 1, done.stderr
    *_, last = done.stderr.splitlines()
    assert last == f"uss log: cannot write {path}: {why}", done.stderr
    assert "Traceback" not in done.stderr
    assert path.read_bytes().endswith(b"\r\n")  # no half row
    table = rows(path)
    assert len(table) > 5 and all(r["comm"] == "ok" and r["P52"] for r in table)


@pytest.mark.posix("RLIMIT_FSIZE and SIGXFSZ, set in the child by preexec_fn")
def test_a_log_the_system_refuses_to_grow_ends_in_one_line_with_whole_rows(
    tmp_path: Path,
) -> None:
    path = tmp_path / "run.csv"
    done = _log_until_the_file_fails(path, _small_files(700))
    _one_line_and_whole_rows(done, path, "file too large")
    assert path.stat().st_size > 600


@pytest.fixture
def full_disk(tmp_path: Path) -> Iterator[Path]:
    """A folder on a tmpfs of 64 kB with one page (4 kB) left free; root only."""
    folder = tmp_path / "disk"
    folder.mkdir()
    mount = ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)]
    if os.geteuid() != 0 or subprocess.run(mount, capture_output=True).returncode != 0:
        pytest.skip("a small tmpfs needs root (the RLIMIT_FSIZE test runs everywhere)")
    try:
        stat = os.statvfs(folder)
        (folder / "filler").write_bytes(bytes(stat.f_bavail * stat.f_frsize - 4096))
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=True)


@pytest.mark.posix("a small tmpfs mounted by root")
def test_a_log_on_a_full_disk_ends_in_one_line_with_whole_rows(full_disk: Path) -> None:
    path = full_disk / "run.csv"
    done = _log_until_the_file_fails(path)
    _one_line_and_whole_rows(done, path, "no space left on device")


def test_bad_values_are_bad_input(tmp_path: Path) -> None:
    done = subprocess.run(
        [*UV, "log", "5", "speed", "-o", str(tmp_path / "x.csv"), "--port", "tcp://127.0.0.1:9"],
        capture_output=True,
        text=True,
        env={**os.environ},
    )
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "speed" in done.stderr
    assert not (tmp_path / "x.csv").exists()


async def test_values_are_typed_by_the_parameter_model(tmp_path: Path) -> None:
    """A float in its unit with two decimals, a value of an array element as the number it is,
    a whole array, the main actual value in Hz through the reference parameter P2000."""
    bus = VirtualBus(38400)
    path = tmp_path / "mm4.csv"
    try:
        async with (
            simulated_drives(bus, [(3, "micromaster4", None)]),
            Master(bus.attach("master"), profile="micromaster4") as master,
        ):
            drive = master.drive(3)
            await drive.write(1120, 2.5)
            logger = DataLogger(
                drive, parse_values(["actual", "P1120", "P2010.1", "P947"]), rate=20
            )
            await logger.prepare()
            log = CsvLog(path, logger.header())
            await logger.run(log, asyncio.Event(), count=3)
            log.close()
    finally:
        await bus.close()
    table = rows(path)
    assert list(table[0]) == [
        "time",
        "actual PZD2 [Hz]",
        "P1120 Ramp-up time [s]",
        "P2010.1 USS baudrate",
        "P947 Last fault code",
        "comm",
    ]
    assert len(table) == 3
    for row in table:
        assert row["P1120 Ramp-up time [s]"] == "2.50"
        assert row["P2010.1 USS baudrate"] == "6"
        assert row["P947 Last fault code"] == "0 0 0 0 0 0 0 0"
        assert row["comm"] == "ok"


LINE = ["--baud", "9600", "--layout", "3,2"]
GENERIC = ["--profile", "generic"]  # the simulated drive's family: its parameters' types


def _log_on_a_9600_baud_line(tmp_path: Path, name: str, *args: str) -> tuple[str, str, Path]:
    """``uss log 5 status ARGS`` on a virtual bus at 9600 baud with true character timing (one
    exchange of PKW 3 + PZD 2 takes some 37 ms there); its stdout, stderr and file."""
    sim = _start("simulate", "--bus-tcp", "127.0.0.1:0", *LINE, "--address", "5")
    try:
        url = _first_line(sim)
        path = tmp_path / name
        done = subprocess.run(
            [*UV, "log", "5", "status", *args, "-o", str(path), "--port", url, *LINE, *GENERIC],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
        return done.stdout, done.stderr, path
    finally:
        sim.send_signal(signal.SIGTERM)
        sim.communicate(timeout=30)


def test_a_rate_the_line_cannot_carry_is_said(tmp_path: Path) -> None:
    _, err, path = _log_on_a_9600_baud_line(tmp_path, "fast.csv", "--rate", "50", "--count", "30")
    said = [line for line in err.splitlines() if "samples a second reached" in line]
    assert len(said) == 2, err  # once early, once at the end
    assert all(line.startswith("uss log: ") and "of the 50 asked" in line for line in said)
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[-1].startswith("# ") and "of the 50 asked: the line is slower" in lines[-1]
    assert lines[-1].endswith(",")  # a row of its own, as many cells as the header
    reached = float(lines[-1].split()[1])
    assert 0 < reached < 45 and len(rows(path)) == 30


def test_a_rate_the_line_carries_says_nothing_more_and_words_are_hex(tmp_path: Path) -> None:
    out, err, path = _log_on_a_9600_baud_line(
        tmp_path, "slow.csv", "P552", "--rate", "2", "--count", "4", "--json"
    )
    summary = json.loads(out)
    assert summary["rate"] == 2 and summary["rate_reached"] == 2 and not err
    assert not [line for line in path.read_text().splitlines() if line.startswith("#")]
    table = rows(path)
    assert len(table) == 4
    for row in table:  # the status word and a V2 parameter (P552) in hex, as everywhere
        assert re.fullmatch(r"[0-9A-F]{4}h", row["status word"]), row
        assert re.fullmatch(r"[0-9A-F]{4}h", row["P552 Status word"]), row
    assert table[0]["status word"] == "0240h"  # switch-on inhibited, as the simulator starts
