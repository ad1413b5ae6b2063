"""A plant on one page (``uss web --mqtt``): three ``uss gateway`` processes, each over its own
``uss simulate --bus-tcp`` process, publishing on one real mosquitto, and one page that sees,
trends and commands the drives of all of them through the gateways' topics. One set-up for
the module: the API tests first, then the walk in a headless Chromium, which stops a gateway
and brings it back read-only."""

from __future__ import annotations

import asyncio
import json
import os
import re
import shlex
import signal
import subprocess
import threading
import time
import urllib.request
from collections.abc import Iterator
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import paho.mqtt.client as paho
import pytest

from gateway.contract import check, problems
from gateway.harness import Broker
from pyuss.errors import ConfigError
from pyuss.gateway.config import mqtt_options
from pyuss.plant.remote import RemotePlant
from pyuss.points.config import Where
from support.network import free_port
from support.paths import ROOT
from support.plant import KEEPALIVE, Line, Page
from support.processes import USS, first_line, stop_uss
from support.waiting import eventually_sync
from support.web import open_page, screenshot

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


class Plant:
    def __init__(self, broker: Broker, lines: dict[str, Line], page: Page) -> None:
        self.broker = broker
        self.lines = lines
        self.page = page


class Watcher:
    """A client that keeps every message on ``topics`` (with its retain flag)."""

    def __init__(self, port: int, *topics: str) -> None:
        self.messages: list[tuple[str, bytes, bool]] = []
        self.ready = threading.Event()
        client = paho.Client(paho.CallbackAPIVersion.VERSION2)
        client.on_connect = lambda c, *_: [c.subscribe(t, qos=1) for t in topics]
        client.on_subscribe = lambda *_: self.ready.set()
        client.on_message = lambda _c, _d, m: self.messages.append(
            (m.topic, bytes(m.payload), bool(m.retain))
        )
        self.client = client
        client.connect("127.0.0.1", port)
        client.loop_start()
        assert self.ready.wait(10)

    def stop(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()

    def payloads(self, part: str) -> list[dict[str, Any]]:
        return [json.loads(p) for t, p, _ in self.messages if part in t]


@pytest.fixture(scope="module")
def plant(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Plant]:
    folder = tmp_path_factory.mktemp("plant")
    broker = Broker(folder)
    broker.start()
    # every message on the broker - the gateways' and the pages' - against the contract
    recorder = Watcher(broker.port, "uss/#")
    lines: dict[str, Line] = {}
    page: Page | None = None
    try:
        for name in ("line1", "line2", "line3"):
            lines[name] = Line(name, broker.url, folder)
        for line in lines.values():
            line.start_gateway()
        page = Page(broker.url)
        yield Plant(broker, lines, page)
    finally:
        if page is not None:
            page.stop()
        for line in lines.values():
            line.stop()
        recorder.stop()
        broker.stop()
    sent = [(topic, payload) for topic, payload, _ in recorder.messages if payload]
    assert any("/cmd/" in topic for topic, _ in sent)
    found = [problem for topic, payload in sent for problem in check(topic, payload)]
    assert not found, "messages that break the MQTT contract:\n" + "\n".join(found[:20])


def bus(plant: Plant) -> dict[str, Any]:
    status, data = plant.page.api("/api/bus")
    assert status == 200
    return dict(data)


def drive(plant: Plant, key: str) -> dict[str, Any]:
    return next(d for d in bus(plant)["drives"] if d["address"] == key)


def command(plant: Plant, key: str, name: str, value: object = None) -> tuple[int, Any]:
    """A command as the page sends it: checked, then confirmed with the check's token."""
    body: dict[str, Any] = {"name": name} if value is None else {"name": name, "value": value}
    status, checked = plant.page.api(f"/api/drive/{key}/command", {**body, "check": True})
    if status != 200:
        return status, checked
    result: tuple[int, Any] = plant.page.api(
        f"/api/drive/{key}/command", {**body, "confirm": checked["confirm"]}
    )
    return result


def test_the_page_lists_every_gateway_and_drive_with_availability(plant: Plant) -> None:
    eventually_sync(
        lambda: sum(d["online"] for d in bus(plant)["drives"]) == 6,
        "the six drives of three gateways online",
    )
    shown = bus(plant)
    assert shown["plant"] is True
    gateways = {g["bus"]: g for g in shown["gateways"]}
    assert sorted(gateways) == ["line1", "line2", "line3"]
    for name, gateway in gateways.items():
        assert gateway["online"] and not gateway["read_only"]
        assert gateway["keepalive"] == KEEPALIVE
        assert gateway["drives"] == [f"{name}.5", f"{name}.6"]
    drives = {d["address"]: d for d in shown["drives"]}
    assert drives["line2.6"]["name"] == "drive6" and drives["line2.6"]["bus"] == "line2"
    assert drives["line2.6"]["state"] == "switch-on inhibited"
    # its words as uss read and uss status spell them (pyuss.params.words)
    word = drives["line2.6"]["status"]
    assert drives["line2.6"]["status_text"].startswith(f"{word:04X}h  switch-on inhibited")
    assert re.fullmatch(r"[0-9A-F]{4}h  .+", drives["line2.6"]["control_text"])
    # what the gateways' states do not carry is shown as not known, never as 0
    assert drives["line2.6"]["health"]["response_ms"] is None
    status, info = plant.page.api("/api/drive/line1.5")
    assert status == 200
    assert info["reference"] == {"value": 50.0, "unit": "Hz"}
    assert info["actuals"] == [{"pzd": 2, "name": "Main actual value", "unit": "Hz"}]
    # the local page's URLs name a drive by a number; here no drive is one
    assert plant.page.api("/api/drive/5")[0] == 400
    # the scan and the telegram monitor need the line itself
    status, refused = plant.page.api("/api/scan", {"addresses": "1-3"})
    assert status == 400 and "not available over the broker" in refused["error"]


def test_a_command_refused_by_the_page_sends_nothing(plant: Plant) -> None:
    watcher = Watcher(plant.broker.port, "uss/+/+/cmd/#")
    try:
        status, refused = command(plant, "line1.6", "setpoint", {"value": 500, "unit": "Hz"})
        assert status == 400
        assert refused["error"] == (
            "setpoint 500 Hz not sent: it is beyond what the drive's setpoint word can carry. "
            "Enter a value within -200 % .. 199.99 % (-100 .. 99.99 Hz) of the reference "
            "(USS specification C 5.2.2)."
        )
        status, refused = command(plant, "line1.6", "setpoint", {"value": 5, "unit": "rpm"})
        assert status == 400 and "takes '%' or 'Hz'" in refused["error"]
        status, refused = command(plant, "line1.6", "jog1")
        assert status == 400 and "jog1 is not a command of the gateway" in refused["error"]
        # a confirmation is good for the command checked only
        status, checked = plant.page.api(
            "/api/drive/line1.6/command", {"name": "on", "check": True}
        )
        assert status == 200 and checked["text"] == "on"
        status, refused = plant.page.api(
            "/api/drive/line1.6/command",
            {"name": "setpoint", "value": 10, "confirm": checked["confirm"]},
        )
        assert status == 409
        # a read goes out: the one command the gateways saw
        status, read = plant.page.api("/api/drive/line1.6/params/read", {"ids": ["107"]})
        assert status == 200 and read == [{"id": "107", "value": "50.00 Hz", "input": "50.00"}]
        eventually_sync(lambda: watcher.messages, "the read on the broker")
    finally:
        watcher.stop()
    assert [topic for topic, _, _ in watcher.messages] == ["uss/line1/drive6/cmd/read"]
    topic, payload, retained = watcher.messages[0]
    assert not retained and check(topic, payload) == []
    sent = json.loads(payload)
    assert sent["reply_to"] == f"uss/line1/drive6/reply/{plant.page.plant.client_id}"


def test_commands_reach_the_drive_once_and_the_latency_is_shown(plant: Plant) -> None:
    second = Page(plant.broker.url)  # another engineer's page on the same broker
    watcher = Watcher(plant.broker.port, "uss/line1/drive5/cmd/#", "uss/line1/drive5/reply/#")
    try:
        eventually_sync(lambda: "line1.5" in second.plant.drives, "the second page knows line1.5")
        status, done = command(plant, "line1.5", "setpoint", {"value": 20, "unit": "Hz"})
        assert status == 200 and done["text"].startswith("Setpoint 20 Hz (40 % of the reference)")
        assert done["setpoint"]["value"] == 20.0
        eventually_sync(lambda: second.plant.live(second.plant.drives["line1.5"]), "line1.5 live")
        body = {"name": "off1", "check": True}
        status, checked = second.api("/api/drive/line1.5/command", body)
        assert status == 200
        status, off = second.api(
            "/api/drive/line1.5/command", {"name": "off1", "confirm": checked["confirm"]}
        )
        assert status == 200 and off["taken"], off
    finally:
        watcher.stop()
        second.stop()
    commands = [(t, json.loads(p)) for t, p, _ in watcher.messages if "/cmd/" in t]
    replies = [json.loads(p) for t, p, _ in watcher.messages if "/reply/" in t]
    assert [t.rsplit("/", 1)[1] for t, _ in commands] == ["setpoint_percent", "off1"]
    ids = [c["id"] for _, c in commands]
    assert len(set(ids)) == 2 and sorted(r["id"] for r in replies) == sorted(ids)
    assert all(problems("reply", r) == [] for r in replies)
    # the setpoint as checked: the word 199Ah (6554) of 20 Hz, 40 % of the reference
    assert commands[0][1]["value"] == round(6554 * 100 / 0x4000, 6)
    latency = {g["bus"]: g["latency"] for g in bus(plant)["gateways"]}["line1"]
    assert latency["command"]["count"] >= 1 and latency["command"]["median_ms"] is not None
    assert latency["value"]["count"] >= 1 and latency["value"]["last_ms"] is not None


def test_parameters_backup_compare_and_restore_go_through_the_gateway(plant: Plant) -> None:
    page = plant.page
    status, text = page.api("/api/drive/line2.6/backup?format=toml")
    assert status == 200 and isinstance(text, str)
    assert 'value = 50.0\nraw = "4248 0000"' in text  # P107 as uss backup writes it
    assert 'value = 16384\nraw = "4000"' in text  # a display beyond its own limits too
    status, wrote = page.api("/api/drive/line2.6/params/write", {"id": "107", "value": "60 Hz"})
    assert status == 200 and wrote["value"] == "60.00 Hz"
    # checked by the page before anything is sent: limits, read-only
    status, refused = page.api("/api/drive/line2.6/params/write", {"id": "107", "value": "900"})
    assert status == 400 and "600" in refused["error"]
    status, refused = page.api("/api/drive/line2.6/params/write", {"id": "52", "value": "1"})
    assert status == 400 and "read-only" in refused["error"]
    status, compared = page.api("/api/drive/line2.6/compare?name=b.toml", raw=text.encode())
    assert status == 200
    assert [d["id"] for d in compared["differences"]] == ["107"]
    assert compared["stranger"] is None and compared["refused"] is None
    status, restored = page.api("/api/drive/line2.6/restore?name=b.toml", raw=text.encode())
    assert status == 200 and restored["message"] == "drive line2.6: 1 of 1 written"
    status, read = page.api("/api/drive/line2.6/params/read", {"ids": ["107"]})
    assert read[0]["value"] == "50.00 Hz"


def test_messages_beyond_bounds_or_of_another_version_are_dropped() -> None:
    page = RemotePlant(mqtt_options({"broker": "mqtt://127.0.0.1:1"}, Where("web")))
    good = {
        "v": 1, "bus": "b", "version": "1", "read_only": False, "keepalive": 5,
        "drives": [{"name": "d", "address": 5, "profile": "generic", "layout": "4,2",
                    "unit": "%", "setpoints": [], "actual": []}],
        "time": None,
    }  # fmt: skip
    for bad, words in (
        ({**good, "v": 2}, "contract version 2: this page reads 1"),
        ({**good, "bus": "c"}, "names bus 'c'"),
        ({**good, "drives": [{**good["drives"][0], "address": 40}]}, "drives[0].address"),
    ):
        with pytest.raises(ConfigError, match=re.escape(words)):
            page.receive("uss/b/gateway", json.dumps(bad).encode())
    with pytest.raises(ConfigError, match="nested deeper than 8 levels"):
        page.receive("uss/b/gateway", b"[" * 5000 + b"]" * 5000)
    with pytest.raises(ConfigError, match="at most 262144 are read"):
        page.receive("uss/b/gateway", b" " * 300_000)
    assert page.drives == {}
    page.receive("uss/b/gateway", json.dumps(good).encode())
    assert list(page.drives) == ["b.5"]
    page.receive("uss/b/gateway", b"")  # its retained message cleared: gone for good
    assert page.drives == {} and page.buses == {}


def ghost_online(client: paho.Client, gateway: dict[str, Any]) -> None:
    """Publish, retained, ``gateway`` and that it and its drive d5 are online."""
    bus = gateway["bus"]
    client.publish(f"uss/{bus}/gateway", json.dumps(gateway), qos=1, retain=True)
    client.publish(f"uss/{bus}/availability", "online", qos=1, retain=True)
    client.publish(f"uss/{bus}/d5/availability", "online", qos=1, retain=True)


def ghost_gateway(bus: str) -> dict[str, Any]:
    """The gateway message of a bus with drive d5 (5) and no gateway behind it."""
    return {
        "v": 1, "bus": bus, "version": "1", "read_only": False, "keepalive": 5,
        "drives": [{"name": "d5", "address": 5, "profile": "generic", "layout": "4,2",
                    "unit": "%", "setpoints": [{"key": "main", "pzd": 2, "dword": False}],
                    "actual": [{"key": "main", "pzd": 2, "dword": False}]}],
        "time": "2026-11-27T00:00:00.000Z",
    }  # fmt: skip


def test_replies_that_answer_no_request_are_dropped(plant: Plant) -> None:
    # A bus with no gateway behind it: this test answers in its place.
    gateway = ghost_gateway("ghost")
    assert problems("gateway", gateway) == []
    ghost = Watcher(plant.broker.port, "uss/ghost/d5/cmd/#")
    page = plant.page
    try:
        ghost_online(ghost.client, gateway)
        eventually_sync(
            lambda: "ghost.5" in page.plant.drives and page.plant.buses["ghost"].online, "ghost"
        )
        eventually_sync(lambda: page.plant.drives["ghost.5"].available, "ghost.5 available")
        page.plant.timeout = 3.0
        asked = ask(page)
        eventually_sync(lambda: ghost.messages, "the command on the broker")
        topic, payload, _ = ghost.messages[0]
        sent = json.loads(payload)
        result = {"pnu": 107, "index": None, "name": "Mot.rated freq.", "value": 1.0, "unit": "Hz",
                  "time": "2026-11-27T00:00:00.000Z"}  # fmt: skip
        reply = {"v": 1, "command": "read", "drive": "d5", "ok": True, "result": result}
        # retained on the page's reply topic, a wrong id, the right id for another drive:
        # none answers the request
        ghost.client.publish(sent["reply_to"], json.dumps({**reply, "id": sent["id"]}), 1, True)
        ghost.client.publish(sent["reply_to"], json.dumps({**reply, "id": "x-1"}), 1)
        other = {**reply, "id": sent["id"], "drive": "d6"}
        ghost.client.publish(sent["reply_to"], json.dumps(other), 1)
        with pytest.raises(Exception, match="gateway ghost did not answer within 3 s"):
            asked.result(30)
        ghost.client.publish(sent["reply_to"], b"", 1, True)  # the test's own, cleared
        # the page never retains: a page that starts again finds no command to replay
        restarted = Page(plant.broker.url)
        try:
            assert restarted.plant.client_id != page.plant.client_id
            retained = Watcher(plant.broker.port, "uss/#")
            time.sleep(0.5)  # let the retained messages arrive
            retained.stop()
            kept = [t for t, _, flag in retained.messages if flag]
            assert kept and not [t for t in kept if "/cmd/" in t or "/reply/" in t]
            assert ghost.messages == [ghost.messages[0]]  # nothing sent again
        finally:
            restarted.stop()
        # a reply to the request it waits for is taken
        asked = ask(page)
        eventually_sync(lambda: len(ghost.messages) == 2, "the second command")
        sent = json.loads(ghost.messages[1][1])
        ghost.client.publish(sent["reply_to"], json.dumps({**reply, "id": sent["id"]}), 1)
        assert asked.result(30) == result
    finally:
        page.plant.timeout = 10.0
        for topic in ("gateway", "availability", "d5/availability"):
            ghost.client.publish(f"uss/ghost/{topic}", b"", qos=1, retain=True)
        ghost.stop()


def test_a_command_whose_gateway_goes_offline_says_nothing_of_the_drive(plant: Plant) -> None:
    # The gateway answers a command and goes away before the drive's state shows it taken:
    # the last state it published is no news of the drive, and the page says so, not "done"
    # or "did not take it".
    gateway = ghost_gateway("ghost2")
    ghost = Watcher(plant.broker.port, "uss/ghost2/d5/cmd/#")
    page = plant.page
    try:
        ghost_online(ghost.client, gateway)
        eventually_sync(
            lambda: (
                "ghost2.5" in page.plant.drives and page.plant.live(page.plant.drives["ghost2.5"])
            ),
            "ghost2.5 live",
        )
        status, checked = page.api("/api/drive/ghost2.5/command", {"name": "off2", "check": True})
        assert status == 200, checked
        done: Future[Any] = Future()
        body = {"name": "off2", "confirm": checked["confirm"]}
        threading.Thread(
            target=lambda: done.set_result(page.api("/api/drive/ghost2.5/command", body))
        ).start()
        eventually_sync(lambda: ghost.messages, "the command on the broker")
        sent = json.loads(ghost.messages[0][1])
        result = {"status_word": 0x0231, "state": "switch-on inhibited", "control_word": 0x047C,
                  "setpoint": {}}  # fmt: skip
        reply = {"v": 1, "id": sent["id"], "command": "off2", "drive": "d5", "ok": True,
                 "result": result}  # fmt: skip
        ghost.client.publish(sent["reply_to"], json.dumps(reply), 1)
        time.sleep(0.3)  # the reply is in, the page waits for the drive's state to show it
        ghost.client.publish("uss/ghost2/availability", "offline", qos=1, retain=True)
        status, said = done.result(30)
    finally:
        for topic in ("gateway", "availability", "d5/availability"):
            ghost.client.publish(f"uss/ghost2/{topic}", b"", qos=1, retain=True)
        ghost.stop()
    assert status == 200
    assert said["taken"] is False and said["state"] == "not known", said
    assert said["text"] == (
        "off2: sent, but whether the drive took it is not known: gateway ghost2 offline."
    )


def ask(page: Page) -> Future[dict[str, Any]]:
    """A read request of the page to ghost.5, started now and awaited later."""
    plant = page.plant
    request = plant.request(plant.drives["ghost.5"], "read", {"pnu": 107})
    return asyncio.run_coroutine_threadsafe(request, page.loop)


def test_the_fault_panel_reads_the_history_through_the_gateway(plant: Plant) -> None:
    """A V20 behind a gateway (played by the test, answering each read): the drive view's
    fault panel reads r0947, r0949 and r2110 through ``cmd/read`` as the local page reads them
    on the line, with the family's texts; it never says the family keeps no history."""
    point = [{"key": "main", "pzd": 2, "dword": False}]
    gateway = {
        "v": 1, "bus": "ghostv20", "version": "1", "read_only": False, "keepalive": 5,
        "drives": [{"name": "v20", "address": 9, "profile": "sinamics-v20", "layout": "4,2",
                    "unit": "Hz", "setpoints": point, "actual": point}],
        "time": "2026-11-27T00:00:00.000Z",
    }  # fmt: skip
    values = {(947, 0): 3, (949, 0): 7, (2110, 0): 503}
    asked: list[tuple[int, int | None]] = []

    def answer(client: paho.Client, _data: object, message: paho.MQTTMessage) -> None:
        sent = json.loads(message.payload)
        key = (sent["pnu"], sent.get("index"))
        asked.append(key)
        result = {"pnu": key[0], "index": key[1], "name": "-", "value": values.get(key, 0),
                  "unit": "", "time": "2026-11-27T00:00:00.000Z"}  # fmt: skip
        reply = {"v": 1, "id": sent["id"], "command": "read", "drive": "v20", "ok": True,
                 "result": result}  # fmt: skip
        client.publish(sent["reply_to"], json.dumps(reply), qos=1)

    ghost = Watcher(plant.broker.port, "uss/ghostv20/v20/cmd/read")
    ghost.client.on_message = answer
    page = plant.page
    try:
        ghost.client.publish("uss/ghostv20/gateway", json.dumps(gateway), qos=1, retain=True)
        ghost.client.publish("uss/ghostv20/availability", "online", qos=1, retain=True)
        ghost.client.publish("uss/ghostv20/v20/availability", "online", qos=1, retain=True)
        eventually_sync(lambda: "ghostv20.9" in page.plant.drives, "ghostv20.9 on the page")
        eventually_sync(lambda: page.plant.drives["ghostv20.9"].available, "ghostv20.9 available")
        status, panel = page.api("/api/drive/ghostv20.9/faults")
        assert status == 200, panel
        assert panel["parameters"] == {"numbers": 947, "values": 949, "warnings": 2110}
        (fault,) = panel["history"]
        assert fault["number"] == 3 and fault["value"] == 7 and fault["text"]
        (warning,) = panel["warnings"]
        assert warning["number"] == 503 and warning["text"]
        assert {pnu for pnu, _ in asked} == {947, 949, 2110}
    finally:
        for topic in ("gateway", "availability", "v20/availability"):
            ghost.client.publish(f"uss/ghostv20/{topic}", b"", qos=1, retain=True)
        ghost.stop()


def test_the_page_walk_in_chromium(plant: Plant, browser: Any, tmp_path: Path) -> None:
    """The "plant on one page" walk: the page lists every drive of the three gateways,
    trends a ramp on line1, writes a parameter and restores a backup on line2, switches
    line3.5 on and off with confirmation; stopping line3's gateway shows its drives offline
    within its keep-alive; brought back read-only, its drives refuse commands."""
    page = open_page(browser, plant.page.url)
    try:
        page.wait_for_function("document.querySelectorAll('#bus-table tbody tr').length === 9")
        table = page.locator("#bus-table tbody").inner_text()
        for key in ("line1.5", "line1.6", "line2.5", "line2.6", "line3.5", "line3.6"):
            assert key in table
        assert page.locator("#gateway-table tbody tr").count() == 3
        assert not page.locator("#scan-form").is_visible()
        assert not page.locator("nav a[data-view=monitor]").is_visible()
        # line1.5: a ramp on the trend (setpoint 20 Hz was set by the API test)
        page.goto(plant.page.url + "#drive/line1.5")
        page.wait_for_function(
            "document.querySelector('#drive-title').textContent.includes('line1')"
        )
        page.fill("#setpoint-value", "40")
        page.select_option("#setpoint-unit", "Hz")
        page.click("#setpoint-form button[type=submit]")
        page.locator("#confirm").wait_for()
        assert (
            "set the setpoint to 40 Hz (80 % of the reference)?"
            in page.locator("#confirm-text").inner_text()
        )
        page.click("#confirm-yes")
        page.wait_for_function(
            "document.querySelector('#drive-message').textContent.includes('in force')"
        )
        page.click("[data-cmd=on]")
        page.click("#confirm-yes")
        page.wait_for_function(
            "document.querySelector('#drive-state').textContent === 'operation enabled'"
        )
        page.wait_for_function(
            "(() => { const c = document.querySelector('#drive-actuals td[data-pzd]').textContent;"
            " return parseFloat(c) > 30; })()"
        )
        ramp = page.evaluate("window.pyuss.views.drive.data[1].filter((v) => v != null)")
        rising = [round(v, 1) for v in ramp if v is not None]
        assert len(set(rising)) > 5 and max(rising) > 25 and min(rising) < 5
        page.wait_for_timeout(1500)  # let the ramp draw a visible line for the picture
        screenshot(page, "web-plant-drive", full_page=True)
        # the bus view: the gateways with their latency, the drives grouped by gateway
        page.goto(plant.page.url + "#bus")
        page.wait_for_function(
            "document.querySelector('#gateway-table tr[data-bus=line1] .latency-command')"
            ".textContent !== '-'"
        )
        screenshot(page, "web-plant", full_page=True)
        status, done = command(plant, "line1.5", "off1")
        assert status == 200 and done["taken"]
        # line2.5: a parameter written, a backup taken and restored
        page.goto(plant.page.url + "#params/line2.5")
        page.wait_for_function(
            "document.querySelector('#param-message').textContent.includes('values read')",
            timeout=90_000,
        )
        with page.expect_download() as info:
            page.click("#param-backup")
        path = tmp_path / info.value.suggested_filename
        info.value.save_as(path)
        assert info.value.suggested_filename.startswith("line2-drive5-generic-")
        page.fill("#param-search", "107")
        page.locator("#param-table tbody tr[data-id='107'] td.value").click()
        page.fill("#edit-value", "75")
        page.click("#edit-write")
        page.wait_for_function(
            "!document.querySelector('#edit').open"
            " || !document.querySelector('#edit-error').textContent.startsWith('Writing')"
        )
        assert page.locator("#edit-error").inner_text() in ("", "Writing …")
        page.wait_for_function("!document.querySelector('#edit').open")
        status, read = plant.page.api("/api/drive/line2.5/params/read", {"ids": ["107"]})
        assert read[0]["value"] == "75.00 Hz"
        page.set_input_files("#param-file", str(path))
        page.locator("#param-diff table.diff").wait_for()
        page.click("#restore-start")
        page.click("#confirm-yes")
        page.locator("#restore-summary").wait_for()
        assert page.locator("#restore-summary").inner_text() == "drive line2.5: 1 of 1 written"
        status, read = plant.page.api("/api/drive/line2.5/params/read", {"ids": ["107"]})
        assert read[0]["value"] == "50.00 Hz"
        # line3.5: on and off, with confirmation
        page.goto(plant.page.url + "#drive/line3.5")
        page.wait_for_function(
            "document.querySelector('#drive-title').textContent.includes('line3')"
        )
        page.click("[data-cmd=on]")
        page.locator("#confirm").wait_for()
        assert "Drive line3.5" in page.locator("#confirm-text").inner_text()
        page.click("#confirm-yes")
        page.wait_for_function(
            "document.querySelector('#drive-state').textContent === 'operation enabled'"
        )
        page.click("[data-cmd=off1]")
        page.wait_for_function(
            "document.querySelector('#drive-state').textContent !== 'operation enabled'"
        )
        # line3's gateway goes away without a word: its last will, within its keep-alive
        plant.lines["line3"].kill_gateway()
        page.wait_for_function(
            "document.querySelector('#drive-state').textContent === 'gateway line3 offline'",
            timeout=(KEEPALIVE * 1.5 + 15) * 1000,  # a bound on a loaded machine
        )
        assert page.locator("#drive-status").inner_text() == "----"
        assert page.locator("[data-cmd=on]").is_disabled()
        status, refused = command(plant, "line3.5", "on")
        assert status == 502
        assert refused["error"] == "gateway line3 is offline: nothing sent to drive line3.5"
        page.goto(plant.page.url + "#bus")
        page.wait_for_function(
            "document.querySelector('#gateway-table tr[data-bus=line3]').textContent"
            ".includes('offline')"
        )
        row = page.locator("#bus-table tbody tr[data-address='line3.6']").inner_text()
        assert "gateway line3 offline" in row and "Hz" not in row
        # back, read-only: the page is read-only for its drives and says so
        plant.lines["line3"].start_gateway(read_only=True)
        page.goto(plant.page.url + "#drive/line3.5")
        page.wait_for_function("!document.querySelector('#ro-badge').hidden", timeout=30_000)
        assert (
            page.locator("#ro-badge").inner_text() == "read-only: gateway line3 takes no commands"
        )
        page.wait_for_function(
            "document.querySelector('#drive-state').textContent === 'ready to switch on'"
        )
        assert not page.locator("[data-cmd=on]").is_visible()
        status, refused = command(plant, "line3.5", "on")
        assert status == 502
        assert refused["error"] == ("gateway line3 is read-only (its MQTT face takes reads only)")
        screenshot(page, "web-plant-read-only", full_page=False)
    finally:
        page.context.close()


def doc_blocks() -> list[tuple[str, str]]:
    """The blocks of docs/web.md that this module runs: (language, text)."""
    text = (ROOT / "docs" / "web.md").read_text(encoding="utf-8")
    mark = "<!-- run by tests/web/test_plant.py -->\n```"
    found = re.findall(re.escape(mark) + r"(\w+)\n(.*?)^```", text, re.MULTILINE | re.DOTALL)
    return [(language, body) for language, body in found]


def test_the_worked_example_of_the_doc_runs(tmp_path: Path) -> None:
    """The set-up of docs/web.md "A plant on one page" as written (its ports free ones): the
    gateway's file, the page's [web] table, the processes; the page shows the drives."""
    (gateway_file, web_table, commands) = doc_blocks()
    assert gateway_file[0] == web_table[0] == "toml" and commands[0] == "sh"
    broker = Broker(tmp_path)
    broker.start()
    bus_port = free_port()

    def ports(text: str) -> str:
        return text.replace("127.0.0.1:1883", f"127.0.0.1:{broker.port}").replace(
            "127.0.0.1:7601", f"127.0.0.1:{bus_port}"
        )

    (tmp_path / "line1.toml").write_text(ports(gateway_file[1]), encoding="utf-8")
    (tmp_path / "uss.toml").write_text(ports(web_table[1]), encoding="utf-8")
    lines = commands[1].strip().splitlines()
    assert lines[0] == "mosquitto -p 1883"  # the broker: this test's own, on a free port
    started: list[subprocess.Popen[str]] = []
    environment = {k: v for k, v in os.environ.items() if k != "USS_CONFIG"}
    try:
        for line, ready in zip(lines[1:], ("bus://", "ready", "http://"), strict=True):
            args = shlex.split(ports(line))
            assert args[0] == "uss"
            if args[1] == "web":
                args += ["--listen", "127.0.0.1:0"]  # not the 8420 of other tests
            process = subprocess.Popen(
                [*USS, *args[1:]], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                text=True, cwd=tmp_path, env={**environment, "PYTHONUNBUFFERED": "1"},
            )  # fmt: skip
            started.append(process)
            url = first_line(process, ready)
        address = url.strip()

        def drives() -> list[str]:
            with urllib.request.urlopen(address + "api/bus", timeout=30) as reply:
                shown = json.loads(reply.read())
            return [d["address"] for d in shown["drives"] if d["online"]]

        eventually_sync(
            lambda: drives() == ["line1.5", "line1.6"], "the example's drives on the page"
        )
    finally:
        for process in reversed(started):
            stop_uss(process, signal.SIGINT)
        broker.stop()


def test_a_page_that_lost_its_broker_says_so_not_that_the_drives_are_silent(
    tmp_path: Path,
) -> None:
    # the page knows nothing of the gateways and drives while it is not connected: it must
    # neither show a gateway "online" nor say that a drive "does not send" (A 5.2.1.1), which
    # is a diagnosis of the drive; it says that its broker is not connected
    broker = Broker(tmp_path)
    broker.start()
    line = Line("line1", broker.url, tmp_path)
    page: Page | None = None
    try:
        line.start_gateway()
        page = Page(broker.url)
        shown = page

        def view() -> dict[str, Any]:
            status, data = shown.api("/api/bus")
            assert status == 200
            return dict(data)

        eventually_sync(lambda: [d["online"] for d in view()["drives"]] == [True, True], "live")
        broker.stop()
        eventually_sync(lambda: not view()["connected"], "the page's broker lost")
        shown_now = view()
        assert [g["online"] for g in shown_now["gateways"]] == [False]
        for item in shown_now["drives"]:
            assert item["offline"] == f"the MQTT broker {broker.url} is not connected", item
            assert item["state"] == item["offline"] and item["status"] is None
    finally:
        if page is not None:
            page.stop()
        line.stop()
        broker.stop()
