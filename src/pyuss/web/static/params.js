// Parameters view: the expert list, search, typed edit, backup, compare and restore.
import { confirmMove, el, fetchFile, get, post, saveBlob, upload, withToken } from "./api.js";

function rangeText(row) {
  const unit = row.unit ? ` ${row.unit}` : "";
  if (row.allowed) return `one of ${row.allowed.join(", ")}${unit}`;
  if (row.min == null && row.max == null) return "";
  return `${row.min ?? ""} .. ${row.max ?? ""}${unit}`;
}

export class ParamsView {
  constructor(state) {
    this.state = state;
    this.rows = [];
    this.values = new Map();
    this.body = document.querySelector("#param-table tbody");
    this.search = document.getElementById("param-search");
    this.note = document.getElementById("param-message");
    this.progress = document.getElementById("param-progress");
    this.box = document.getElementById("param-diff");
    this.busy = false;
    this.search.addEventListener("input", () => this.render());
    document.getElementById("param-read").addEventListener("click", () => this.readAll());
    document.getElementById("param-backup").addEventListener("click", () => this.backup());
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
    this.box.hidden = true;
    if (this.state.view === "params" && address != null) this.load(address);
  }

  // Live progress of a backup, compare or restore of the drive shown.
  message(message) {
    if (message.type !== "progress" || message.address !== this.state.address || !this.busy) return;
    this.progress.hidden = message.done >= message.total;
    this.progress.max = Math.max(message.total, 1);
    this.progress.value = message.done;
    if (message.label) this.note.textContent = `${this.busy}: ${message.label} (${message.done + 1} of ${message.total})`;
  }

  async load(address) {
    this.loaded = address;
    this.rows = await get(`/api/drive/${address}/params`);
    this.render();
    await this.readAll();
  }

  matches(row, words) {
    if (!words) return true;
    const label = (row.label || "").toLowerCase();
    const text = `p${row.id} ${row.id} ${label} ${row.name} ${row.unit}`.toLowerCase();
    return words.split(/\s+/).every((w) => {
      // A parameter as any document writes it - r21, P0021, 21, 21.0, r0947[1] - finds its rows.
      const spelled = /^[rp]?0*(\d+)(?:[.[](\d+)\]?)?$/.exec(w);
      if (spelled) {
        const wanted = spelled[2] === undefined ? spelled[1] : `${spelled[1]}.${spelled[2]}`;
        const id = String(row.id);
        if (id === wanted || id.startsWith(`${wanted}.`)) return true;
        if (id === spelled[1] && Number(spelled[2]) === 0) return true; // 21.0: a scalar's only value
      }
      return text.includes(w.replace(/^r/, "p")) || text.includes(w);
    });
  }

  // A parameter the list does not know (all of them, on a drive of unknown kind), typed into
  // the search by number: a row of its own, read and written as the words it travels in.
  wordsRow(words) {
    const spelled = /^[rp]?0*(\d+)(?:[.[](\d+)\]?)?$/.exec(words);
    if (!spelled) return null;
    const id = spelled[2] === undefined ? spelled[1] : `${spelled[1]}.${spelled[2]}`;
    if (!this.values.has(id)) {
      this.values.set(id, {});
      post(`/api/drive/${this.state.address}/params/read`, { ids: [id] }).then((batch) => {
        for (const item of batch) this.values.set(item.id, item);
        this.render();
      }, (e) => this.values.set(id, { error: e.message }));
    }
    return { id, label: `P${id}`, name: "(nothing known: words)", doc: "", type: "words",
      unit: "", texts: {}, access: "", writable: true };
  }

  render() {
    const words = this.search.value.trim().toLowerCase();
    const writable = !this.state.config.read_only;
    let listed = this.rows.filter((r) => this.matches(r, words));
    if (!listed.length) listed = [this.wordsRow(words)].filter(Boolean);
    const rows = listed.map((r) => {
      const value = this.values.get(r.id) || {};
      // A value the layout cannot carry: said once, in short, no value, no edit.
      const cell = r.needs
        ? el("td", { class: "value na", title: r.needs }, r.needs.split(":")[0])
        : el("td", { class: value.error ? "value err" : "value" },
          value.error ? value.error : value.value ?? "…");
      const access = r.access === "ro" ? "read-only" : r.access === "protected" ? "protected" : "";
      const tr = el("tr", { dataset: { id: r.id } },
        el("td", {}, r.label || `P${r.id}`), el("td", { class: "name", title: r.doc }, r.name), cell,
        el("td", { class: "note" }, rangeText(r)),
        el("td", { class: "note" }, access));
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
    const ids = this.rows.filter((r) => !r.needs).map((r) => r.id);
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
    const texts = Object.entries(row.texts).map(([k, v]) => `${k} = ${v}`).join(", ");
    const range = rangeText(row);
    const parts = [row.type + (row.unit ? ` in ${row.unit}` : ""),
      range ? `Range ${range}` : "", texts ? `Values: ${texts}` : "",
      `Now: ${this.values.get(row.id)?.value ?? "?"}`];
    document.getElementById("edit-info").textContent = parts.filter(Boolean).join(". ") + ".";
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
      this.note.textContent = result.written === undefined
        ? `P${row.id} is now ${result.value}.`
        : `P${row.id} is now ${result.value}: the drive answered this, not ${result.written} ` +
          "(it limits or rounds the value).";
      document.getElementById("edit").close();
    } catch (e) {
      error.textContent = e.message;
    }
  }

  // Run one long job (backup, compare, restore) at a time, with its progress bar.
  async job(name, work) {
    if (this.busy) return;
    this.busy = name;
    this.progress.value = 0;
    this.progress.hidden = false;
    try {
      return await work();
    } finally {
      this.busy = false;
      this.progress.hidden = true;
    }
  }

  async backup() {
    const address = this.state.address;
    const format = document.getElementById("param-format").value;
    this.note.textContent = `Backup of drive ${address} …`;
    await this.job("Backup", async () => {
      try {
        const file = await fetchFile(withToken(`/api/drive/${address}/backup?format=${format}`));
        saveBlob(file.name, file.blob);
        this.note.textContent = `Backup of drive ${address} saved as ${file.name}.`;
      } catch (e) {
        this.note.textContent = "";
        this.showError(`Backup: ${e.message}`);
      }
    });
  }

  showError(text) {
    this.box.hidden = false;
    this.box.replaceChildren(el("p", { class: "error" }, text));
  }

  async compare(input) {
    const file = input.files[0];
    input.value = "";
    if (!file) return;
    const address = this.state.address;
    this.note.textContent = `Comparing drive ${address} with ${file.name} …`;
    await this.job("Compare", async () => {
      try {
        const reply = await upload(`/api/drive/${address}/compare?name=${encodeURIComponent(file.name)}`, file);
        this.note.textContent = "";
        this.showDiff(address, file, reply);
      } catch (e) {
        this.note.textContent = "";
        this.showError(`Compare: ${e.message}`);
      }
    });
  }

  showDiff(address, file, reply) {
    const differ = reply.differences;
    const parts = [el("h3", {}, `Drive ${address} and ${file.name}`),
      el("p", { class: "note" }, `Backup of drive ${reply.address} (${reply.profile}), ${reply.date || "no date"}.`)];
    parts.push(el("p", {}, differ.length
      ? `${differ.length} parameter(s) differ.`
      : `Drive ${address} holds the values of ${file.name}.`));
    if (differ.length) {
      parts.push(el("div", { class: "scroll" }, el("table", { class: "diff" },
        el("thead", {}, el("tr", {}, el("th", {}, "No."), el("th", {}, "Name"),
          el("th", {}, `Drive ${address}`), el("th", {}, `File`))),
        el("tbody", {}, ...differ.map((d) => el("tr", { dataset: { id: d.id } },
          el("td", {}, d.label), el("td", {}, d.name ?? ""),
          el("td", {}, d.drive ?? "(not there)"), el("td", { class: "changed" }, d.file ?? "(not there)")))))));
    }
    if (reply.skipped.length) {
      parts.push(el("p", { class: "note" }, "Not written by a restore: " +
        reply.skipped.map((s) => `${s.label} (${s.reason})`).join("; ") + "."));
    }
    if (reply.stranger) parts.push(el("p", { class: "warn" }, reply.stranger + "."));
    if (reply.refused) {
      parts.push(el("p", { class: "error" }, `This file cannot be restored: ${reply.refused}`));
    } else if (reply.writes.length && !this.state.config.read_only) {
      const eeprom = el("input", { type: "checkbox", id: "restore-eeprom" });
      const go = el("button", { class: "go", type: "button", id: "restore-start" },
        `Restore ${reply.writes.length} parameter(s) to drive ${address} …`);
      go.addEventListener("click", () => this.restore(address, file, reply, eeprom.checked));
      parts.push(el("div", { class: "row writes" }, go,
        el("label", {}, eeprom, " also store in EEPROM")));
    }
    this.box.hidden = false;
    this.box.replaceChildren(...parts);
  }

  async restore(address, file, reply, eeprom) {
    const lines = reply.writes.map((w) => w.change).join("\n");
    const question = `Write ${reply.writes.length} parameter(s) from ${file.name} to drive ${address}` +
      `${eeprom ? " and store them in EEPROM" : ""}?\n\n${lines}` +
      (reply.stranger ? `\n\nCareful: ${reply.stranger}.` : "");
    if (!(await confirmMove(question, "Yes, write"))) {
      this.note.textContent = "Nothing written.";
      return;
    }
    // The yes carries the comparison's "confirm": the server writes exactly the writes asked
    // about, or nothing (the drive changed since: compare again).
    const query = `name=${encodeURIComponent(file.name)}${reply.stranger ? "&force=1" : ""}` +
      `${eeprom ? "&eeprom=1" : ""}&confirm=${encodeURIComponent(reply.confirm)}`;
    await this.job("Restore", async () => {
      try {
        const done = await upload(`/api/drive/${address}/restore?${query}`, file);
        this.showResults(done);
      } catch (e) {
        this.note.textContent = "";
        this.showError(`Restore: ${e.message}`);
      }
    });
    await this.readAll();
  }

  showResults(done) {
    const items = done.results.map((r) => el("li", { class: r.ok ? "ok" : "refused", dataset: { id: r.id } },
      r.ok ? `${r.change}: written` : `${r.change}: refused: ${r.error}`));
    this.box.hidden = false;
    this.box.replaceChildren(el("h3", {}, "Restore"), el("p", { id: "restore-summary" }, done.message),
      el("ul", { class: "results" }, ...items));
  }
}
