"""Log output of the command: a failed one-shot command reads as one line; -v brings the
log lines back."""

from __future__ import annotations

import asyncio
import sys

from pyuss.transport.tcp import TcpServerTransport


async def _read_from_silent_line(*extra: str) -> tuple[int | None, str]:
    port = TcpServerTransport("127.0.0.1", 0, baud=19200)
    await port.open()
    try:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "pyuss.cli.main", *extra, "read", "9", "52",
            "--port", f"tcp://127.0.0.1:{port.port}", "--baud", "19200", "--timeout", "0.5",
            stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
        )  # fmt: skip
        _, err = await asyncio.wait_for(proc.communicate(), 60)
        return proc.returncode, err.decode()
    finally:
        await port.close()


async def test_a_failed_read_is_one_line_on_stderr() -> None:
    code, err = await _read_from_silent_line()
    assert code == 1
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("P52: ") and "does not send" in err  # one line per parameter


async def test_verbose_shows_the_warnings() -> None:
    code, err = await _read_from_silent_line("-v")
    assert code == 1
    assert "slave 9 does not send" in err  # (INFO: one missed answer is no outage)
