"""The page in a real headless Chromium against the demo's simulated drives: every view loads,
the trend moves, commands switch the simulated drive (after asking), parameter edits reach it
and its refusals are shown in words, the monitor shows the telegrams. Each test saves a
screenshot of its view into build/screenshots/ (`make screenshots` puts them into docs/images/,
which docs/web.md shows)."""

from __future__ import annotations

import contextlib
import re
import time
from collections.abc import Iterator
from typing import Any

import pytest

from pyuss.drive.states import DriveState
from pyuss.monitor.capture import read_capture
from pyuss.profiles import profile_names
from support.web import Running, open_page, screenshot, serve

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.fixture
def page(browser: Any, demo: Running) -> Any:
    page = open_page(browser, demo.url)
    yield page
    page.context.close()


def drive_state(demo: Running, address: int) -> DriveState:
    return demo.run(lambda: demo.backend.engines[address].drive.state)


def test_the_bus_view_lists_the_drives_with_their_health(page: Any) -> None:
    rows = page.locator("#bus-table tbody tr")
    rows.first.wait_for()
    page.wait_for_function(
        "document.querySelectorAll('#bus-table tbody tr').length === 4 && "
        "Number(document.querySelector('#bus-table tbody tr td:nth-child(7)').textContent) > 0"
    )
    assert [rows.nth(i).get_attribute("data-address") for i in range(4)] == ["1", "4", "7", "9"]
    # (the drives start in a process of their own, and a loaded machine may miss an answer:
    # a row says "does not send" until the drive's next answer)
    page.wait_for_function(
        "[...document.querySelectorAll('#bus-table tbody tr')]"
        ".every(row => !row.textContent.includes('does not send')) && "
        "document.querySelector('#bus-table tbody tr').textContent.includes('switch-on inhibited')"
    )
    assert "0.00 Hz" in rows.nth(0).inner_text()  # the main actual value in its unit
    assert "0.00 %" in rows.nth(1).inner_text()  # no reference parameter: percent
    assert page.locator("#bus-baud").inner_text() == "38400 baud"
    # a scan looks for drives of unknown kind, or of any profile pyuss knows
    options = page.locator("#scan-profile option").all_inner_texts()
    assert options == ["unknown", *profile_names()]
    # chosen at first: the line's profile, "generic" for the demo's line of four families
    assert page.locator("#scan-profile").input_value() == "generic"
    screenshot(page, "web-bus", full_page=True)


def test_the_trend_moves_and_on_off_switch_the_drive_after_asking(page: Any, demo: Running) -> None:
    page.goto(demo.url + "#drive/1")
    page.wait_for_function("document.querySelector('#drive-state').textContent !== '-'")
    page.wait_for_function("document.querySelector('#drive-actuals td[data-pzd]')")
    # The page asks before ON; "Cancel" sends nothing.
    page.click("[data-cmd=on]")
    page.locator("#confirm").wait_for()
    assert "ON" in page.locator("#confirm-text").inner_text()
    page.click("#confirm-no")
    assert page.locator("#drive-message").inner_text() == "Not sent."
    assert demo.run(lambda: demo.backend.points(1).drive.control) == 0
    # A setpoint the drive's word cannot carry is refused before the page asks anything: the
    # question never promises what would be refused.
    page.fill("#setpoint-value", "500")
    page.click("#setpoint-form button[type=submit]")
    page.wait_for_function(
        "document.querySelector('#drive-message').textContent.includes('not sent')"
    )
    # The message says what went wrong and what to do; the section only follows.
    said = page.locator("#drive-message").inner_text()
    assert said.startswith("Setpoint: setpoint 500 % not sent: it is beyond what the drive")
    assert "Enter a value within -200 % .. 199.99 % (-100 .. 99.99 Hz)" in said
    assert said.endswith("(USS specification C 5.2.2).")
    assert not page.locator("#confirm").is_visible()
    assert demo.run(lambda: demo.backend.points(1).drive.setpoints) == (0,)
    # Setpoint 40 % and ON: the simulated drive runs and the trend follows its ramp. The page
    # asks with the setpoint as checked (what will be sent).
    page.fill("#setpoint-value", "40")
    page.click("#setpoint-form button[type=submit]")
    page.locator("#confirm").wait_for()
    assert "set the setpoint to 40 % (20 Hz)?" in page.locator("#confirm-text").inner_text()
    page.click("#confirm-yes")
    page.wait_for_function(
        "document.querySelector('#drive-message').textContent.includes('in force')"
    )
    assert page.locator("#setpoint-force").inner_text() == "40.00 % (20.00 Hz)"
    page.click("[data-cmd=on]")
    page.click("#confirm-yes")
    page.wait_for_function(
        "document.querySelector('#drive-state').textContent === 'operation enabled'"
    )
    assert drive_state(demo, 1) is DriveState.OPERATION
    assert page.locator("#drive-bits li.on", has_text="operation enabled").count() == 1
    before = page.evaluate("window.pyuss && document.querySelector('#trend canvas') !== null")
    assert before
    page.wait_for_function(
        "(() => { const c = document.querySelector('#drive-actuals td[data-pzd]').textContent;"
        " return parseFloat(c) > 5; })()"
    )
    page.wait_for_timeout(1500)  # let the ramp draw a visible line for the picture
    screenshot(page, "web-drive", full_page=True)
    # OFF1: the drive ramps down and switches off (no question: it stops the motor).
    page.click("[data-cmd=off1]")
    page.wait_for_function(
        "document.querySelector('#drive-state').textContent !== 'operation enabled'"
    )
    assert drive_state(demo, 1) is not DriveState.OPERATION


def _command(page: Any, name: str) -> str:
    """Click command ``name`` (say yes where the page asks) and wait for what the page says."""
    page.evaluate("document.querySelector('#drive-message').textContent = ''")
    page.click(f"[data-cmd={name}]")
    if name in ("on", "jog1", "jog2"):
        page.wait_for_function(
            "document.querySelector('#confirm').open"
            " || document.querySelector('#drive-message').textContent !== ''"
        )
        assert page.locator("#drive-message").inner_text() == ""
        page.click("#confirm-yes")
    page.wait_for_function(
        "(() => { const t = document.querySelector('#drive-message').textContent;"
        " return t !== '' && !t.includes('waiting'); })()"
    )
    return str(page.locator("#drive-message").inner_text())


def test_a_command_the_drive_does_not_take_is_said_so(page: Any, demo: Running) -> None:
    # The generic drive jogs as the USS specification says: not from "switch-on inhibited".
    page.goto(demo.url + "#drive/4")
    page.wait_for_function("document.querySelector('#drive-state').textContent !== '-'")
    page.wait_for_function("!document.querySelector('[data-cmd=jog1]').disabled")
    said = _command(page, "jog1")
    assert said.startswith("jog1: the drive did not take it: it shows ready to switch on")
    assert "What to do:" in said
    assert page.locator("#drive-message").get_attribute("class") == "error"
    assert demo.run(lambda: demo.backend.points(4).snapshot().state) != "operation enabled"
    said = _command(page, "jog_off")
    assert said.startswith("jog_off: done")


def test_a_v20_jogs_from_standstill_and_shows_its_ramp_down(page: Any, demo: Running) -> None:
    page.goto(demo.url + "#drive/9")
    page.wait_for_function("document.querySelector('#drive-title').textContent.includes('drive 9')")
    page.wait_for_function("!document.querySelector('[data-cmd=jog1]').disabled")
    # Nothing sent yet: the setpoint box is empty, the setpoint in force is 0.
    page.wait_for_function("document.querySelector('#setpoint-force').textContent !== '-'")
    assert page.locator("#setpoint-value").input_value() == ""
    assert page.locator("#setpoint-force").inner_text().startswith("0.00 %")
    said = _command(page, "jog1")
    assert said.startswith("jog1: done, the drive is operation enabled"), said
    assert "jogging" in said
    assert _command(page, "jog_off").startswith("jog_off: done")
    page.wait_for_function(
        "document.querySelector('#drive-state').textContent !== 'operation enabled'"
    )
    demo.call(demo.backend.command(9, "setpoint", 60))
    assert _command(page, "on").startswith("on: done, the drive is operation enabled")
    page.wait_for_function(
        "parseFloat(document.querySelector('#drive-actuals td[data-pzd]').textContent) > 8"
    )
    # OFF1: the drive stays in "operation enabled" while it ramps down; the page says so.
    said = _command(page, "off1")
    assert said.startswith("off1: done") and "OFF1 active, ramping down" in said
    assert page.locator("#drive-state").inner_text() == "operation enabled"
    page.wait_for_function(
        "document.querySelector('#drive-motion').textContent === 'OFF1 active, ramping down'"
    )
    page.wait_for_function("document.querySelector('#drive-motion').textContent === 'stopped'")


def test_the_drive_view_shows_every_status_bit_and_the_fault_panel(
    page: Any, demo: Running
) -> None:
    page.goto(demo.url + "#drive/9")
    page.wait_for_function("document.querySelector('#drive-title').textContent.includes('drive 9')")
    page.wait_for_function("document.querySelector('#fault-note').textContent !== ''")
    # All 16 bits, 11..15 with the SINAMICS V20's own texts (r0052).
    bits = page.locator("#drive-bits li")
    assert bits.count() == 16
    assert "motor turns right" in bits.nth(14).inner_text()
    assert "inverter overload (0 = active)" in bits.nth(15).inner_text()
    page.wait_for_function("document.querySelector('#control-force').textContent !== '-'")
    # the control words and the status word as uss read and uss status spell them: the hex
    # word and the names of its set bits (the status word's in its title)
    for word in ("#control-sent", "#control-force"):
        text = page.locator(word).text_content()
        assert re.fullmatch(r"[0-9A-F]{4}h  .+", text or ""), (word, text)
    page.wait_for_function(
        "document.querySelector('#drive-status').title.includes('motor turns right')"
    )
    # (a drive that missed an answer on a loaded machine is "not known" until its next one)
    page.wait_for_function(
        "document.querySelector('#fault-now').textContent === 'no fault, no warning'"
    )
    assert "r0947 fault numbers" in page.locator("#fault-note").inner_text()
    # A fault and a warning trip: the panel shows them with the family's texts.
    engine = demo.backend.engines[9].drive
    demo.run(engine.raise_fault, 3)
    demo.run(engine.raise_warning, 503)
    # The fault and the warning reach the page in separate answers: wait for both.
    page.wait_for_function(
        "(t => t.includes('F0003') && t.includes('undervoltage'))"
        "(document.querySelector('#fault-table tbody').textContent)"
    )
    table = page.locator("#fault-table tbody").inner_text()
    assert "F0003" in table and "A0503" in table and "undervoltage limit" in table
    page.wait_for_function(
        "document.querySelector('#fault-now').textContent === 'fault active, warning active'"
    )
    screenshot(page, "web-faults", full_page=True)
    # Acknowledge from the panel: the fault goes, the warning stays while its cause does.
    page.click("#fault-ack")
    page.wait_for_function(
        "document.querySelector('#fault-now').textContent === 'no fault, warning active'"
    )
    assert page.locator("#drive-message").inner_text().startswith("acknowledge: done")
    demo.run(engine.clear_warning, 503)


def test_a_v20_shows_its_key_actual_values_and_trends_them(page: Any, demo: Running) -> None:
    page.goto(demo.url + "#drive/9")
    page.wait_for_function("document.querySelector('#drive-title').textContent.includes('drive 9')")
    # Polled through the parameter channel beside the process data, with units.
    page.wait_for_function(
        "document.querySelector('#drive-actuals td[data-pnu=\"27\"]').textContent !== '-'"
    )
    table = page.locator("#drive-actuals").inner_text()
    for name in ("Actual frequency (r0021)", "Output current (r0027)", "Output voltage (r0025)"):
        assert name in table
    assert "DC link voltage (r0026)" in table and "Output power (r0032)" in table
    assert " A" in page.locator("#drive-actuals td[data-pnu='27']").inner_text()
    # Each may be put on the trend; the time axis is the 24-hour clock.
    choice = page.locator("#trend-choice label", has_text="Output current [A]")
    choice.locator("input").check()
    page.wait_for_function("window.pyuss.views.drive.polls >= 2")
    column = page.evaluate(
        "(() => { const d = window.pyuss.views.drive; const i = d.series.findIndex("
        "s => s.key === 'p27'); return d.data[i + 1].filter(v => v !== null).length; })()"
    )
    assert column >= 2
    ticks = page.evaluate("window.pyuss.views.drive.plot.axes[0]._values")
    assert ticks and all(len(t) == 8 and t[2] == ":" and t[5] == ":" for t in ticks)
    assert not any(t.endswith(("am", "pm", "AM", "PM")) for t in ticks)
    # Running: the polled frequency follows the ramp (for the picture of the docs). No fault
    # left by another test may keep it from running.
    demo.run(demo.backend.engines[9].drive.clear_warning, 503)
    demo.call(demo.backend.command(9, "acknowledge"))
    demo.call(demo.backend.command(9, "setpoint", 60))
    demo.call(demo.backend.command(9, "on"))
    try:
        page.wait_for_function(
            "parseFloat(document.querySelector('#drive-actuals td[data-pnu=\"21\"]')"
            ".textContent) > 10"
        )
        # the simulated motor draws current at a voltage by V/f, and takes power
        for pnu in (27, 25, 32):
            page.wait_for_function(
                f"parseFloat(document.querySelector('#drive-actuals td[data-pnu=\"{pnu}\"]')"
                ".textContent) > 0"
            )
        screenshot(page, "web-v20", full_page=True)
    finally:
        demo.call(demo.backend.command(9, "off1"))


def test_every_answer_reaches_the_trend(page: Any, demo: Running) -> None:
    page.goto(demo.url + "#drive/4")
    page.wait_for_function("document.querySelector('#drive-title').textContent.includes('drive 4')")
    page.evaluate(
        "window.times = []; window.pyuss.socket.addEventListener('message', e => {"
        " const m = JSON.parse(e.data); if (m.type === 'tick' && m.drives['4'])"
        " for (const s of m.drives['4'].samples) window.times.push(s[0]); })"
    )

    def answers_now() -> tuple[int, float]:
        # read in the drives' loop, so an answer is either counted or later than the time
        return demo.backend.points(4).drive.diagnostics().answers, time.time()

    start, since = demo.run(answers_now)
    page.wait_for_function(f"window.times.filter(t => t > {since:.4f}).length >= 30")
    end, until = demo.run(answers_now)
    page.wait_for_function(f"window.times.some(t => t > {until:.4f})")
    # every answer the master got between the two readings is sent on, once (none
    # dropped, thinned out or repeated); a sample's time is rounded to 0.1 ms
    got = page.evaluate(f"window.times.filter(t => t > {since:.4f} && t <= {until:.4f}).length")
    assert abs(got - (end - start)) <= 1, (got, end - start)
    times = page.evaluate("window.times")
    assert times == sorted(times)


def test_a_parameter_edit_reaches_the_drive_and_a_refusal_is_shown(
    page: Any, demo: Running
) -> None:
    page.goto(demo.url + "#params/1")
    page.wait_for_function(
        "document.querySelector('#param-message').textContent.includes('values read')"
    )
    page.fill("#param-search", "ramp-up")
    row = page.locator("#param-table tbody tr[data-id='462']")
    assert page.locator("#param-table tbody tr").count() == 1
    assert "10.0 s" in row.inner_text()
    row.locator("td.value").click()
    page.fill("#edit-value", "2.5 s")
    page.click("#edit-write")
    page.wait_for_function("!document.querySelector('#edit').open")
    assert "2.5 s" in row.inner_text()
    assert demo.run(lambda: demo.backend.engines[1].drive.value(462)) == 25
    # Checked before sending: not a number, outside the limits.
    row.locator("td.value").click()
    page.fill("#edit-value", "fast")
    page.click("#edit-write")
    page.wait_for_function(
        "document.querySelector('#edit-error').textContent.includes('not a number')"
    )
    page.fill("#edit-value", "1000")
    page.click("#edit-write")
    page.wait_for_function("document.querySelector('#edit-error').textContent.includes('outside')")
    page.click("#edit-cancel")
    # Refused by the drive: P352 is protected (access level below 3, error 12).
    page.fill("#param-search", "352")
    page.locator("#param-table tbody tr[data-id='352'] td.value").click()
    page.fill("#edit-value", "40")
    page.click("#edit-write")
    page.wait_for_function("document.querySelector('#edit-error').textContent.includes('error 12')")
    assert "keyword" in page.locator("#edit-error").inner_text()
    assert demo.run(lambda: demo.backend.engines[1].drive.value(352)) == 5000
    page.click("#edit-cancel")
    page.fill("#param-search", "")
    screenshot(page, "web-params", full_page=False)


def test_a_v20_names_its_parameters_as_its_manual_and_finds_every_spelling(
    page: Any, demo: Running
) -> None:
    page.goto(demo.url + "#params/9")  # the demo's SINAMICS V20
    page.wait_for_function(
        "document.querySelector('#param-message').textContent.includes('values read')"
    )
    for spelling in ("r0021", "r21", "P0021", "21.0", "r0021[0]"):
        page.fill("#param-search", spelling)
        rows = page.locator("#param-table tbody tr[data-id^='21']")
        assert rows.count() >= 1, spelling
        assert rows.first.locator("td").first.inner_text().startswith("r0021"), spelling
    page.fill("#param-search", "P1120")
    row = page.locator("#param-table tbody tr[data-id^='1120']").first
    assert row.locator("td").first.inner_text().startswith("P1120")
    page.fill("#param-search", "")


def test_a_value_the_layout_cannot_carry_is_said_once_and_not_editable(
    page: Any, demo: Running
) -> None:
    # Drive 4 talks the fixed layout 3,2: its 32-bit parameters do not fit one PWE word.
    page.goto(demo.url + "#params/4")
    page.wait_for_function(
        "document.querySelector('#param-message').textContent.includes('values read')"
    )
    row = page.locator("#param-table tbody tr[data-id='70']")
    assert row.locator("td.value").inner_text() == "needs PKW 4 or the variable layout"
    assert "error" not in row.inner_text()
    assert row.get_attribute("class") != "writable"
    row.locator("td.value").click()
    assert not page.locator("#edit").is_visible()
    assert page.locator("#param-table tbody tr[data-id='60']").get_attribute("class") == "writable"


def test_a_backup_downloads_and_restores_and_a_refusal_is_shown(
    page: Any, demo: Running, tmp_path: Any
) -> None:
    from pyuss.commission import load

    engine = demo.backend.engines[1].drive
    backend = demo.backend
    page.goto(demo.url + "#params/1")
    page.wait_for_function(
        "document.querySelector('#param-message').textContent.includes('values read')"
    )
    # The backup: a file of uss backup, downloaded by the browser.
    with page.expect_download() as info:
        page.click("#param-backup")
    download = info.value
    assert download.suggested_filename.startswith("drive1-generic-")
    assert download.suggested_filename.endswith(".toml")
    path = tmp_path / download.suggested_filename
    download.save_as(path)
    backup = load(path)
    assert (backup.address, backup.profile) == (1, "generic")
    ramp = backup.find(462)
    assert ramp is not None and ramp.unit == "s"
    saved = demo.run(lambda: engine.value(462))
    page.wait_for_function(
        "document.querySelector('#param-message').textContent.includes('saved as')"
    )
    try:
        # Changes: the ramp-up time on the page; the reference frequency by an expert (access
        # level 3 unlocks it), who goes back to level 2 afterwards.
        page.fill("#param-search", "ramp-up")
        page.locator("#param-table tbody tr[data-id='462'] td.value").click()
        page.fill("#edit-value", "7.5" if saved != 75 else "8")
        page.click("#edit-write")
        page.wait_for_function("!document.querySelector('#edit').open")
        assert demo.run(lambda: engine.value(462)) != saved
        demo.call(backend.write(1, 51, None, "EXPERT"))
        demo.call(backend.write(1, 352, None, "40"))
        demo.call(backend.write(1, 51, None, "STANDARD"))
        # Compare: the differences with names and units.
        page.set_input_files("#param-file", str(path))
        page.locator("#param-diff table.diff").wait_for()
        diff = page.locator("#param-diff")
        assert "Ramp-up time" in diff.locator("tr[data-id='462']").inner_text()
        reference = diff.locator("tr[data-id='352']").inner_text()
        assert "Reference freq." in reference and "40.00 Hz" in reference
        assert "50.00 Hz" in reference
        # Restore: it asks first, with the writes it will make; "Cancel" writes nothing.
        page.click("#restore-start")
        page.locator("#confirm").wait_for()
        question = page.locator("#confirm-text").inner_text()
        assert "P462 (Ramp-up time)" in question and "P352 (Reference freq.)" in question
        page.click("#confirm-no")
        assert demo.run(lambda: engine.value(462)) != saved
        page.click("#restore-start")
        page.click("#confirm-yes")
        page.locator("#restore-summary").wait_for()
        assert page.locator("#restore-summary").inner_text() == "drive 1: 1 of 2 written, 1 refused"
        # The ramp is back in the simulated drive; the protected parameter is refused in words.
        assert demo.run(lambda: engine.value(462)) == saved
        refused = page.locator("#param-diff li.refused").inner_text()
        assert refused.startswith("P352 (Reference freq.): 40.00 Hz -> 50.00 Hz")
        assert "refused: error 12: keyword missing" in refused
        assert page.locator("#param-diff li.ok[data-id='462']").count() == 1
        assert demo.run(lambda: engine.value(352)) == 4000
        page.fill("#param-search", "")
        page.wait_for_function(
            "document.querySelector('#param-message').textContent.includes('values read')"
        )
        screenshot(page, "web-restore", full_page=False)
    finally:
        demo.call(backend.write(1, 51, None, "EXPERT"))
        demo.call(backend.write(1, 352, None, "50"))
        demo.call(backend.write(1, 51, None, "STANDARD"))


def test_the_monitor_shows_filters_and_downloads_the_telegrams(
    page: Any, demo: Running, tmp_path: Any
) -> None:
    page.goto(demo.url + "#monitor")
    page.wait_for_function("document.querySelectorAll('#mon-list div').length > 20")
    text = page.locator("#mon-list").inner_text()
    assert "adr 1" in text and "adr 4" in text and "adr 7" in text
    page.fill("#mon-filter", "adr 4")
    page.wait_for_function(
        "[...document.querySelectorAll('#mon-list div')]"
        ".every(d => d.textContent.includes('adr 4'))"
    )
    page.click("#mon-pause")
    frozen = page.locator("#mon-list").inner_text()
    page.wait_for_timeout(500)
    assert page.locator("#mon-list").inner_text() == frozen
    page.click("#mon-pause")
    page.fill("#mon-filter", "")
    screenshot(page, "web-monitor", full_page=False)
    with page.expect_download() as info:
        page.click("#mon-pcapng")
    path = tmp_path / "line.pcapng"
    info.value.save_as(path)
    capture = read_capture(path)
    assert capture.baud == 38400
    assert len(capture.records) > 20


def test_the_page_fits_a_tablet(browser: Any, demo: Running) -> None:
    page = open_page(browser, demo.url + "#drive/1", width=768, height=1024)
    try:
        page.wait_for_function("document.querySelector('#drive-state').textContent !== '-'")
        overflow = page.evaluate(
            "document.documentElement.scrollWidth - document.documentElement.clientWidth"
        )
        assert overflow <= 0
        for button in ("on", "off1", "off2", "off3", "acknowledge", "jog1"):
            assert page.locator(f"[data-cmd={button}]").is_visible()
        screenshot(page, "web-tablet", full_page=False)
    finally:
        page.context.close()


def test_the_bus_table_and_the_monitor_are_usable_on_a_phone(browser: Any, demo: Running) -> None:
    page = open_page(browser, demo.url + "#bus", width=400, height=800)
    try:
        page.wait_for_function("document.querySelectorAll('#bus-table tbody tr').length === 4")
        wide = "document.documentElement.scrollWidth - document.documentElement.clientWidth"
        assert page.evaluate(wide) <= 0
        # every column shown fits the card: nothing to scroll sideways for
        table = page.evaluate(
            "(() => { const s = document.querySelector('#bus-table').parentElement;"
            " return s.scrollWidth - s.clientWidth; })()"
        )
        assert table <= 0
        row = page.locator("#bus-table tbody tr[data-address='9']")
        assert "sinamics-v20" in row.inner_text()
        shown = [c.is_visible() for c in row.locator("td").all()]
        assert sum(shown) == 6 and shown[3]  # the state is one of them
        screenshot(page, "web-phone-bus", full_page=True)
        page.goto(demo.url + "#monitor")
        page.wait_for_function("document.querySelectorAll('#mon-list div').length > 20")
        assert page.evaluate(wide) <= 0
        lines = page.evaluate(
            "(() => { const l = document.querySelector('#mon-list');"
            " return l.scrollWidth - l.clientWidth; })()"
        )
        assert lines <= 0  # the lines wrap: a telegram is read without scrolling sideways
        screenshot(page, "web-phone-monitor", full_page=False)
    finally:
        page.context.close()


def test_the_trend_zooms_pauses_and_exports_what_it_shows(
    page: Any, demo: Running, tmp_path: Any
) -> None:
    page.goto(demo.url + "#drive/7")
    page.wait_for_function("document.querySelector('#drive-title').textContent.includes('drive 7')")
    page.wait_for_function("window.pyuss.views.drive.data[0].length > 60")
    page.locator("#trend .u-over").scroll_into_view_if_needed()
    box = page.locator("#trend .u-over").bounding_box()
    assert box is not None
    # drag across the middle of the plot: a zoom into that time span
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + box["width"] * 0.80, y)
    page.mouse.down()
    page.mouse.move(box["x"] + box["width"] * 0.90, y, steps=5)
    page.mouse.move(box["x"] + box["width"] * 0.97, y, steps=5)
    page.mouse.up()
    page.locator("#trend-follow").wait_for()
    low, high = page.evaluate(
        "[pyuss.views.drive.plot.scales.x.min, pyuss.views.drive.plot.scales.x.max]"
    )
    page.click("#trend-pause")
    assert page.locator("#trend-pause").inner_text() == "Resume"
    with page.expect_download() as info:
        page.click("#trend-csv")
    path = tmp_path / "trend.csv"
    info.value.save_as(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0] == '"time","Main actual value [Hz]","Setpoint [Hz]"'
    import datetime as dt

    times = [dt.datetime.fromisoformat(line.split(",")[0]).timestamp() for line in lines[1:]]
    assert times and times == sorted(times)
    assert all(low - 1e-3 <= t <= high + 1e-3 for t in times)  # what is shown, nothing else
    shown = page.evaluate(
        "pyuss.views.drive.data[0].filter(t => t >= pyuss.views.drive.plot.scales.x.min"
        " && t <= pyuss.views.drive.plot.scales.x.max).length"
    )
    assert len(times) == shown
    page.click("#trend-pause")
    page.click("#trend-follow")
    assert page.locator("#trend-follow").is_hidden()


def test_the_buttons_are_disabled_while_no_drive_answers(browser: Any, demo: Running) -> None:
    from pyuss.web.backend import Backend, DriveSpec
    from pyuss.web.server import WebServer

    async def start() -> Backend:
        backend = Backend(demo=True, drives=[DriveSpec(12)], job_timeout=0.3)
        await backend.start()
        return backend

    backend = demo.call(start())  # nothing answers at address 12 on its virtual bus
    server = WebServer(backend, port=0)
    url = demo.call(server.start())
    try:
        page = open_page(browser, url + "#drive/12")
        page.wait_for_function("document.querySelector('[data-cmd=on]').disabled")
        for selector in ("[data-cmd=on]", "[data-cmd=jog1]", "#setpoint-form button", "#fault-ack"):
            assert page.locator(selector).is_disabled(), selector
        assert page.locator("[data-cmd=on]").get_attribute("title") == "the drive does not answer"
        # nothing is known of its status bits: none is shown as 0 or 1
        bits = page.locator("#drive-bits li").all_inner_texts()
        assert len(bits) == 16 and all(" = -: " in text for text in bits), bits
        page.context.close()
    finally:
        demo.call(server.close())
        demo.call(backend.close())


@contextlib.contextmanager
def _line_of_drive_5(demo: Running, *, answering: bool) -> Iterator[tuple[Any, str, Any]]:
    """A page over drive 5 (generic, 4,2) of a virtual bus, started in the demo's loop: its
    backend, its address and ``join(on)``, which brings the simulated drive onto the bus
    (True) or takes it off (False); it is there at the start if ``answering``."""
    from pyuss.bus import VirtualBus
    from pyuss.master.testing import simulated_drives
    from pyuss.protocol.layout import Layout
    from pyuss.web.backend import Backend, DriveSpec

    drives = contextlib.AsyncExitStack()
    bus = VirtualBus(38400)

    def join(on: bool) -> None:
        if on:
            simulated = simulated_drives(bus, [(5, "generic", Layout(4, 2))])
            demo.call(drives.enter_async_context(simulated))
        else:
            demo.call(drives.aclose())

    async def start() -> Backend:
        backend = Backend(transport=bus.attach("master"), baud=38400, job_timeout=0.3,
                          drives=[DriveSpec(5, "generic", Layout(4, 2))])  # fmt: skip
        await backend.start()
        return backend

    if answering:
        join(True)
    backend = demo.call(start())
    server = demo.call(serve(backend))
    try:
        yield backend, server.url, join
    finally:
        demo.call(server.close())
        demo.call(backend.close())
        join(False)
        demo.call(bus.close())


def test_a_drive_that_stops_answering_shows_nothing_of_before_as_now(
    browser: Any, demo: Running
) -> None:
    with _line_of_drive_5(demo, answering=True) as (backend, url, join):
        page = open_page(browser, url + "#drive/5")
        demo.call(backend.command(5, "on"))
        page.wait_for_function(
            "document.querySelector('#drive-bits li.on') && "
            "document.querySelector('#drive-bits li[data-bit=\"2\"]').classList.contains('on')"
        )
        assert page.locator("#drive-status").inner_text() != "----"
        join(False)  # the drive leaves the bus, switched on
        page.wait_for_function(
            "document.querySelector('#drive-state').textContent === 'does not send'"
        )
        assert page.locator("#drive-status").inner_text() == "----"
        assert page.locator("#drive-bits li.on").count() == 0
        assert all(" = -: " in t for t in page.locator("#drive-bits li").all_inner_texts())
        assert page.locator("#drive-motion").inner_text() == "-"
        # nor the fault panel read before: "no fault" was then
        assert page.locator("#fault-now").inner_text() == "not known"
        join(True)  # a drive answers again: the panel is read anew
        page.wait_for_function(
            "document.querySelector('#fault-now').textContent === 'no fault, no warning'"
        )
        # the trend draws no line over the silent spell: it is cut from the last value before
        # it to the first after
        page.wait_for_function(
            "(v => v.breaks.length === 1 && v.silentGaps(v.plot, 1).length === 1)"
            "(window.pyuss.views.drive)"
        )
        join(False)
        page.wait_for_function(
            "document.querySelector('#drive-state').textContent === 'does not send'"
        )
        # the bus view's row alike: no status word, no actual value of before
        page.goto(url + "#bus")
        page.wait_for_function(
            "(r => r && r.textContent.includes('does not send'))"
            "(document.querySelector('#bus-table tbody tr'))"
        )
        cells = page.locator("#bus-table tbody tr").first.locator("td").all_inner_texts()
        assert cells[4] == "----" and cells[5] == "-", cells
        page.context.close()


def test_the_units_follow_a_reference_read_after_the_view_opened(
    browser: Any, demo: Running
) -> None:
    # a drive powered on after the page: its reference (P352) is read once it answers, and
    # from then on its values are in Hz; the view opened before says Hz too, not % of them
    with _line_of_drive_5(demo, answering=False) as (_, url, join):
        page = open_page(browser, url + "#drive/5")
        page.wait_for_function("document.querySelector('#drive-title').textContent !== ''")
        assert "Main actual value [%]" in page.locator("#trend-choice").inner_text()
        join(True)
        page.wait_for_function(
            "document.querySelector('#trend-choice').textContent.includes('Main actual value [Hz]')"
        )
        page.wait_for_function(
            "document.querySelector('#drive-actuals td[data-pzd=\"2\"]').textContent"
            ".endsWith(' Hz')"
        )
        assert page.locator("#setpoint-unit option").all_inner_texts() == ["%", "Hz"]
        page.context.close()


def test_a_drive_of_unknown_kind_shows_a_parameter_typed_by_number_as_words(
    browser: Any, demo: Running
) -> None:
    from pyuss.protocol.layout import PKW_VARIABLE, Layout
    from pyuss.web.backend import Backend, DriveSpec
    from pyuss.web.server import WebServer

    async def start() -> Backend:
        # the demo's generic drive at address 1, shown as a drive no profile is named for
        unknown = DriveSpec(1, None, Layout(PKW_VARIABLE, 2))
        backend = Backend(demo=True, drives=[unknown], job_timeout=2.0)
        await backend.start()
        return backend

    backend = demo.call(start())
    server = WebServer(backend, port=0)
    url = demo.call(server.start())
    try:
        page = open_page(browser, url + "#params/1")
        page.wait_for_function(
            "document.querySelector('#param-message').textContent.includes('values read')"
        )
        assert page.locator("#param-table tbody tr").count() == 0  # no family's list
        page.fill("#param-search", "P462")
        row = page.locator("#param-table tbody tr[data-id='462']")
        page.wait_for_function(
            "document.querySelector(\"#param-table tr[data-id='462'] td.value\")"
            ".textContent.includes('0064h')"
        )
        assert "(nothing known: words)" in row.inner_text()  # 10.0 s is the word 100
        row.locator("td.value").click()
        page.fill("#edit-value", "0x19")
        page.click("#edit-write")
        page.wait_for_function("!document.querySelector('#edit').open")
        assert "25 (0019h)" in row.inner_text()
        assert demo.run(lambda: backend.engines[1].drive.value(462)) == 25
        page.context.close()
    finally:
        demo.call(server.close())
        demo.call(backend.close())


def test_read_only_hides_every_control(browser: Any, demo: Running) -> None:
    from pyuss.web.server import WebServer

    server = WebServer(demo.backend, port=0, read_only=True)
    url = demo.call(server.start())
    try:
        page = open_page(browser, url + "#drive/1")
        page.wait_for_function("document.querySelector('#drive-state').textContent !== '-'")
        assert page.locator("#ro-badge").is_visible()
        for selector in ("[data-cmd=on]", "[data-cmd=off1]", "#setpoint-form", "#scan-form"):
            assert page.locator(selector).is_hidden(), selector
        page.goto(url + "#params/1")
        page.wait_for_function(
            "document.querySelector('#param-message').textContent.includes('values read')"
        )
        assert page.locator("#param-table tr.writable").count() == 0
        assert page.locator("#param-backup").is_visible()  # reading stays
        page.context.close()
    finally:
        demo.call(server.close())


def test_a_page_of_an_earlier_start_of_the_server_changes_nothing(
    browser: Any, demo: Running
) -> None:
    # a tab left open while uss web was started again on the same address (perhaps on
    # another line): it reconnects, and its buttons are refused with what to do
    from pyuss.web.server import WebServer

    earlier = WebServer(demo.backend, port=0)
    url = demo.call(earlier.start())
    page = open_page(browser, url + "#drive/1")
    page.wait_for_function("document.querySelector('#drive-state').textContent !== '-'")
    demo.call(earlier.close())
    again = WebServer(demo.backend, port=earlier.port)
    demo.call(again.start())
    try:
        page.wait_for_function("document.querySelector('#link').textContent === 'live'")
        control = demo.run(lambda: demo.backend.points(1).drive.control)
        page.click("[data-cmd=off1]")
        page.wait_for_function(
            "document.querySelector('#drive-message').textContent.includes('reload the page')"
        )
        assert demo.run(lambda: demo.backend.points(1).drive.control) == control
        page.reload()
        page.wait_for_function("document.querySelector('#drive-state').textContent !== '-'")
        page.click("[data-cmd=off1]")
        page.wait_for_function(
            "document.querySelector('#drive-message').textContent.startsWith('off1: done')"
        )
        page.context.close()
    finally:
        demo.call(again.close())
