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
    // The line's profile (uss web --profile, uss.toml), "generic" where none is named.
    profiles.value = state.config.scan_profile || "generic";
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
    if (bus.plant) {
      this.renderPlant(bus);
      return;
    }
    document.getElementById("bus-port").textContent = bus.port;
    document.getElementById("bus-baud").textContent = `${bus.baud} baud`;
    document.getElementById("bus-cycle").textContent =
      bus.cycle_ms ? `${bus.cycle_ms.toFixed(1)} ms` : "-";
    document.getElementById("bus-line").textContent =
      bus.line.good === undefined ? "-" : `${bus.line.good} / ${bus.line.discarded}`;
    this.body.replaceChildren(...bus.drives.map((d) => this.row(d)));
  }

  row(d) {
    const h = d.health;
    const c = h.counters;
    const state = d.offline || (d.not_sending ? "does not send" : d.state);
    const actual = d.actual.length ? `${d.actual[0].toFixed(2)} ${d.actual_unit}` : "-";
    const row = el("tr", { dataset: { address: d.address } },
      el("td", {}, el("a", { href: `#drive/${d.address}` }, d.name ? `${d.address} ${d.name}` : d.address)),
      el("td", {}, d.profile), el("td", {}, d.layout), el("td", {}, state),
      el("td", {}, hex4(d.status)), el("td", { class: "num" }, actual),
      ...[h.answers, h.timeouts, h.response_ms == null ? "-" : h.response_ms.toFixed(2), c.good, c.discarded, c.framing,
        c.overrun, c.parity, c.no_stx, c.residual_time, c.bcc, c.bad_lge, c.timeout]
        .map((v) => el("td", { class: "num" }, v)));
    if (d.not_sending) row.classList.add("lost");
    if (d.fault) row.classList.add("fault");
    return row;
  }

  // A plant over the broker: the gateways with availability and latency, and the drives
  // grouped by gateway; a drive of an offline gateway shows why and no value.
  renderPlant(bus) {
    document.getElementById("plant-broker").textContent =
      `${bus.broker}${bus.connected ? "" : " (not connected)"}`;
    const ms = (m) => (m.last_ms == null ? "-" : `${m.last_ms.toFixed(1)} / ${m.median_ms.toFixed(1)}`);
    const gateways = bus.gateways.map((g) => {
      const row = el("tr", { dataset: { bus: g.bus } },
        el("td", {}, g.bus),
        el("td", {}, g.online ? "online" : "offline"),
        el("td", {}, g.read_only ? "read-only" : "read and write"),
        el("td", {}, g.version ?? "-"),
        el("td", { class: "num" }, g.keepalive == null ? "-" : `${g.keepalive} s`),
        el("td", { class: "num" }, g.drives.length),
        el("td", { class: "num latency-command" }, ms(g.latency.command)),
        el("td", { class: "num latency-value" }, ms(g.latency.value)));
      if (!g.online) row.classList.add("offline");
      return row;
    });
    document.querySelector("#gateway-table tbody").replaceChildren(...gateways);
    const rows = [];
    for (const g of bus.gateways) {
      const state = g.online ? (g.read_only ? "online, read-only" : "online") : "offline";
      rows.push(el("tr", { class: "group" }, el("td", { colspan: 19 }, `gateway ${g.bus}: ${state}`)));
      for (const d of bus.drives.filter((x) => x.bus === g.bus)) rows.push(this.row(d));
    }
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
