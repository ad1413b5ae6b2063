"""``uss monitor`` reads the line configuration as the commands that talk to drives do
(docs/lines.md): bare in a folder with ``uss.toml`` it listens to the file's line at its baud
rate, with each drive's layout and profile; ``--config`` and ``--line`` name file and line;
options given win over the file."""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

import pytest

from monitor.traffic import Slave, answer, drive, request
from pyuss.bus import VirtualBus
from pyuss.cli.main import main
from pyuss.protocol import Layout, Pkw
from pyuss.protocol.telegram import Telegram
from support.userconfig import empty_place

BAUD = 19200
TIMEOUT = 30


@pytest.fixture(autouse=True)
def place(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty working directory, no USS_CONFIG, a configuration folder of the test's own."""
    return empty_place(tmp_path, monkeypatch)


def line_file(port: str, name: str = "line1") -> str:
    """A line as ``uss scan --save`` writes it, with a SINAMICS V20 at 5 and a drive of
    unknown kind at 6 (no profile named)."""
    return (
        f'[[bus]]\nname = "{name}"\nport = "{port}"\nbaud = {BAUD}\nlayout = "3,2"\n\n'
        '[[bus.drive]]\nname = "v20"\naddress = 5\nprofile = "sinamics-v20"\n\n'
        '[[bus.drive]]\nname = "other"\naddress = 6\n'
    )


def _reply(tg: Telegram) -> bytes | None:
    """Array reads answered with their IND kept (r2110 of a V20 is PNU 110 on IND page 1)."""
    job = Layout(3, 2).unpack(tg.data).pkw
    assert job is not None
    return answer(tg.address, Pkw(4, job.pnu, index=job.index, values=(7,)))


JOBS = [request(a, Pkw(6, 110, index=0x8001)) for a in (5, 6)]
SLAVES = [Slave(5, _reply, delay=0.004), Slave(6, _reply, delay=0.004)]


async def monitor(bus: VirtualBus, *argv: str) -> tuple[list[dict[str, object]], str]:
    """``uss monitor ARGV --json --count 2`` in a process of its own while the two jobs go
    over ``bus``: the exchanges and the line it says it listens on."""
    proc = await asyncio.create_subprocess_exec(
        *(sys.executable, "-m", "pyuss.cli.main", "monitor", *argv, "--json", "--count", "2"),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    assert proc.stderr is not None
    listening = (await asyncio.wait_for(proc.stderr.readline(), TIMEOUT)).decode()
    assert "listening on" in listening, listening
    await asyncio.sleep(0.2)
    await drive(bus, bus, JOBS, SLAVES)
    out, err = await asyncio.wait_for(proc.communicate(), TIMEOUT)
    assert proc.returncode == 0, err
    return [json.loads(line) for line in out.decode().splitlines()], listening


async def test_bare_in_a_folder_with_the_file_it_monitors_its_line(place: Path) -> None:
    bus = VirtualBus(BAUD)
    host, port = await bus.serve_tcp(framed=True)
    url = f"bus://{host}:{port}"
    try:
        (place / "uss.toml").write_text(line_file(url))
        items, listening = await monitor(bus)
        assert f"listening on {url}?listen_only=1 (2-wire, {BAUD} baud" in listening
        by_address = {i["address"]: i for i in items}
        assert [by_address[a]["layout_source"] for a in (5, 6)] == ["given", "given"]
        # each drive with its own profile: the V20's page resolved, the other's not
        assert "read r2110[1] -> r2110[1] = 7" in str(by_address[5]["summary"])
        assert "r2110" not in str(by_address[6]["summary"])
        assert "P110" in str(by_address[6]["summary"]), by_address[6]["summary"]
        # --profile wins for every drive; --config and --line name another file's line
        other = place / "elsewhere.toml"
        other.write_text(line_file(url, "line2"))
        (place / "uss.toml").write_text(line_file("/dev/nonexistent-port"))
        argv = ("--config", str(other), "--line", "line2", "--profile", "sinamics-v20")
        items, _ = await monitor(bus, *argv)
        assert all("read r2110[1] -> r2110[1] = 7" in str(i["summary"]) for i in items)
        # --port given wins over the file's; with --line the file gives the rest (the baud)
        items, listening = await monitor(bus, "--port", url, "--line", "line1")
        assert f"listening on {url}?listen_only=1 (2-wire, {BAUD} baud" in listening
        assert "read r2110[1]" in str({i["address"]: i for i in items}[5]["summary"])
    finally:
        await bus.close()


def test_the_files_line_and_options_given(place: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (place / "uss.toml").write_text(line_file("/dev/nonexistent-port"))
    assert main(["monitor", "--count", "1"]) == 1  # the file's port is the one opened
    assert "nonexistent-port" in capsys.readouterr().err
    assert main(["monitor", "--line", "nosuch"]) == 2
    assert "no line of that name (lines: line1)" in capsys.readouterr().err
    assert main(["monitor", "--baud", "1234"]) == 2  # given: wins over the file's
    assert "1234" in capsys.readouterr().err
    (place / "uss.toml").unlink()
    assert main(["monitor"]) == 2
    err = capsys.readouterr().err
    assert "nothing to listen to" in err and "configuration file (none found" in err
