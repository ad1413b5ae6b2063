"""Backups for real, against simulated drives on TCP: files that keep their word (atomic,
refused when cut short or broken), failures recorded, restores that go on past a refusal, the
profile and identity checks, and the file codec's round trip (hypothesis)."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from commission.test_docs import uss
from commission.test_restore_order import drive_of
from pyuss.commission.backup import Backup, Entry, dumps, load, loads, take
from pyuss.commission.compare import plan
from pyuss.errors import ConfigError
from pyuss.params.book import ParamBook
from pyuss.profiles import get_profile
from support.processes import simulator
from support.typed import Simulator, start, stop
from test_userfile import bad_files, refuses

USS = [sys.executable, "-m", "pyuss.cli.main"]


@pytest.fixture
def mm4() -> Iterator[Simulator]:
    params = Path(__file__).resolve().parents[2] / "src/pyuss/profiles/data/micromaster4.toml"
    sim = start(params, "--profile", "micromaster4", "--address", "3")
    try:
        yield sim
    finally:
        stop(sim)


def opts(sim: Simulator) -> list[str]:
    return ["--port", sim.path, "--baud", "38400", "--profile", "micromaster4"]


def test_a_backup_restored_diffs_back_to_empty(mm4: Simulator, tmp_path: Path) -> None:
    file = str(tmp_path / "set.json")
    assert uss(["backup", "3", "-o", file, *opts(mm4)])[0] == 0
    assert uss(["write", "3", "1120", "3", *opts(mm4)])[0] == 0
    assert uss(["write", "3", "947.0", "1", *opts(mm4)])[0] == 2  # read-only: refused first
    code, out = uss(["diff", "3", file, *opts(mm4), "--json"])
    assert code == 1 and [d["label"] for d in json.loads(out)["differences"]] == ["P1120"]
    assert json.loads(out)["sides"] == {"left": "drive 3 (live)", "right": f"file ({file})"}
    # which side is which, and what a restore would do: the file's value to the drive
    code, out = uss(["diff", "3", file, *opts(mm4)])
    assert code == 1 and out.splitlines() == [
        f"left: drive 3 (live) -> right: file ({file})",
        "P1120 (Ramp-up time): 3.00 s -> 10.00 s",
        f"1 parameter differs between drive 3 and {file}",
        f"uss restore 3 {file} (file -> drive 3) would make 1 write: P1120",
    ]
    code, out = uss(["restore", "3", file, "--yes", "--json", *opts(mm4)])
    result = json.loads(out)
    assert code == 0 and [r["label"] for r in result["results"]] == ["P1120"]
    assert uss(["diff", "3", file, *opts(mm4)]) == (
        0,
        f"left: drive 3 (live) -> right: file ({file})\n"
        f"drive 3 and {file} agree\n"
        f"uss restore 3 {file} (file -> drive 3) would write nothing\n",
    )
    assert uss(["diff", file, file])[0] == 0


def test_a_backup_replaces_a_file_only_with_force(mm4: Simulator, tmp_path: Path) -> None:
    file = tmp_path / "set.json"
    file.write_text("the backup of yesterday\n", encoding="utf-8")
    code, out = uss(["backup", "3", "-o", str(file), *opts(mm4)])
    assert code == 2
    assert out == f"uss backup: {file} exists: --force replaces it, or give another file name\n"
    assert file.read_text(encoding="utf-8") == "the backup of yesterday\n"
    assert uss(["backup", "3", "-o", str(file), "--force", *opts(mm4)])[0] == 0
    assert load(file).find(1120) is not None


@pytest.mark.posix("os.mkfifo")
def test_a_backup_never_replaces_a_device_or_a_pipe(mm4: Simulator, tmp_path: Path) -> None:
    pipe = tmp_path / "to-the-logger"
    os.mkfifo(pipe)
    code, out = uss(["backup", "3", "-o", str(pipe), "--format", "toml", "--force", *opts(mm4)])
    assert code == 2
    assert out == (
        f"uss backup: {pipe} is no regular file (a device, a pipe or a socket): "
        "a backup goes into a file of its own\n"
    )
    assert pipe.is_fifo()


def test_a_failing_parameter_is_recorded_and_the_backup_goes_on(
    mm4: Simulator, tmp_path: Path
) -> None:
    mine = tmp_path / "mine.toml"
    mine.write_text(
        '[profile]\nextends = "micromaster4"\nname = "mine"\n'
        '[[parameter]]\npnu = 999\nname = "Not there"\ntype = "uint16"\n',
        encoding="utf-8",
    )
    file = tmp_path / "set.toml"
    code, out = uss(["backup", "3", "-o", str(file), "--params", str(mine), *opts(mm4)])
    assert code == 1
    assert "P0999: not read: drive refused the job (P0999): error 0" in out
    taken = load(file)
    assert len(taken.entries) == 20 and [e.label for e in taken.failed] == ["P0999"]
    assert taken.failed[0].error == {
        "type": "DriveRefusal",
        "message": "drive refused the job (P0999): error 0: illegal parameter number"
        "; check the parameter number and the drive's profile: this drive has no such parameter",
        "number": 0,
        "meaning": "illegal parameter number",
        "hint": "check the parameter number and the drive's profile: this drive has no such "
        "parameter",
    }
    assert taken.find(1120) is not None and taken.find(1120).value == 10.0  # type: ignore[union-attr]


def test_a_cut_short_or_broken_file_is_refused_before_anything_is_written(
    mm4: Simulator, tmp_path: Path
) -> None:
    file = tmp_path / "set.toml"
    assert uss(["backup", "3", "-o", str(file), *opts(mm4)])[0] == 0
    assert uss(["write", "3", "1120", "3", *opts(mm4)])[0] == 0
    assert uss(["write", "3", "1121", "4", *opts(mm4)])[0] == 0
    text = file.read_text(encoding="utf-8")
    cut = tmp_path / "cut.toml"
    cut.write_text(text[: text.rindex("[[parameter]]")], encoding="utf-8")
    broken = tmp_path / "broken.toml"
    head, _, tail = text.partition("pnu = 1120\n")
    broken.write_text(
        head + "pnu = 1120\n" + tail.replace("value = 10.0", "value = 700.0", 1), encoding="utf-8"
    )
    garbage = tmp_path / "garbage.toml"
    garbage.write_text(text[: len(text) // 2] + '\nvalue = "', encoding="utf-8")
    for bad, message in (
        (cut, "the header counts 19 parameters, the file holds 18"),
        (broken, "P1120: 700.00 s is outside 0.00..650.00 s"),
        (garbage, "not a TOML or JSON backup"),
    ):
        code, out = uss(["restore", "3", str(bad), "--yes", *opts(mm4)])
        assert code == 2 and message in out and len(out.splitlines()) == 1, out
    code, out = uss(["read", "3", "1120", "1121", *opts(mm4)])
    assert "P1120 = 3.00 s" in out and "P1121 = 4.00 s" in out  # nothing was written


def test_another_profile_or_drive_is_refused_unless_forced(mm4: Simulator, tmp_path: Path) -> None:
    file = tmp_path / "set.json"
    assert uss(["backup", "3", "-o", str(file), *opts(mm4)])[0] == 0
    data = json.loads(file.read_text(encoding="utf-8"))
    data["profile"] = "nord"
    other = tmp_path / "nord.json"
    other.write_text(json.dumps(data), encoding="utf-8")
    code, out = uss(["restore", "3", str(other), "--yes", *opts(mm4)])
    assert code == 2 and "a backup of a nord drive" in out and "--force" in out
    data["profile"] = "micromaster4"
    data["identity"] = [{"pnu": 2010, "name": "USS baudrate", "value": [6, 13], "raw": "0006 000D"}]
    stranger = tmp_path / "stranger.json"
    stranger.write_text(json.dumps(data), encoding="utf-8")
    code, out = uss(["restore", "3", str(stranger), "--yes", *opts(mm4)])
    assert code == 2 and "from another drive: P2010 (USS baudrate)" in out
    assert uss(["restore", "3", str(stranger), "--yes", "--force", *opts(mm4)])[0] == 0
    code, out = uss(["restore", "3", str(file), *opts(mm4)])  # stdin is no terminal here
    assert code == 0 and "nothing to write" in out


def test_a_backup_killed_half_way_leaves_the_old_file(tmp_path: Path) -> None:
    params = Path(__file__).resolve().parents[2] / "src/pyuss/profiles/data/micromaster4.toml"
    slow = start(params, "--profile", "micromaster4", "--address", "3", "--latency-time", "100")
    try:
        file = tmp_path / "set.toml"
        file.write_text("the old backup\n", encoding="utf-8")
        process = subprocess.Popen(
            [*USS, "backup", "3", "-o", str(file), "--force", *opts(slow)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        time.sleep(1.0)  # a few parameters read, not all 19 at 100 ms or more each
        assert process.poll() is None
        process.kill()  # SIGKILL on POSIX systems: no clean end
        process.wait(10)
    finally:
        stop(slow)
    assert file.read_text(encoding="utf-8") == "the old backup\n"
    assert os.listdir(tmp_path) == ["set.toml"]  # no half-written file beside it


def test_scan_finds_the_parameters_no_file_knows(tmp_path: Path) -> None:
    from support.typed import TYPES_TOML

    params = tmp_path / "typed.toml"
    params.write_text(TYPES_TOML, encoding="utf-8")
    sim = start(params, "--layout", "v,2")
    try:
        port = ["--port", sim.path, "--baud", "38400", "--layout", "v,2"]
        asked = ["--describe", "always"]  # no --profile: the drive's descriptions on request
        code, out = uss(["params", "5", "--scan", "800-812", "--values", *port, *asked, "--json"])
        found = {p["pnu"]: p for p in json.loads(out)["parameters"]}
        assert code == 0 and {800, 805, 811} <= set(found)
        assert found[805]["source"] == "drive" and found[805]["value_text"] == "1500.50"
        file = tmp_path / "set.json"
        code, out = uss(["backup", "5", "-o", str(file), "--scan", "800-812", *port, *asked])
        assert code == 0
        assert load(file).find(804).value == -123.456  # type: ignore[union-attr]
    finally:
        stop(sim)


def test_status_and_acknowledge(mm4: Simulator) -> None:
    code, out = uss(["status", "3", *opts(mm4), "--json"])
    data = json.loads(out)
    assert code == 0 and data["state"] == "switch-on inhibited" and data["unit"] == "Hz"
    assert [p["label"] for p in data["parameters"]] == ["r0002", "r0021", "r0947.0"]
    code, out = uss(["ack", "3", *opts(mm4)])  # the drive reported no fault before
    assert code == 0 and out.startswith("drive 3: no fault to acknowledge: ready to switch on")


values = st.one_of(
    st.integers(-(2**31), 2**32 - 1),
    st.floats(allow_nan=False, allow_infinity=False, width=32),
    st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=16),
)
entries = st.builds(
    Entry,
    pnu=st.integers(0, 31999),
    index=st.one_of(st.none(), st.integers(0, 254)),
    name=st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=16),
    unit=st.sampled_from(["", "s", "Hz", "%"]),
    type=st.sampled_from(["float", "uint16", "int32", "string"]),
    value=st.one_of(values, st.lists(st.integers(0, 65535), min_size=1, max_size=8)),
    raw=st.lists(st.integers(0, 0xFFFF), max_size=4).map(tuple),
    access=st.sampled_from(["rw", "ro", "protected"]),
)


@given(
    st.lists(entries, max_size=12, unique_by=lambda e: (e.pnu, e.index)),
    st.sampled_from(["toml", "json"]),
)
def test_every_backup_reads_back_as_written(items: list[Entry], fmt: str) -> None:
    taken = Backup(3, "micromaster4", items, "2026-01-05T09:30:00+00:00", [], "/dev/ttyUSB0")
    again = loads(dumps(taken, fmt))
    assert again.entries == items and again.address == 3 and again.profile == "micromaster4"


@given(st.lists(entries, min_size=2, max_size=6, unique_by=lambda e: (e.pnu, e.index)))
def test_any_backup_cut_short_is_refused(items: list[Entry]) -> None:
    text = dumps(Backup(3, "generic", items), "toml")
    cut = text[: text.rindex("[[parameter]]")]
    with pytest.raises(ConfigError, match=r"cut short|not a TOML"):
        loads(cut)


def test_two_files_compare_without_a_drive(mm4: Simulator, tmp_path: Path) -> None:
    before, after = str(tmp_path / "before.toml"), str(tmp_path / "after.json")
    assert uss(["backup", "3", "-o", before, *opts(mm4)])[0] == 0
    assert uss(["write", "3", "1120", "500 ms", *opts(mm4)])[0] == 0
    assert uss(["backup", "3", "-o", after, *opts(mm4)])[0] == 0
    code, out = uss(["diff", before, after])
    assert code == 1
    # two files: the sides named, no drive to restore to
    assert out.splitlines() == [
        f"left: file ({before}) -> right: file ({after})",
        "P1120 (Ramp-up time): 10.00 s -> 0.50 s",
        f"1 parameter differs between {before} and {after}",
    ]
    code, out = uss(["diff", before, str(tmp_path / "missing.toml")])
    assert code == 2 and "cannot read" in out


def test_status_words_and_actual_values_are_no_differences_to_restore(tmp_path: Path) -> None:
    # two readings of a V20: before and after a run, with one setting changed in between
    def taken(status: int, control: int, ramp: float) -> Backup:
        return Backup(
            5,
            "sinamics-v20",
            [
                Entry(52, name="Status word 1", type="uint16", value=status, access="ro"),
                Entry(54, name="Control word 1", type="uint16", value=control, access="ro"),
                Entry(1120, 0, "Ramp-up time", "s", "float", ramp, access="rw"),
            ],
        )

    before, after = tmp_path / "before.toml", tmp_path / "after.toml"
    before.write_text(dumps(taken(59968, 0, 2.0), "toml"), "utf-8")
    after.write_text(dumps(taken(59953, 1150, 3.5), "toml"), "utf-8")
    code, out = uss(["diff", str(after), str(before)])
    assert code == 1
    # the status and control words in hex, with the bits that changed
    assert out.splitlines() == [
        f"left: file ({after}) -> right: file ({before})",
        "P1120.0 (Ramp-up time): 3.50 s -> 2.00 s",
        f"1 parameter differs between {after} and {before}",
        "read-only values, measured or shown by the drive (no settings, not restored):",
        "  r0052 (Status word 1): EA31h -> EA40h  -ready to switch on, -no OFF2, -no OFF3, "
        "+switch-on inhibited",
        "  r0054 (Control word 1): 047Eh -> 0000h  -no OFF2, -no OFF3, -enable operation, "
        "-ramp generator enabled, -ramp generator running, -setpoint enabled, -control by PLC",
    ]
    code, out = uss(["diff", str(after), str(before), "--json"])
    found = json.loads(out)
    assert [d["label"] for d in found["differences"]] == ["P1120.0"]
    assert [d["label"] for d in found["read_only"]] == ["r0052", "r0054"]
    # only the values the drive shows differ: the settings agree
    same = tmp_path / "same.toml"
    same.write_text(dumps(taken(59953, 1150, 2.0), "toml"), "utf-8")
    code, out = uss(["diff", str(before), str(same)])
    assert code == 0 and out.splitlines()[1] == f"{before} and {same} agree"
    # a restore plans no write for them, and does not list them as left out either
    book = ParamBook.for_profile(get_profile("sinamics-v20"))
    writes, skips = plan(
        loads(before.read_text("utf-8")), taken(59953, 1150, 3.5), book, get_profile("sinamics-v20")
    )
    assert [w.label for w in writes] == ["P1120.0"] and skips == []


def test_a_file_that_is_no_backup_is_one_line_naming_it(tmp_path: Path) -> None:
    good = tmp_path / "good.toml"
    good.write_text(dumps(Backup(3, "micromaster4", [Entry(1120, value=10.0)]), "toml"), "utf-8")
    nowhere = ["--port", str(tmp_path / "no-port"), "--profile", "micromaster4"]
    for bad, message in bad_files(tmp_path, "the backup", json_too=True):
        for command, argv in (
            ("diff", ["diff", str(good), str(bad)]),
            ("diff", ["diff", str(bad), str(good)]),
            ("restore", ["restore", "3", str(bad), "--yes", *nowhere]),
        ):
            code, out = uss(argv)
            line, *more = out.splitlines()
            assert code == 2 and not more, out
            assert refuses(line.removeprefix(f"uss {command}: "), bad, message), line


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        ("inf", "inf is not a finite number"),
        ("-inf", "-inf is not a finite number"),
        ("nan", "nan is not a finite number"),
        ("[1.0, nan]", "nan is not a finite number"),
        (f"1{'0' * 400}", "100000... (401 digits) is beyond the range of any parameter"),
    ],
)
def test_a_number_no_parameter_holds_is_refused_naming_the_parameter(
    tmp_path: Path, value: str, shown: str
) -> None:
    good = tmp_path / "good.toml"
    text = dumps(Backup(3, "micromaster4", [Entry(1120, value=10.0)]), "toml")
    good.write_text(text, encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("value = 10.0", f"value = {value}"), encoding="utf-8")
    code, out = uss(["diff", str(good), str(bad)])
    assert (code, out) == (2, f"uss diff: {bad}: parameter 1 (P1120): field 'value': {shown}\n")
    if not value.startswith("1"):  # JSON has no such numbers but Python writes them
        json_file = tmp_path / "bad.json"
        json_file.write_text(json.dumps(tomllib.loads(bad.read_text(encoding="utf-8"))), "utf-8")
        code, out = uss(["diff", str(json_file), str(good)])
        assert (code, out) == (
            2,
            f"uss diff: {json_file}: parameter 1 (P1120): field 'value': {shown}\n",
        )


def test_descriptions_kept_in_a_cache_file_for_the_next_run(tmp_path: Path) -> None:
    from support.typed import TYPES_TOML

    params = tmp_path / "typed.toml"
    params.write_text(TYPES_TOML, encoding="utf-8")
    cache = str(tmp_path / "cache.json")
    sim = start(params, "--layout", "v,2")
    try:
        port = ["--port", sim.path, "--baud", "38400", "--layout", "v,2"]
        typed = "P805 = 1500.50 (Speed limit)\n"  # the type and name from the drive (no unit)
        asked = ["--describe", "always"]  # no --profile: the drive's descriptions on request
        assert uss(["read", "5", "805", *port, *asked, "--params-cache", cache]) == (0, typed)
        never = ["--describe", "never"]
        assert uss(["read", "5", "805", *port, *never]) == (0, "P805 = 1153142784 (44BB9000h)\n")
        assert uss(["read", "5", "805", *port, *never, "--params-cache", cache]) == (0, typed)
        for bad, message in bad_files(tmp_path, "the description cache", json_too=True):
            # a missing cache is an empty one; dotted keys and bare numbers are no JSON
            if bad.name not in ("missing.toml", "dotted.toml", "long.toml"):
                code, out = uss(["read", "5", "805", *port, "--params-cache", str(bad)])
                line, *more = out.splitlines()
                assert code == 2 and not more, out
                assert refuses(line.removeprefix("uss read: "), bad, message), line
    finally:
        stop(sim)


OLD_BACKUP = """\
pyuss_backup = 1
address = 3
profile = "micromaster4"
date = "2026-01-05T09:30:00+00:00"
port = "/dev/pts/7"
count = 3
identity = []

[[parameter]]
pnu = 21
label = "P21"
name = "Act. frequency"
unit = "Hz"
type = "float"
access = "ro"
value = 0.0
raw = "0000 0000"

[[parameter]]
pnu = 947
index = 1
label = "P947.1"
name = "Last fault code"
type = "uint16"
access = "ro"
value = 0
raw = "0000"

[[parameter]]
pnu = 1120
label = "P1120"
name = "Ramp-up time"
unit = "s"
type = "float"
access = "rw"
value = 10.0
raw = "4120 0000"
"""


def test_a_backup_written_before_reads_and_names_as_the_family_writes(tmp_path: Path) -> None:
    """Files keep ``pnu`` and ``index`` as numbers; the ``label`` they carry is not read, so
    a file written in the project's spelling reads as it did and prints in the family's."""
    old = loads(OLD_BACKUP)
    assert [(e.pnu, e.index) for e in old.entries] == [(21, None), (947, 1), (1120, None)]
    assert [e.label for e in old.entries] == ["r0021", "r0947.1", "P1120"]
    by_hand = OLD_BACKUP.replace("pnu = 21\n", 'pnu = "r0021"\n')
    by_hand = by_hand.replace("pnu = 947\nindex = 1\n", 'pnu = "r0947[1]"\n')
    by_hand = by_hand.replace("pnu = 1120\n", 'pnu = "P1120"\n')
    assert loads(by_hand).entries == old.entries
    old_file, hand_file = tmp_path / "old.toml", tmp_path / "hand.toml"
    old_file.write_text(OLD_BACKUP, encoding="utf-8")
    hand_file.write_text(by_hand.replace("value = 0.0", "value = 1.5"), encoding="utf-8")
    code, out = uss(["diff", str(old_file), str(hand_file)])
    assert (code, out.splitlines()[-1]) == (0, "  r0021 (Act. frequency): 0.00 Hz -> 1.50 Hz")
    with pytest.raises(ConfigError) as info:
        loads(OLD_BACKUP.replace("pnu = 21\n", 'pnu = "P21x"\n'))
    assert "parameter 1: field 'pnu': 'P21x' is not a parameter number" in str(info.value)
    with pytest.raises(ConfigError, match="names index 1, 'index' 2"):
        loads(OLD_BACKUP.replace("pnu = 947\nindex = 1\n", 'pnu = "r0947[1]"\nindex = 2\n'))


V20 = Path(__file__).resolve().parents[2] / "src/pyuss/profiles/data/sinamics-v20.toml"


def v20_opts(sim: Simulator) -> list[str]:
    return ["--port", sim.path, "--baud", "38400", "--profile", "sinamics-v20"]


def restore_cut_short(
    tmp_path: Path, cut: Callable[[Simulator, subprocess.Popen[str]], None], *timeout: str
) -> tuple[int, list[str], Simulator]:
    """A V20 set up, its factory backup restored in a process of its own, which ``cut``
    cuts short once the writes begin: the exit code, the lines on stderr, the simulator."""

    async def factory() -> Backup:  # a V20 as it leaves the factory, the parameters used
        async with drive_of("sinamics-v20") as drive:
            return await take(drive, pnus=[305, 307, 1120, 1121])

    file = tmp_path / "factory.json"
    file.write_text(dumps(asyncio.run(factory()), "json"), encoding="utf-8")
    sim = start(V20, "--profile", "sinamics-v20", "--latency-time", "60")
    try:
        for name, value in [("P0010", "1"), ("P0305.0", "3.2"), ("P0307.0", "1.5")]:
            assert uss(["write", "5", name, value, *v20_opts(sim)])[0] == 0
        for name, value in [("P0010", "0"), ("P1120.0", "2"), ("P1121.0", "2")]:
            assert uss(["write", "5", name, value, *v20_opts(sim)])[0] == 0
        process = subprocess.Popen(
            [*USS, "restore", "5", str(file), "--yes", *timeout, *v20_opts(sim)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        assert process.stdout is not None
        planned = [process.stdout.readline() for _ in range(6)]  # printed before the writes
        if not planned[-1].startswith("P1121.0 (Ramp-down time)"):
            raise AssertionError([*planned, *process.communicate(timeout=30)])
        cut(sim, process)
        _, err = process.communicate(timeout=30)
    except BaseException:
        stop(sim)
        raise
    return process.returncode, err.splitlines(), sim


def says_what_was_written(lines: list[str]) -> None:
    """The lines name how many were written, the write under way, and how to go on."""
    done = next(line for line in lines if " of 6 written" in line)
    assert int(done.split()[2]) < 6
    assert (
        lines[-1]
        == "uss restore: the same uss restore again writes the rest (only what still differs)"
    )
    assert any(line.endswith("under way, the drive may or may not have taken it") for line in lines)


@pytest.mark.posix("interrupts uss restore with SIGINT")
def test_a_restore_interrupted_says_what_it_wrote_and_goes_on_when_run_again(
    tmp_path: Path,
) -> None:
    def interrupt(sim: Simulator, process: subprocess.Popen[str]) -> None:
        time.sleep(0.15)  # a write or two made, at 60 ms an answer
        process.send_signal(signal.SIGINT)

    code, lines, sim = restore_cut_short(tmp_path, interrupt, "--timeout", "30")
    try:
        assert code == 130
        assert lines[0] == "uss restore: interrupted: drive 5 not fully restored"
        says_what_was_written(lines)
        file = str(tmp_path / "factory.json")
        assert uss(["restore", "5", file, "--yes", *v20_opts(sim)])[0] == 0
        if any("in quick commissioning" in line for line in lines):
            assert uss(["write", "5", "P0010", "0", *v20_opts(sim)])[0] == 0
        assert uss(["diff", "5", file, *v20_opts(sim)])[0] == 0
        assert uss(["read", "5", "P0010", *v20_opts(sim)])[1].startswith("P0010 = 0 [ready]")
    finally:
        stop(sim)


@pytest.mark.posix("silences the simulator with SIGSTOP and SIGCONT")
def test_a_drive_gone_mid_restore_is_told_with_what_was_written(tmp_path: Path) -> None:
    def silence(sim: Simulator, process: subprocess.Popen[str]) -> None:
        sim.process.send_signal(signal.SIGSTOP)
        process.wait(30)
        sim.process.send_signal(signal.SIGCONT)

    code, lines, sim = restore_cut_short(tmp_path, silence, "--timeout", "1")
    try:
        assert code == 1
        assert lines[0].startswith("uss restore: slave 5 does not answer")
        assert lines[0].endswith(": drive 5 not fully restored")
        says_what_was_written(lines)
        assert any(line.startswith("uss restore: not written: ") for line in lines)
    finally:
        stop(sim)


def test_a_parameter_the_drive_cannot_have_is_refused_naming_the_file(
    mm4: Simulator, tmp_path: Path
) -> None:
    file = tmp_path / "set.json"
    assert uss(["backup", "3", "-o", str(file), *opts(mm4)])[0] == 0
    data = json.loads(file.read_text(encoding="utf-8"))
    element = {**next(p for p in data["parameter"] if p["pnu"] == 2010), "index": 5, "value": 7}
    element["label"], element["raw"] = "P2010.5", "0007"
    data["parameter"].append(element)
    data["count"] += 1
    file.write_text(json.dumps(data), encoding="utf-8")
    said = f"{file}: P2010 (USS baudrate) has 2 element(s): index 0..1, not 5\n"
    assert uss(["restore", "3", str(file), "--yes", *opts(mm4)]) == (2, f"uss restore: {said}")
    assert uss(["diff", "3", str(file), *opts(mm4)]) == (2, f"uss diff: {said}")


@pytest.mark.posix("os.mkfifo")
def test_a_cache_file_that_cannot_be_kept_is_refused_before_the_write(
    mm4: Simulator, tmp_path: Path
) -> None:
    """A ``--params-cache`` in a folder that is not there, or a pipe (whose reading would wait
    for a writer forever), is bad input before anything is written, not after the write."""
    pipe = tmp_path / "pipe.json"
    os.mkfifo(pipe)
    for cache, message in [
        (
            tmp_path / "gone" / "cache.json",
            f"cannot write the description cache to {tmp_path / 'gone' / 'cache.json'}: "
            f"folder {tmp_path / 'gone'} does not exist",
        ),
        (pipe, f"{pipe} is no regular file (a device, a pipe or a socket): give a file"),
    ]:
        code, out = uss(["write", "3", "1120", "3", *opts(mm4), "--params-cache", str(cache)])
        assert (code, out) == (2, f"uss write: {message}\n")
        assert uss(["read", "3", "1120", *opts(mm4)])[1] == "P1120 = 10.00 s (Ramp-up time)\n"


def test_a_scan_beyond_the_drives_numbers_is_refused_before_it_starts(
    mm4: Simulator, tmp_path: Path
) -> None:
    said = "--scan '31995-32005': the parameter numbers of profile micromaster4 are 0..31999\n"
    code, out = uss(["params", "3", "--scan", "31995-32005", *opts(mm4)])
    assert (code, out) == (2, f"uss params: {said}")
    file = tmp_path / "set.toml"
    code, out = uss(["backup", "3", "-o", str(file), "--scan", "31995-32005", *opts(mm4)])
    assert (code, out) == (2, f"uss backup: {said}") and not file.exists()


def test_a_parameter_read_on_neither_side_is_not_compared(tmp_path: Path) -> None:
    # P4 and the other 32-bit and text parameters do not fit PKW 3: neither the backup nor
    # the drive now gives their values, so nothing says they agree
    options = ("--profile", "generic", "--address", "5", "--layout", "3,2", "--baud", "38400")
    with simulator(*options) as url:
        port = ["--port", url, "--baud", "38400", "--layout", "3,2", "--profile", "generic"]
        backup = str(tmp_path / "b.json")
        assert uss(["backup", "5", "-o", backup, *port])[0] == 1  # 5 not read
        code, out = uss(["diff", "5", backup, *port])
        assert code == 1, out
        lines = out.splitlines()
        assert lines[0] == f"left: drive 5 (live) -> right: file ({backup})"
        assert lines[1].startswith("not compared, read on neither side: P4 (")
        assert "P90 (" in lines[1] and "P107 (" in lines[1]
        assert lines[-2] == f"drive 5 and {backup} agree in the parameters both hold"
        assert lines[-1] == f"uss restore 5 {backup} (file -> drive 5) would write nothing"
        code, out = uss(["diff", backup, backup])
        assert code == 0 and out.splitlines()[1].startswith("not compared, read on neither side")
        code, out = uss(["diff", "5", backup, *port, "--json"])
        data = json.loads(out)
        assert data["differences"] == []
        assert [e["pnu"] for e in data["not_compared"]] == [4, 90, 91, 107, 825]


def test_an_identity_read_on_one_side_only_is_no_other_drive(
    mm4: Simulator, tmp_path: Path
) -> None:
    # the backup could not read the drive's product type: nothing says it is another drive's
    # file, and nothing says it is this one's - refused without --force, in those words
    file = tmp_path / "set.json"
    assert uss(["backup", "3", "-o", str(file), *opts(mm4)])[0] == 0
    data = json.loads(file.read_text(encoding="utf-8"))
    error = {"type": "JobTimeout", "message": "slave 3 does not answer"}
    data["identity"] = [{"pnu": 2010, "name": "USS baudrate", "error": error}]
    unread = tmp_path / "unread.json"
    unread.write_text(json.dumps(data), encoding="utf-8")
    code, out = uss(["restore", "3", str(unread), "--yes", *opts(mm4)])
    assert code == 2, out
    assert "another drive" not in out
    assert f"cannot tell whether {unread} is this drive's: P2010 (USS baudrate)" in out
    assert "not read there" in out and "--force" in out
    assert uss(["restore", "3", str(unread), "--yes", "--force", *opts(mm4)])[0] == 0
