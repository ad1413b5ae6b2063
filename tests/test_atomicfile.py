"""Files the user keeps (recordings, captures, stores, GSD, dissector) are written one way:
checked before any work, complete or absent, with ordinary permissions, and never lost."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from pyuss.atomicfile import AtomicWriter, write_atomically
from pyuss.cli.main import main
from pyuss.errors import ConfigError


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def test_written_file_has_the_permissions_of_any_new_file(tmp_path: Path) -> None:
    target = tmp_path / "out.bin"
    write_atomically(target, b"data")
    assert target.read_bytes() == b"data"
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~_umask()
    assert os.listdir(tmp_path) == ["out.bin"]


@pytest.mark.parametrize("kind", ["folder", "missing folder"])
def test_a_target_that_cannot_be_written_is_refused_before_any_work(
    tmp_path: Path, kind: str
) -> None:
    target = tmp_path if kind == "folder" else tmp_path / "nope" / "x.jsonl"
    with pytest.raises(ConfigError, match=str(target)):
        AtomicWriter(target, "a recording")
    assert os.listdir(tmp_path) == []


@pytest.mark.posix("os.mkfifo")
@pytest.mark.parametrize("link", [False, True])
def test_a_pipe_or_device_is_never_replaced_by_a_file(tmp_path: Path, link: bool) -> None:
    # the rename would put a file where the pipe (or, for root, /dev/null) was
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    target = pipe
    if link:
        target = tmp_path / "capture.pcapng"
        target.symlink_to(pipe)
    with pytest.raises(ConfigError, match=r"no regular file .* give a file"):
        AtomicWriter(target, "a capture")
    with pytest.raises(ConfigError, match="no regular file"):
        write_atomically(target, b"data", "the GSD file")
    assert stat.S_ISFIFO(pipe.stat().st_mode)
    assert sorted(os.listdir(tmp_path)) == sorted({"pipe", target.name})


@pytest.mark.posix("os.mkfifo")
def test_gsd_onto_a_pipe_is_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    os.mkfifo(tmp_path / "pipe")
    code = main(["ksvario", "gsd", "--output", str(tmp_path / "pipe")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "no regular file" in err, err
    assert stat.S_ISFIFO((tmp_path / "pipe").stat().st_mode)


def test_a_failed_rename_keeps_what_was_written(tmp_path: Path) -> None:
    target = tmp_path / "capture.pcapng"
    writer = AtomicWriter(target, "a capture")
    writer.write(b"an hour of traffic")
    target.mkdir()  # the name turned into a folder meanwhile
    with pytest.raises(ConfigError, match="kept as") as info:
        writer.close()
    kept = Path(writer.tmp)
    assert str(kept) in str(info.value)
    assert kept.read_bytes() == b"an hour of traffic"


def test_an_error_inside_the_block_leaves_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "store"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError), AtomicWriter(target, "the store") as writer:
        writer.write(b"new, half")
        raise RuntimeError
    assert target.read_bytes() == b"old"
    assert os.listdir(tmp_path) == ["store"]


def test_bus_record_into_a_folder_is_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["bus", "--tcp", "127.0.0.1:0", "--duration", "1", "--record", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "it is a folder" in err, err


def test_gsd_into_a_folder_is_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["ksvario", "gsd", "--output", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "it is a folder" in err, err
    assert os.listdir(tmp_path) == []


def test_gsd_file_is_readable_like_any_new_file(tmp_path: Path) -> None:
    target = tmp_path / "PMA_1030.gsd"
    assert main(["ksvario", "gsd", "--output", str(target)]) == 0
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~_umask()
    assert target.read_bytes().startswith(b";")
