// Parameters view: the expert list, search, typed edit, backup, compare and restore.
import { el, get, post, upload, withToken } from "./api.js";

export class ParamsView {
  constructor(state) {
    this.state = state;
    this.rows = [];
    this.values = new Map();
    this.body = document.querySelector("#param-table tbody");
    this.search = document.getElementById("param-search");
    this.note = document.getElementById("param-message");
    this.search.addEventListener("input", () => this.render());
    document.getElementById("param-read").addEventListener("click", () => this.readAll());
    document.getElementById("param-file").addEventListener("change", (e) => this.compare(e.target));
    document.getElementById("edit-form").addEventListener("submit", (e) => this.submit(e));
    this.loaded = null;
  }

  shown(visible) {
    if (visible && this.state.address != null && this.loaded !== this.state.address) {
      this.load(this.state.address);
    }
  }

  driveChanged(address) {
    this.loaded = null;
    this.rows = [];
    this.values.clear();
    this.body.replaceChildren();
    document.getElementById("param-diff").hidden = true;
    document.getElementById("param-backup").href = withToken(`/api/drive/${address}/backup`);
    if (this.state.view === "params" && address != null) this.load(address);
  }

  async load(address) {
    this.loaded = address;
    this.rows = await get(`/api/drive/${address}/params`);
    this.render();
    await this.readAll();
  }

  matches(row, words) {
    if (!words) return true;
    const text = `p${row.id} ${row.id} ${row.name} ${row.unit}`.toLowerCase();
    return words.split(/\s+/).every((w) => text.includes(w.replace(/^r/, "p")) || text.includes(w));
  }

  render() {
    const words = this.search.value.trim().toLowerCase();
    const writable = !this.state.config.read_only;
    const rows = this.rows.filter((r) => this.matches(r, words)).map((r) => {
      const value = this.values.get(r.id) || {};
      const range = r.min == null ? "" : `${r.min} .. ${r.max}${r.unit ? ` ${r.unit}` : ""}`;
      const cell = el("td", { class: value.error ? "value err" : "value" },
        value.error ? value.error : value.value ?? "…");
      const tr = el("tr", { dataset: { id: r.id } },
        el("td", {}, `P${r.id}`), el("td", { class: "name", title: r.doc }, r.name), cell,
        el("td", { class: "note" }, range),
        el("td", { class: "note" }, r.access === "ro" ? "read-only" : r.access === "protected" ? "protected" : ""));
      if (r.writable && writable) {
        tr.classList.add("writable");
        cell.addEventListener("click", () => this.edit(r));
      }
      return tr;
    });
    this.body.replaceChildren(...rows);
  }

  async readAll() {
    const address = this.state.address;
    const ids = this.rows.map((r) => r.id);
    this.note.textContent = `Reading ${ids.length} values …`;
    for (let i = 0; i < ids.length; i += 16) {
      const batch = await post(`/api/drive/${address}/params/read`, { ids: ids.slice(i, i + 16) });
      if (this.state.address !== address) return;
      for (const item of batch) this.values.set(item.id, item);
      this.render();
    }
    this.note.textContent = `${ids.length} values read from drive ${address}.`;
  }

  edit(row) {
    this.editing = row;
    const dialog = document.getElementById("edit");
    document.getElementById("edit-title").textContent = `P${row.id} ${row.name}`;
    const texts = Object.entries(row.texts).map(([k, v]) => `${k} = ${v.trim()}`).join(", ");
    const range = row.min == null ? "" : `Range ${row.min} .. ${row.max}${row.unit ? ` ${row.unit}` : ""}. `;
    document.getElementById("edit-info").textContent =
      `${row.type}. ${range}${texts ? `Values: ${texts}.` : ""} Now: ${this.values.get(row.id)?.value ?? "?"}`;
    const input = document.getElementById("edit-value");
    input.value = this.values.get(row.id)?.input ?? "";
    document.getElementById("edit-error").textContent = "";
    document.getElementById("edit-eeprom").checked = false;
    dialog.showModal();
    input.focus();
  }

  async submit(event) {
    if (event.submitter?.value !== "write") return;
    event.preventDefault();
    const row = this.editing;
    const error = document.getElementById("edit-error");
    error.textContent = "Writing …";
    try {
      const result = await post(`/api/drive/${this.state.address}/params/write`, {
        id: row.id,
        value: document.getElementById("edit-value").value,
        eeprom: document.getElementById("edit-eeprom").checked,
      });
      this.values.set(row.id, result);
      this.render();
      this.note.textContent = `P${row.id} is now ${result.value}.`;
      document.getElementById("edit").close();
    } catch (e) {
      error.textContent = e.message;
    }
  }

  async compare(input) {
    const file = input.files[0];
    input.value = "";
    if (!file) return;
    const address = this.state.address;
    const box = document.getElementById("param-diff");
    try {
      const reply = await upload(`/api/drive/${address}/compare`, file);
      const differ = reply.differences;
      box.hidden = false;
      const table = el("table", { class: "diff" },
        el("thead", {}, el("tr", {}, el("th", {}, "No."), el("th", {}, "Name"),
          el("th", {}, "Drive"), el("th", {}, `File ${file.name}`))),
        el("tbody", {}, ...differ.map((d) => el("tr", {},
          el("td", {}, `P${d.id}`), el("td", {}, d.name ?? ""),
          el("td", { class: "changed" }, d.drive ?? "-"), el("td", {}, d.file ?? "-")))));
      const restore = el("button", { class: "go writes", type: "button" }, "Restore these to the drive");
      restore.addEventListener("click", () => this.restore(file));
      box.replaceChildren(
        el("p", {}, differ.length
          ? `${differ.length} parameter(s) of drive ${address} differ from ${file.name}.`
          : `Drive ${address} holds the values of ${file.name}.`),
        differ.length ? table : "", differ.length && !this.state.config.read_only ? restore : "");
    } catch (e) {
      box.hidden = false;
      box.replaceChildren(el("p", { class: "error" }, `Compare: ${e.message}`));
    }
  }

  async restore(file) {
    const box = document.getElementById("param-diff");
    try {
      const reply = await upload(`/api/drive/${this.state.address}/restore`, file);
      box.replaceChildren(el("p", {}, reply.message));
      await this.readAll();
    } catch (e) {
      box.replaceChildren(el("p", { class: "error" }, `Restore: ${e.message}`));
    }
  }
}
