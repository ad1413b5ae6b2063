"""Fixtures of the gateway tests (see harness.py)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from gateway.contract import Recorder
from gateway.harness import Broker


@pytest.fixture
def broker(tmp_path: Path) -> Iterator[Broker]:
    """A real mosquitto on a free loopback port, stopped after the test. Every message the
    gateway publishes on it during the test is checked against the MQTT contract's schema of
    its topic (tests/gateway/contract.py): a payload that breaks it fails the test."""
    server = Broker(tmp_path)
    server.start()
    recorder = Recorder(server.port)
    try:
        recorder.start()
        yield server
    finally:
        recorder.stop()
        server.stop()
    found = recorder.problems()
    assert not found, "payloads that break the MQTT contract:\n" + "\n".join(found[:20])
