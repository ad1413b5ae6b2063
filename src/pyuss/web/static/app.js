// The page: one live connection, four views (bus, drive, parameters, monitor).
import { get, setStart, socketUrl } from "./api.js";
import { BusView } from "./bus.js";
import { DriveView } from "./drive.js";
import { ParamsView } from "./params.js";
import { MonitorView } from "./monitor.js";

const state = {
  config: { read_only: false, moves: [] },
  bus: null,
  address: null,        // the drive the drive and parameter views show
  view: "bus",
  socket: null,
};

const views = {};
const select = document.getElementById("drive-select");
const link = document.getElementById("link");

// A drive's key: its address on the page's own line, BUS.ADDRESS in a plant (--mqtt).
function keyOf(value) {
  return state.config.plant ? String(value) : Number(value);
}

function setAddress(address) {
  if (address === state.address) return;
  state.address = address;
  select.value = address == null ? "" : String(address);
  for (const view of Object.values(views)) view.driveChanged?.(address);
  showReadOnly();
}

// Read-only: the whole page (--read-only), or in a plant the drives of a gateway whose
// MQTT face takes reads only; the badge says which.
function showReadOnly() {
  const d = state.bus && state.bus.drives.find((x) => x.address === state.address);
  const gateway = Boolean(d && d.read_only) && !state.config.read_only;
  const readOnly = state.config.read_only || gateway;
  document.body.classList.toggle("read-only", readOnly);
  const badge = document.getElementById("ro-badge");
  badge.hidden = !readOnly;
  badge.textContent = gateway ? `read-only: gateway ${d.bus} takes no commands` : "read-only";
}

function fillDrives(bus) {
  const addresses = bus.drives.map((d) => d.address);
  const shown = [...select.options].map((o) => keyOf(o.value));
  if (addresses.join() !== shown.join()) {
    select.replaceChildren(...bus.drives.map((d) => {
      const option = document.createElement("option");
      option.value = d.address;
      option.textContent = d.name ? `${d.address} ${d.name} (${d.profile})` : `${d.address} (${d.profile})`;
      return option;
    }));
  }
  if (!addresses.includes(state.address)) setAddress(addresses.length ? addresses[0] : null);
  else select.value = String(state.address);
}

function route() {
  const [name, arg] = (location.hash.slice(1) || "bus").split("/");
  const view = views[name] ? name : "bus";
  if (arg !== undefined && arg !== "" && state.config.plant) setAddress(decodeURIComponent(arg));
  else if (arg !== undefined && arg !== "" && !Number.isNaN(Number(arg))) setAddress(Number(arg));
  state.view = view;
  for (const key of Object.keys(views)) {
    document.getElementById(`view-${key}`).hidden = key !== view;
  }
  for (const a of document.querySelectorAll("nav a")) {
    a.classList.toggle("active", a.dataset.view === view);
  }
  for (const [key, v] of Object.entries(views)) v.shown?.(key === view);
  sendWanted();
}

function sendWanted() {
  const socket = state.socket;
  if (socket && socket.readyState === WebSocket.OPEN) {
    socket.send(JSON.stringify({ monitor: state.view === "monitor" }));
  }
}

function connect() {
  const socket = new WebSocket(socketUrl());
  state.socket = socket;
  socket.addEventListener("open", () => {
    link.textContent = "live";
    link.className = "link up";
    sendWanted();
  });
  socket.addEventListener("message", (event) => {
    const message = JSON.parse(event.data);
    if (message.type === "bus") {
      state.bus = message.bus;
      fillDrives(message.bus);
      showReadOnly();
    }
    for (const view of Object.values(views)) view.message?.(message);
  });
  socket.addEventListener("close", () => {
    link.textContent = "offline";
    link.className = "link down";
    state.socket = null;
    setTimeout(connect, 1000);
  });
}

async function main() {
  state.config = await get("/api/config");
  setStart(state.config.start);
  document.body.classList.toggle("read-only", state.config.read_only);
  document.body.classList.toggle("plant", Boolean(state.config.plant));
  document.getElementById("ro-badge").hidden = !state.config.read_only;
  views.bus = new BusView(state);
  views.drive = new DriveView(state);
  views.params = new ParamsView(state);
  views.monitor = new MonitorView(state);
  select.addEventListener("change", () => {
    setAddress(keyOf(select.value));
  });
  const bus = await get("/api/bus");
  state.bus = bus;
  fillDrives(bus);
  showReadOnly();
  views.bus.message({ type: "bus", bus });
  window.addEventListener("hashchange", route);
  route();
  connect();
  state.views = views;
  window.pyuss = state;  // for scripts and tests: the page's state
}

main();
