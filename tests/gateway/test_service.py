"""docs/service.md: the systemd unit it gives is one systemd takes as written (checked with
``systemd-analyze verify`` where systemd's tools are installed), and starts what the page says
it starts."""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from support.paths import ROOT

PAGE = ROOT / "docs" / "service.md"
INSTALLED = "/opt/pyuss/bin/uss"


def unit_text() -> str:
    text = PAGE.read_text(encoding="utf-8")
    match = re.search(
        r"<!-- run by tests/gateway/test_service.py -->\n```text\n(.*?)^```", text, re.S | re.M
    )
    assert match is not None, "docs/service.md has no unit block run by this test"
    return match.group(1)


def test_the_unit_starts_the_gateway_with_its_configuration_and_restarts_on_failure() -> None:
    unit = unit_text()
    (command,) = re.findall(r"^ExecStart=(.*)$", unit, re.M)
    assert shlex.split(command) == [INSTALLED, "gateway", "--config", "/etc/pyuss/uss.toml"]
    assert "\nRestart=on-failure\n" in unit and "\nKillSignal=SIGTERM\n" in unit


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="needs systemd-analyze")
def test_systemd_takes_the_unit_as_written(tmp_path: Path) -> None:
    # The installed path is this environment's uss: systemd checks the program exists.
    uss = str(Path(sys.executable).with_name("uss"))
    unit = tmp_path / "pyuss-gateway.service"
    unit.write_text(unit_text().replace(INSTALLED, uss), encoding="utf-8")
    done = subprocess.run(
        ["systemd-analyze", "verify", "--man=no", str(unit)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    complaints = [
        line
        for line in (done.stdout + done.stderr).splitlines()
        if str(unit) in line or "pyuss-gateway" in line
    ]
    assert done.returncode == 0 and not complaints, done.stdout + done.stderr
