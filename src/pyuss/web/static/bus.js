// Bus view: the line, the drives on it with state and communication health, scan.
import { el, hex4, post } from "./api.js";

export class BusView {
  constructor(state) {
    this.state = state;
    this.body = document.querySelector("#bus-table tbody");
    this.progress = document.getElementById("scan-progress");
    this.result = document.getElementById("scan-result");
    const profiles = document.getElementById("scan-profile");
    profiles.replaceChildren(...(state.config.profiles || ["generic"]).map((name) => el("option", {}, name)));
    document.getElementById("scan-form").addEventListener("submit", (e) => {
      e.preventDefault();
      this.scan();
    });
  }

  message(message) {
    if (message.type === "bus") this.render(message.bus);
    if (message.type === "scan") {
      this.progress.hidden = false;
      this.progress.max = message.total;
      this.progress.value = message.done;
    }
  }

  render(bus) {
    document.getElementById("bus-port").textContent = bus.port;
    document.getElementById("bus-baud").textContent = `${bus.baud} baud`;
    document.getElementById("bus-cycle").textContent =
      bus.cycle_ms ? `${bus.cycle_ms.toFixed(1)} ms` : "-";
    document.getElementById("bus-line").textContent =
      bus.line.good === undefined ? "-" : `${bus.line.good} / ${bus.line.discarded}`;
    const rows = bus.drives.map((d) => {
      const h = d.health;
      const c = h.counters;
      const state = d.not_sending ? "does not send" : d.state;
      const actual = d.actual.length ? `${d.actual[0].toFixed(2)} ${d.actual_unit}` : "-";
      const row = el("tr", { dataset: { address: d.address } },
        el("td", {}, el("a", { href: `#drive/${d.address}` }, d.address)),
        el("td", {}, d.profile), el("td", {}, d.layout), el("td", {}, state),
        el("td", {}, hex4(d.status)), el("td", { class: "num" }, actual),
        ...[h.answers, h.timeouts, h.response_ms.toFixed(2), c.good, c.discarded, c.framing,
          c.overrun, c.parity, c.no_stx, c.residual_time, c.bcc, c.bad_lge, c.timeout]
          .map((v) => el("td", { class: "num" }, v)));
      if (d.not_sending) row.classList.add("lost");
      if (d.fault) row.classList.add("fault");
      return row;
    });
    this.body.replaceChildren(...rows);
  }

  async scan() {
    const button = document.getElementById("scan-start");
    button.disabled = true;
    this.progress.hidden = false;
    this.progress.value = 0;
    this.result.textContent = "Scanning: the cyclic traffic pauses meanwhile.";
    try {
      const reply = await post("/api/scan", {
        addresses: document.getElementById("scan-addresses").value,
        profile: document.getElementById("scan-profile").value,
      });
      const found = reply.found;
      this.result.textContent = found.length
        ? `Found ${found.map((f) => `${f.address} (${f.layout}, ${f.baud} baud)`).join(", ")}.`
        : "No drive answered.";
    } catch (error) {
      this.result.textContent = `Scan failed: ${error.message}`;
    } finally {
      button.disabled = false;
      this.progress.value = this.progress.max;
    }
  }
}
