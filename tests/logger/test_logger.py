"""uss log against simulated drives: fresh rows, units in the header, and a drive that stops
answering written as such - never with its last values."""

from __future__ import annotations

import asyncio
import contextlib
import csv
import datetime as dt
import os
import resource
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from pyuss.bus import VirtualBus
from pyuss.datalog import NO_ANSWER, CsvLog, DataLogger, parse_values
from pyuss.master import Master
from pyuss.master.testing import simulated_drives
from pyuss.protocol.layout import Layout

UV = [sys.executable, "-m", "pyuss.cli.main"]


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as file:
        return list(csv.DictReader(file))


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
            assert table[0]["comm"] == "ok" and table[0]["P52 Load display"] == "16384"
            silent = [r for r in table if r["comm"] == NO_ANSWER]
            assert silent, table[-5:]
            assert all(
                r["status word"] == r["state"] == r["P52 Load display"] == "" for r in silent
            )
            assert "rows" in out
        finally:
            if log is not None and log.poll() is None:
                log.kill()
                log.wait()


def _small_files(limit: int) -> Callable[[], None]:
    """For a child process: files may grow to ``limit`` bytes; a write beyond fails with
    EFBIG (the signal that would kill the process for it is ignored), as on a full disk."""

    def setup() -> None:
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
    assert len(table) > 5 and all(r["comm"] == "ok" and r["P52 Load display"] for r in table)


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
