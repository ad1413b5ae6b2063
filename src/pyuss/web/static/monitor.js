// Monitor view: the decoded telegrams live, with filter and pause.
import { el, withToken } from "./api.js";

const KEEP = 2000;   // telegrams kept in the page
const SHOW = 500;    // telegrams shown at once

export class MonitorView {
  constructor(state) {
    this.state = state;
    this.items = [];
    this.seen = 0;
    this.paused = false;
    this.list = document.getElementById("mon-list");
    this.filter = document.getElementById("mon-filter");
    this.errors = document.getElementById("mon-errors");
    this.count = document.getElementById("mon-count");
    this.filter.addEventListener("input", () => this.render());
    this.errors.addEventListener("change", () => this.render());
    document.getElementById("mon-pause").addEventListener("click", (e) => {
      this.paused = !this.paused;
      e.target.textContent = this.paused ? "Resume" : "Pause";
      if (!this.paused) this.render();
    });
    document.getElementById("mon-clear").addEventListener("click", () => {
      this.items = [];
      this.render();
    });
    document.getElementById("mon-pcapng").href = withToken("/api/monitor.pcapng");
  }

  shown(visible) { this.visible = visible; if (visible) this.render(); }

  message(message) {
    if (message.type !== "telegrams") return;
    if (this.paused) return;
    for (const item of message.items) {
      if (item.seq <= this.seen) continue;
      this.seen = item.seq;
      this.items.push(item);
    }
    if (this.items.length > KEEP) this.items.splice(0, this.items.length - KEEP);
    if (message.left_out) this.leftOut = (this.leftOut || 0) + message.left_out;
    this.render();
  }

  wanted(item, words, errorsOnly) {
    if (errorsOnly && !item.problems.length) return false;
    if (!words.length) return true;
    const text = item.line.toLowerCase();
    return words.every((w) => text.includes(w));
  }

  render() {
    if (!this.visible || this.paused) return;
    if (this.frame) return;
    this.frame = requestAnimationFrame(() => {
      this.frame = null;
      const words = this.filter.value.trim().toLowerCase().split(/\s{2,}|,\s*/).filter(Boolean);
      const chosen = this.items.filter((i) => this.wanted(i, words, this.errors.checked));
      const shown = chosen.slice(-SHOW);
      const atBottom = this.list.scrollTop + this.list.clientHeight >= this.list.scrollHeight - 4;
      this.list.replaceChildren(...shown.map((i) =>
        el("div", { class: i.problems.length ? "bad" : "" }, i.line)));
      if (atBottom) this.list.scrollTop = this.list.scrollHeight;
      const left = this.leftOut ? `, ${this.leftOut} left out (too many for the page)` : "";
      this.count.textContent = `${shown.length} of ${this.items.length} telegrams shown${left}`;
    });
  }
}
