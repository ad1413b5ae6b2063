"""The log file: whole rows, append only to a log with the same columns, rotation by size."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

from pyuss.datalog import CsvLog, parse_size
from pyuss.errors import ConfigError

HEADER = ["time", "status word", "actual PZD2 [Hz]", "comm"]


def rows(path: Path) -> list[list[str]]:
    with open(path, newline="", encoding="utf-8") as file:
        return list(csv.reader(file))


def test_a_new_log_starts_with_its_header_and_gets_whole_rows(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    log = CsvLog(path, HEADER)
    assert rows(path) == [HEADER]  # the header is there before the first sample
    log.write(["2024-01-01T00:00:00.000+00:00", "567", "12.5", "ok"])
    log.write(["2024-01-01T00:00:01.000+00:00", "", "", "no answer"])
    log.close()
    assert rows(path)[1:] == [
        ["2024-01-01T00:00:00.000+00:00", "567", "12.5", "ok"],
        ["2024-01-01T00:00:01.000+00:00", "", "", "no answer"],
    ]
    assert path.read_bytes().endswith(b"\r\n")


def test_an_existing_file_is_never_overwritten(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    path.write_text("my own data\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="exists: --append"):
        CsvLog(path, HEADER)
    assert path.read_text(encoding="utf-8") == "my own data\n"


def test_append_needs_the_same_columns(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    first = CsvLog(path, HEADER)
    first.write(["t1", "1", "2", "ok"])
    first.close()
    with pytest.raises(ConfigError, match="other columns"):
        CsvLog(path, ["time", "state", "comm"], append=True)
    again = CsvLog(path, HEADER, append=True)
    again.write(["t2", "3", "4", "ok"])
    again.close()
    assert rows(path) == [HEADER, ["t1", "1", "2", "ok"], ["t2", "3", "4", "ok"]]


@pytest.mark.parametrize("content", [b"", b"\x00\x01PK\n", "Zeit;Drehzahl\n".encode("utf-16")])
def test_append_to_a_file_that_is_no_log_is_refused(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "run.csv"
    path.write_bytes(content)
    with pytest.raises(ConfigError, match=f"^{re.escape(str(path))} is not a CSV log of uss"):
        CsvLog(path, HEADER, append=True)
    assert path.read_bytes() == content


@pytest.mark.posix("/dev/zero")
def test_append_to_an_endless_device_is_refused_at_once() -> None:
    with pytest.raises(ConfigError, match=r"^/dev/zero is not a CSV log of uss log$"):
        CsvLog("/dev/zero", HEADER, append=True)


def test_append_removes_a_row_cut_short_by_a_crash(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    log = CsvLog(path, HEADER)
    log.write(["t1", "1", "2", "ok"])
    log.close()
    with open(path, "ab") as file:
        file.write(b"t2,3,")  # the program died in the middle of a row
    again = CsvLog(path, HEADER, append=True)
    assert again.repaired == len(b"t2,3,")
    again.write(["t3", "5", "6", "ok"])
    again.close()
    assert rows(path) == [HEADER, ["t1", "1", "2", "ok"], ["t3", "5", "6", "ok"]]


def test_rotation_keeps_every_file_below_the_size_with_its_header(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    log = CsvLog(path, HEADER, rotate=1000)
    for number in range(100):
        log.write([f"2024-01-01T00:00:{number:02d}.000+00:00", str(number), "1.5", "ok"])
    log.close()
    files = [*log.rotated, path]
    assert len(log.rotated) >= 3
    seen = []
    for file in files:
        assert file.stat().st_size <= 1000
        content = rows(file)
        assert content[0] == HEADER
        seen += [int(row[1]) for row in content[1:]]
    assert seen == list(range(100))  # nothing lost, nothing twice, in order
    assert all(f.name.startswith("run-") and f.suffix == ".csv" for f in log.rotated)


def test_a_folder_that_does_not_exist_is_bad_input(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="does not exist"):
        CsvLog(tmp_path / "missing" / "run.csv", HEADER)


@pytest.mark.parametrize(
    ("text", "size"), [("10M", 10_000_000), ("500k", 500_000), ("2000", 2000), ("1G", 10**9)]
)
def test_sizes(text: str, size: int) -> None:
    assert parse_size(text) == size


@pytest.mark.parametrize("text", ["", "ten", "10X", "12"])
def test_bad_sizes(text: str) -> None:
    with pytest.raises(ConfigError):
        parse_size(text)
