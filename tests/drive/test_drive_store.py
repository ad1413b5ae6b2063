"""EEPROM writes survive a power cycle; a torn or corrupt store file is refused by name."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from pyuss.drive.loader import load_profile
from pyuss.drive.memory import ParameterMemory
from pyuss.drive.store import StoreError, decode_store, encode_store


def power_on(path: Path, profile: str = "generic") -> ParameterMemory:
    return ParameterMemory(load_profile(profile), store=path)


def test_eeprom_writes_survive_a_power_cycle_ram_writes_do_not(tmp_path: Path) -> None:
    path = tmp_path / "drive5.store"
    drive = power_on(path)
    drive.write_words(18, [0x7000], interface="uss", eeprom=True)
    drive.write_words(4, [0x4000, 0x0000], 2, interface="uss", eeprom=True)
    drive.write(107, 60.5, eeprom=True)
    drive.write(90, "LINE 3", eeprom=True)
    drive.write_array_words(686, [4, 6, 8], eeprom=True)
    drive.write(683, 9, 1)  # RAM only
    drive = power_on(path)
    assert drive.value(18) == 0x7000
    assert drive.value(4, 2) == 0x4000_0000
    assert drive.value(107) == 60.5
    assert drive.value(90).rstrip() == "LINE 3"  # type: ignore[union-attr]
    assert drive.values(686) == (4, 6, 8)
    assert drive.value(683, 1) == 0  # back to the factory value
    assert drive.stored()[(18, None)] == (0x7000,)


def test_a_drive_that_never_stored_starts_with_factory_values(tmp_path: Path) -> None:
    drive = power_on(tmp_path / "new.store")
    assert drive.value(18) == 0
    assert not (tmp_path / "new.store").exists()


def _stored_file(tmp_path: Path) -> Path:
    path = tmp_path / "drive.store"
    power_on(path).write(18, 1234, eeprom=True)
    return path


def test_torn_file_is_refused(tmp_path: Path) -> None:
    path = _stored_file(tmp_path)
    data = path.read_bytes()
    path.write_bytes(data[:-5])
    with pytest.raises(StoreError, match="torn") as info:
        power_on(path)
    assert str(path) in str(info.value)


def test_corrupted_byte_is_refused(tmp_path: Path) -> None:
    path = _stored_file(tmp_path)
    data = bytearray(path.read_bytes())
    data[-3] ^= 0x01
    path.write_bytes(bytes(data))
    with pytest.raises(StoreError, match="checksum") as info:
        power_on(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("content", [b"", b"garbage\n{}", b'{"profile": "generic", "values": []}'])
def test_foreign_content_is_refused(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "x.store"
    path.write_bytes(content)
    with pytest.raises(StoreError, match="header"):
        power_on(path)


def test_store_of_another_profile_is_refused(tmp_path: Path) -> None:
    path = _stored_file(tmp_path)
    with pytest.raises(StoreError, match="'generic'"):
        power_on(path, "nord")


def test_stored_value_that_no_longer_fits_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "drive.store"
    path.write_bytes(encode_store("generic", {(683, 1): (77,)}))  # limit of P683 is 30
    with pytest.raises(StoreError, match=r"P683\.1"):
        power_on(path)
    path.write_bytes(encode_store("generic", {(999, None): (1,)}))
    with pytest.raises(StoreError, match="P999"):
        power_on(path)
    path.write_bytes(encode_store("generic", {(4, 1): (1,)}))  # a double word needs two
    with pytest.raises(StoreError, match=r"P4\.1"):
        power_on(path)


def test_failed_save_changes_nothing_and_leaves_no_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _stored_file(tmp_path)
    before = path.read_bytes()
    drive = power_on(path)

    def broken_fsync(fd: int) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", broken_fsync)
    with pytest.raises(StoreError, match="No space left"):
        drive.write(18, 99, eeprom=True)
    monkeypatch.undo()
    assert drive.value(18) == 1234  # RAM unchanged as well
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive.store"]


def test_store_folder_must_exist(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="does not exist"):
        power_on(tmp_path / "missing" / "drive.store")


def test_codec_round_trip() -> None:
    values = {(18, None): (0x7000,), (4, 2): (0x4000, 0)}
    assert decode_store(encode_store("p", values), "p", "f") == values


_WRITER = """
import sys, time
from pyuss.atomicfile import AtomicWriter
writer = AtomicWriter(sys.argv[1], "the store")
writer.write(b"half of a store")
print(writer.tmp, flush=True)
time.sleep(60)
"""


def _writer(path: Path) -> tuple[subprocess.Popen[str], Path]:
    """A process caught in the middle of writing ``path``: its temporary file."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _WRITER, str(path)],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    return proc, Path(proc.stdout.readline().strip())


def test_temporary_file_of_a_killed_writer_is_removed_at_the_next_start(tmp_path: Path) -> None:
    """kill -9 during an EEPROM write leaves .drive5.store.*.tmp; the next start of that
    store removes it, and the stored values are those of the last complete write."""
    path = tmp_path / "drive5.store"
    power_on(path).write_words(18, [0x7000], interface="uss", eeprom=True)
    proc, tmp = _writer(path)
    proc.kill()  # SIGKILL on POSIX systems: no clean end
    proc.wait()
    assert tmp.exists() and tmp.name.startswith(".drive5.store.")
    drive = power_on(path)
    assert not tmp.exists()
    assert sorted(os.listdir(tmp_path)) == ["drive5.store"]
    assert drive.value(18) == 0x7000


def test_temporary_file_of_a_live_writer_is_left_alone(tmp_path: Path) -> None:
    """Two drives sharing a store folder: the start of one never takes the file another is
    writing at that moment; nor the files of other stores."""
    path = tmp_path / "drive5.store"
    other = tmp_path / ".drive6.store.abcdefgh.tmp"
    other.write_bytes(b"not ours")
    proc, tmp = _writer(path)
    try:
        power_on(path)
        assert tmp.exists()
        assert other.exists()
    finally:
        proc.kill()
        proc.wait()
    power_on(path)
    assert not tmp.exists()
    assert other.exists()
