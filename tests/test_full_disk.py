"""A disk that is full or read-only: one line naming the file and the reason, a non-zero exit,
no half-written file and the old file kept (atomic writes, backups, logs).

The disk is real: a tmpfs of a few KiB, mounted in a user and mount namespace of the test's
own (``unshare``), filled up before the command runs. Where the system allows no such
namespace the tests say so and skip."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from support.processes import first_line, start_uss, stop_uss

pytestmark = pytest.mark.skipif(
    shutil.which("unshare") is None or not sys.platform.startswith("linux"),
    reason="needs unshare (util-linux) to mount a small disk of the test's own",
)

UUS = str(Path(sys.executable).with_name("uss"))


def _namespaces_work() -> bool:
    done = subprocess.run(
        ["unshare", "--user", "--map-root-user", "--mount", "true"],
        capture_output=True,
        check=False,
    )
    return done.returncode == 0


def on_small_disk(
    folder: Path, script: str, *, fill: bool = True
) -> subprocess.CompletedProcess[str]:
    """Run the shell ``script`` with an 8 KiB tmpfs at ``folder`` (``$DISK``), holding
    ``$DISK/old.json`` (a file written before) and, with ``fill``, full to the last byte."""
    if not _namespaces_work():
        pytest.skip("this system refuses user namespaces (unshare --user)")
    folder.mkdir(exist_ok=True)
    setup = f"""
        set -u
        mount -t tmpfs -o size=8k none {folder}
        DISK={folder}
        printf '{{"old": true}}\\n' > $DISK/old.json
    """
    if fill:
        setup += "dd if=/dev/zero of=$DISK/fill bs=1k count=64 2>/dev/null || true\n"
    return subprocess.run(
        ["unshare", "--user", "--map-root-user", "--mount", "sh", "-c", setup + script],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def _python(code: str) -> str:
    return f"{sys.executable} -c {_quote(textwrap.dedent(code))}"


def _quote(text: str) -> str:
    return "'" + text.replace("'", "'\\''") + "'"


def test_an_atomic_write_onto_a_full_disk_fails_whole_and_keeps_the_old_file(
    tmp_path: Path,
) -> None:
    code = """
        import sys
        from pyuss.atomicfile import write_atomically
        from pyuss.errors import ConfigError
        try:
            write_atomically(sys.argv[1], b"x" * 100_000, "the backup")
        except ConfigError as exc:
            print("refused:", exc)
    """
    done = on_small_disk(tmp_path / "disk", f"{_python(code)} $DISK/old.json; ls -A $DISK")
    lines = done.stdout.splitlines()
    assert lines[0].startswith("refused: cannot write the backup ")
    assert "old.json: No space left on device" in lines[0], done.stdout + done.stderr
    assert sorted(lines[1:]) == ["fill", "old.json"]  # no temporary file left beside it


def test_a_streamed_file_on_a_full_disk_names_what_was_kept(tmp_path: Path) -> None:
    code = """
        import sys
        from pyuss.atomicfile import AtomicWriter
        from pyuss.errors import ConfigError
        writer = AtomicWriter(sys.argv[1], "a capture")
        try:
            for _ in range(100):
                writer.write(b"y" * 4096)
            writer.close()
        except ConfigError as exc:
            print("refused:", exc)
    """
    done = on_small_disk(tmp_path / "disk", f"{_python(code)} $DISK/cap.pcapng", fill=False)
    out = done.stdout.strip()
    assert out.startswith("refused: cannot write a capture "), done.stdout + done.stderr
    assert "No space left on device; what was written is kept as " in out


@pytest.fixture
def simulator() -> Iterator[str]:
    process = start_uss("simulate", "--address", "5", "--tcp", "127.0.0.1:0")
    try:
        yield first_line(process, "tcp://")
    finally:
        stop_uss(process)


def test_uss_backup_onto_a_full_disk_is_one_line_and_leaves_nothing(
    tmp_path: Path, simulator: str
) -> None:
    done = on_small_disk(
        tmp_path / "disk",
        f"{UUS} backup 5 -o $DISK/new.json --port {simulator} --profile generic; echo exit=$?;"
        " ls -A $DISK",
    )
    err = done.stderr.strip().splitlines()
    assert len(err) == 1, done.stderr
    assert err[0].startswith("uss backup: cannot write the backup ") and "new.json" in err[0]
    assert "No space left on device" in err[0] and "Traceback" not in done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] != "exit=0" and lines[0].startswith("exit=")
    assert sorted(lines[1:]) == ["fill", "old.json"]


def test_uss_backup_onto_a_read_only_disk_is_one_line(tmp_path: Path, simulator: str) -> None:
    done = on_small_disk(
        tmp_path / "disk",
        f"mount -o remount,ro $DISK; {UUS} backup 5 -o $DISK/new.json --port {simulator}"
        " --profile generic;"
        " echo exit=$?",
        fill=False,
    )
    assert done.stderr.strip().count("\n") == 0, done.stderr
    assert "uss backup: cannot write the backup to " in done.stderr
    assert "is not writable" in done.stderr
    assert done.stdout.strip() != "exit=0"


def test_uss_log_onto_a_full_disk_is_one_line_and_leaves_nothing(
    tmp_path: Path, simulator: str
) -> None:
    done = on_small_disk(
        tmp_path / "disk",
        f"{UUS} log 5 P0003 -o $DISK/log.csv --count 20 --port {simulator}; echo exit=$?;"
        " ls -A $DISK",
    )
    err = [line for line in done.stderr.splitlines() if line.startswith("uss log: ")]
    assert len(err) == 1 and "No space left on device" in err[0], done.stderr
    assert "log.csv" in err[0] and "Traceback" not in done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] != "exit=0"
    assert sorted(lines[1:]) == ["fill", "old.json"]
