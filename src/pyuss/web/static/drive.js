// Drive view: status word decoded live, actual values, trend, control panel.
import { confirmMove, download, el, get, hex4, post } from "./api.js";

const COLORS = ["#1565c0", "#ef6c00", "#2e7d32", "#6a1b9a", "#c62828", "#00838f", "#5d4037"];
const MAX_POINTS = 60000;
const STATE_WORDS = {
  "operation enabled": "run", fault: "fault",
};

const CONFIRM = {
  on: "Switch the drive ON? The motor runs up to the setpoint.",
  jog1: "Jog 1? The motor turns at the jog 1 setpoint until you press Jog off.",
  jog2: "Jog 2? The motor turns at the jog 2 setpoint until you press Jog off.",
};

// A time of day on the 24-hour clock (14:05:09), as the trend's axis and legend show it.
function clock(t) {
  const d = new Date(t * 1000);
  return [d.getHours(), d.getMinutes(), d.getSeconds()].map((n) => String(n).padStart(2, "0")).join(":");
}

// A status bit as a panel shows it: the meaning now, or the family's text with the bit's value;
// on == null: not known (no answer yet, or the drive does not send), its value shown as "-".
function bitText(b, on) {
  if (on == null) return `${b.bit} = -: ${b.text || b.set}`;
  return b.text ? `${b.bit} = ${on ? 1 : 0}: ${b.text}` : `${b.bit}: ${on ? b.set : b.clear}`;
}

export class DriveView {
  constructor(state) {
    this.state = state;
    this.info = null;
    this.series = [];     // [{name, unit, key}]
    this.data = [[]];     // uPlot data: x, then one array per series
    this.breaks = [];     // the times at which the drive fell silent (`silentGaps`)
    this.window = 30;
    this.paused = false;
    this.following = true;
    this.pending = false;
    this.plot = null;
    this.updates = 0;     // samples received for the shown drive (tests read it)
    this.message_ = document.getElementById("drive-message");
    for (const button of document.querySelectorAll("[data-cmd]")) {
      button.addEventListener("click", () => this.command(button.dataset.cmd));
    }
    document.getElementById("setpoint-form").addEventListener("submit", (e) => {
      e.preventDefault();
      this.setpoint();
    });
    document.getElementById("trend-window").addEventListener("change", (e) => {
      this.window = Number(e.target.value);
      this.following = true;
      this.redraw();
    });
    document.getElementById("trend-pause").addEventListener("click", () => this.pause(!this.paused));
    document.getElementById("trend-follow").addEventListener("click", () => this.follow());
    document.getElementById("trend-csv").addEventListener("click", () => this.csv());
    document.getElementById("faults-read").addEventListener("click", () => this.readFaults());
    document.getElementById("fault-ack").addEventListener("click", async () => {
      await this.command("acknowledge");
      this.readFaults();
    });
    window.addEventListener("resize", () => this.resize());
    setInterval(() => this.poll(), 1000);
  }

  shown(visible) {
    this.visible = visible;
    if (visible) { this.resize(); this.redraw(); }
  }

  async driveChanged(address) {
    this.info = null;
    this.silent = undefined;
    this.setpointShown = false;
    document.getElementById("setpoint-value").value = "";
    // nothing of the drive shown before stays until this one's state comes
    for (const id of ["setpoint-force", "control-sent", "control-force", "drive-motion"]) {
      document.getElementById(id).textContent = "-";
    }
    if (address == null) return;
    const info = await get(`/api/drive/${address}`);
    if (this.state.address !== address) return;
    this.info = info;
    document.getElementById("drive-title").textContent =
      `drive ${address} · ${info.title} · layout ${info.layout}`;
    document.getElementById("drive-bits").replaceChildren(
      ...info.status_bits.map((b) => el("li", { dataset: { bit: b.bit } }, bitText(b, null))));
    const rows = info.actuals.map((a) => el("tr", {},
      el("td", {}, `${a.name} (PZD${a.pzd})`),
      el("td", { dataset: { pzd: a.pzd } }, "-")));
    // The family's key actual values, polled through the parameter channel.
    for (const k of info.key_actuals) {
      rows.push(el("tr", { class: "polled" },
        el("td", {}, `${k.name} (r${String(k.pnu).padStart(4, "0")})`),
        el("td", { dataset: { pnu: k.pnu } }, "-")));
    }
    document.querySelector("#drive-actuals tbody").replaceChildren(...rows);
    const unit = document.getElementById("setpoint-unit");
    const units = ["%"];
    if (info.reference) units.push(info.reference.unit);
    unit.replaceChildren(...units.map((u) => el("option", {}, u)));
    this.series = [
      ...info.actuals.map((a) => ({ name: a.name, unit: a.unit, key: `pzd${a.pzd}`, on: a.pzd === 2 })),
      { name: "Setpoint", unit: info.actuals.length ? info.actuals[0].unit : "%", key: "setpoint", on: true },
      ...info.key_actuals.map((k) => ({ name: k.name, unit: k.unit, key: `p${k.pnu}`, on: false, polled: true })),
    ];
    const choice = document.getElementById("trend-choice");
    choice.replaceChildren(...this.series.map((s, i) => {
      const box = el("input", { type: "checkbox", dataset: { series: i } });
      box.checked = s.on;
      box.addEventListener("change", () => {
        s.on = box.checked;
        this.plot?.setSeries(i + 1, { show: s.on });
      });
      return el("label", {}, box, ` ${s.name}${s.unit ? ` [${s.unit}]` : ""}`);
    }));
    this.data = [[], ...this.series.map(() => [])];
    this.breaks = [];
    this.updates = 0;
    this.build();
    this.alarmBits = null;
    this.readFaults();
  }

  // One row of the trend at time t, in time order (a polled value may be older than the
  // newest sample).
  insert(t, row) {
    const xs = this.data[0];
    let at = xs.length;
    while (at > 0 && xs[at - 1] > t) at -= 1;
    if (at === xs.length) {
      xs.push(t);
      row.forEach((v, i) => this.data[i + 1].push(v));
    } else {
      xs.splice(at, 0, t);
      row.forEach((v, i) => this.data[i + 1].splice(at, 0, v));
    }
  }

  // The key actual values: read once a second through the parameter channel while the drive
  // view is shown (one read at a time), into their cells and the trend.
  async poll() {
    const address = this.state.address;
    if (this.polling || !this.visible || !this.info || !this.info.key_actuals.length) return;
    this.polling = true;
    try {
      const reply = await get(`/api/drive/${address}/actuals`);
      if (this.state.address !== address || !this.info) return;
      this.polls = (this.polls || 0) + 1;
      const row = this.series.map((s) => {
        const v = reply.values.find((x) => `p${x.pnu}` === s.key);
        return v && v.value != null ? v.value : null;
      });
      for (const v of reply.values) {
        const cell = document.querySelector(`#drive-actuals td[data-pnu="${v.pnu}"]`);
        if (cell) cell.textContent = v.error ? "not read" : v.text;
        if (cell && v.error) cell.title = v.error;
      }
      this.insert(reply.time, row);
      this.redraw();
    } catch (error) {
      // the drive may not answer now: the buttons and state say so
    } finally {
      this.polling = false;
    }
  }

  // The fault and warning panel: read through the parameter channel when the drive is shown
  // and whenever its fault or warning bit changes.
  async readFaults() {
    const address = this.state.address;
    if (address == null) return;
    let panel;
    try {
      panel = await get(`/api/drive/${address}/faults`);
    } catch (error) {
      if (this.state.address === address) this.faultsNotKnown(error.message);
      return;
    }
    // a drive that fell silent while it was read: what it answered then is not what it is now
    if (this.state.address !== address || this.silent) return;
    const now = [panel.fault ? "fault active" : "no fault", panel.warning ? "warning active" : "no warning"];
    const fault = document.getElementById("fault-now");
    fault.textContent = now.join(", ");
    fault.className = panel.fault ? "error" : "note";
    const rows = [];
    const cell = (v) => el("td", {}, v == null ? "" : String(v));
    for (const f of panel.history || []) {
      rows.push(el("tr", { class: "fault" }, cell("fault"), cell(f.index), cell(`F${String(f.number).padStart(4, "0")}`),
        cell(f.text), cell(f.time), cell(f.value)));
    }
    for (const w of panel.warnings || []) {
      rows.push(el("tr", { class: "warning" }, cell("warning"), cell(w.index), cell(`A${String(w.number).padStart(4, "0")}`),
        cell(w.text), cell(null), cell(null)));
    }
    document.querySelector("#fault-table tbody").replaceChildren(...rows);
    const names = { numbers: "fault numbers", times: "fault times", values: "fault values", warnings: "warning numbers" };
    const kept = Object.entries(panel.parameters).map(([k, pnu]) => `r${String(pnu).padStart(4, "0")} ${names[k]}`);
    document.getElementById("fault-note").textContent = kept.length
      ? `Read from ${kept.join(", ")}${rows.length ? "" : ": none recorded"}.`
      : "This drive family keeps no fault history in its parameters: the status word shows fault and warning.";
  }

  // What could not be read is not shown as read: no "no fault", no history of before.
  faultsNotKnown(why) {
    const fault = document.getElementById("fault-now");
    fault.textContent = "not known";
    fault.className = "error";
    document.querySelector("#fault-table tbody").replaceChildren();
    document.getElementById("fault-note").textContent = `Faults not read: ${why}`;
  }

  // The trend's silent spells: from the last value before a drive fell silent to the first
  // after it answered again, no line is drawn (a straight line there would be no value the
  // drive said). Each spell is a row of no values just after the last sample (`breaks`).
  silentGaps(u, i) {
    const gaps = [];
    const xs = u.data[0];
    const ys = u.data[i];
    for (const x of this.breaks) {
      const at = xs.indexOf(x);
      if (at < 0) continue;
      let before = at - 1;
      while (before >= 0 && ys[before] == null) before -= 1;
      let after = at + 1;
      while (after < xs.length && ys[after] == null) after += 1;
      if (before < 0 || after >= xs.length) continue;  // no line there to cut
      uPlot.addGap(gaps, Math.round(u.valToPos(xs[before], "x", true)),
        Math.round(u.valToPos(xs[after], "x", true)));
    }
    return gaps;
  }

  build() {
    const target = document.getElementById("trend");
    this.plot?.destroy();
    target.replaceChildren();
    const opts = {
      width: Math.max(target.clientWidth, 280),
      height: 300,
      scales: { x: { time: true } },
      series: [
        { label: "time", value: (u, t) => (t == null ? "-" : clock(t)) },
        ...this.series.map((s, i) => ({
          label: `${s.name}${s.unit ? ` [${s.unit}]` : ""}`,
          stroke: COLORS[i % COLORS.length],
          width: 2,
          show: s.on,
          // a polled row holds no process data: drawn across; a silent spell is not (`gaps`)
          spanGaps: false,
          gaps: (u, i) => this.silentGaps(u, i),
          points: { show: false },
        })),
      ],
      axes: [{ values: (u, splits) => splits.map(clock) }, { size: 60 }],
      cursor: { drag: { x: true, y: false } },
      hooks: {
        setSelect: [(u) => {
          if (u.select.width > 0) {
            this.following = false;
            document.getElementById("trend-follow").hidden = false;
          }
        }],
      },
    };
    this.plot = new uPlot(opts, this.data, target);
    this.plot.over.addEventListener("dblclick", () => this.follow());
  }

  resize() {
    const target = document.getElementById("trend");
    if (this.plot && target.clientWidth) {
      this.plot.setSize({ width: target.clientWidth, height: 300 });
    }
  }

  follow() {
    this.following = true;
    document.getElementById("trend-follow").hidden = true;
    this.redraw();
  }

  pause(paused) {
    this.paused = paused;
    document.getElementById("trend-pause").textContent = paused ? "Resume" : "Pause";
    if (!paused) this.redraw();
  }

  message(message) {
    if (message.type === "tick") this.tick(message);
    if (message.type === "bus") this.busState(message.bus);
  }

  busState(bus) {
    const d = bus.drives.find((x) => x.address === this.state.address);
    if (!d) return;
    this.summary = d;
    const main = this.info && this.info.actuals[0];  // the column actual_unit is of
    const unitOf = `${d.address} ${d.actual_unit}`;  // made anew once per drive and unit
    if (main && d.actual_unit && main.unit !== d.actual_unit && !this.reloading
        && this.reloadedFor !== unitOf) {
      // the reference was read since the view opened: the values come in its unit now, so
      // the names, units and trend are made anew (a trend of % and Hz in one line is none)
      this.reloading = true;
      this.reloadedFor = unitOf;
      this.driveChanged(this.state.address).finally(() => { this.reloading = false; });
      return;
    }
    const stateEl = document.getElementById("drive-state");
    const silent = d.not_sending || d.status == null;
    if (d.not_sending) {
      stateEl.textContent = d.offline || "does not send";
      stateEl.className = "state lost";
      // nothing of before is shown as live: no status word, no status bits, no values
      document.getElementById("drive-status").textContent = hex4(null);
      if (this.info) this.showBits(null);
      for (const cell of document.querySelectorAll("#drive-actuals td[data-pzd]")) cell.textContent = "-";
    } else if (this.state.config.plant && d.status != null && this.info) {
      // a gateway sends a drive's state when it changes: a drive at rest sends none, so
      // the bus messages show its state too (after an offline spell, say)
      this.showStatus(d.status, d.state, d.actual);
    }
    // The fault panel read before is not what a silent drive shows now; read it anew once
    // the drive answers again.
    if (silent !== this.silent && this.info) {
      if (silent) {
        this.faultsNotKnown("the drive does not send");
        const xs = this.data[0];
        if (xs.length) {  // the trend's line ends here (`silentGaps`)
          const x = xs[xs.length - 1] + 0.001;
          this.insert(x, this.series.map(() => null));
          this.breaks.push(x);
        }
      } else if (this.silent !== undefined) this.readFaults();
    }
    this.silent = silent;
    // No drive answering: nothing to command (a command would only time out).
    for (const button of document.querySelectorAll("#view-drive .controls button, #setpoint-form button, #fault-ack")) {
      button.disabled = silent;
      button.title = silent ? (d.offline || "the drive does not answer") : "";
    }
    document.getElementById("drive-motion").textContent = silent ? "-" : d.motion;
    this.showSetpoint(d.setpoint);
    // the words as the server spells them (pyuss.params.words): hex and the set bits named
    document.getElementById("control-sent").textContent = d.control_text ?? hex4(d.control);
    document.getElementById("control-force").textContent =
      d.control_in_force == null ? "-" : d.control_in_force_text ?? hex4(d.control_in_force);
    document.getElementById("drive-status").title = silent ? "" : d.status_text ?? "";
    const box = document.getElementById("setpoint-value");
    if (!this.setpointShown && d.sent_setpoint && document.activeElement !== box) {
      box.value = d.sent_setpoint.value;
      document.getElementById("setpoint-unit").value = d.sent_setpoint.unit;
    }
    this.setpointShown = true;
  }

  showSetpoint(sp) {
    document.getElementById("setpoint-force").textContent = sp == null ? "-"
      : `${sp.percent.toFixed(2)} %${sp.value != null && sp.unit !== "%" ? ` (${sp.value.toFixed(2)} ${sp.unit})` : ""}`;
  }

  tick(message) {
    const address = this.state.address;
    const drive = message.drives[String(address)];
    if (!drive || !this.info) return;
    const samples = drive.samples;
    const last = samples[samples.length - 1];
    this.updates += samples.length;
    this.showStatus(last[1], drive.state, last[2]);
    if (drive.motion) document.getElementById("drive-motion").textContent = drive.motion;
    for (const [t, , values] of samples) {
      this.insert(t, this.series.map((s) => {
        if (s.key === "setpoint") return drive.setpoint ?? null;
        if (s.key.startsWith("pzd")) return values[Number(s.key.slice(3)) - 2] ?? null;
        return null;
      }));
    }
    const extra = this.data[0].length - MAX_POINTS;
    if (extra > 0) {
      for (const column of this.data) column.splice(0, extra);
      this.breaks = this.breaks.filter((x) => x >= this.data[0][0]);  // gone with its rows
    }
    this.redraw();
  }

  showStatus(word, state, values) {
    const alarms = word & 0x88;  // status bits 3 (fault) and 7 (warning)
    if (this.alarmBits !== null && this.alarmBits !== undefined && alarms !== this.alarmBits) this.readFaults();
    this.alarmBits = alarms;
    document.getElementById("drive-status").textContent = hex4(word);
    const stateEl = document.getElementById("drive-state");
    stateEl.textContent = state;
    stateEl.className = `state ${STATE_WORDS[state] || ""}`;
    this.showBits(word);
    for (const cell of document.querySelectorAll("#drive-actuals td[data-pzd]")) {
      const pzd = Number(cell.dataset.pzd);
      const a = this.info.actuals.find((x) => x.pzd === pzd);
      const v = values[pzd - 2];
      cell.textContent = v == null ? "-" : `${v.toFixed(2)} ${a.unit}`;
    }
  }

  // The 16 status bits of ``word`` (null: not known, none shown as set).
  showBits(word) {
    for (const li of document.querySelectorAll("#drive-bits li")) {
      const bit = Number(li.dataset.bit);
      const on = word == null ? null : Boolean((word >> bit) & 1);
      li.classList.toggle("on", Boolean(on));
      li.textContent = bitText(this.info.status_bits[bit], on);
    }
  }

  redraw() {
    if (this.pending || this.paused || !this.plot || !this.visible) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      if (this.paused || !this.plot) return;
      const xs = this.data[0];
      if (this.following) {
        const now = xs.length ? xs[xs.length - 1] : Date.now() / 1000;
        this.plot.setData(this.data, false);
        this.plot.setScale("x", { min: now - this.window, max: now });
      } else {
        this.plot.setData(this.data, false);
      }
    });
  }

  // The samples between the plot's left and right edge, in the series shown.
  shownRows() {
    const { min, max } = this.plot.scales.x;
    const shown = this.series.map((s, i) => [s, i + 1]).filter(([s]) => s.on);
    const rows = [];
    this.data[0].forEach((t, k) => {
      if (t >= min && t <= max) rows.push([t, ...shown.map(([, i]) => this.data[i][k])]);
    });
    return { shown: shown.map(([s]) => s), rows };
  }

  csv() {
    if (!this.plot) return;
    const { shown, rows } = this.shownRows();
    const quote = (text) => `"${String(text).replaceAll('"', '""')}"`;
    const head = ["time", ...shown.map((s) => `${s.name}${s.unit ? ` [${s.unit}]` : ""}`)];
    const lines = [head.map(quote).join(",")];
    for (const [t, ...values] of rows) {
      lines.push([new Date(t * 1000).toISOString(), ...values.map((v) => (v == null ? "" : v))].join(","));
    }
    download(`drive${this.state.address}-trend.csv`, lines.join("\r\n") + "\r\n");
  }

  say(text, bad = false) {
    this.message_.textContent = text;
    this.message_.className = bad ? "error" : "note";
  }

  // The server checks the whole command first (nothing is sent); a refused one is shown and
  // never asked about, so the question only promises what will be sent. The yes carries the
  // check's "confirm", good once for exactly that command.
  async checked(address, request, label) {
    try {
      return await post(`/api/drive/${address}/command`, { ...request, check: true });
    } catch (error) {
      this.say(`${label}: ${error.message}`, true);
      return null;
    }
  }

  async command(name) {
    const address = this.state.address;
    if (address == null) return;
    const request = { name };
    if (CONFIRM[name]) {
      const check = await this.checked(address, request, name);
      if (!check) return;
      if (!(await confirmMove(`Drive ${address}: ${CONFIRM[name]}`))) {
        this.say("Not sent.");
        return;
      }
      request.confirm = check.confirm;
    }
    try {
      this.say(`${name}: sent, waiting for the drive ...`);
      const reply = await post(`/api/drive/${address}/command`, request);
      this.say(reply.text, !reply.taken);
    } catch (error) {
      this.say(`${name}: ${error.message}`, true);
    }
  }

  async setpoint() {
    const address = this.state.address;
    const value = document.getElementById("setpoint-value").value;
    const unit = document.getElementById("setpoint-unit").value;
    const request = { name: "setpoint", value: { value, unit } };
    const check = await this.checked(address, request, "Setpoint");
    if (!check) return;
    if (!(await confirmMove(`Drive ${address}: ${check.text}? A running motor follows it.`))) {
      this.say("Not sent.");
      return;
    }
    try {
      const reply = await post(`/api/drive/${address}/command`, { ...request, confirm: check.confirm });
      this.showSetpoint(reply.setpoint);
      this.say(reply.text, !reply.taken);
    } catch (error) {
      this.say(`Setpoint: ${error.message}`, true);
    }
  }
}
