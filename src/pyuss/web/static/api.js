// Requests to the page's server. The token (when the server needs one) comes in the URL the
// server printed; the server keeps it in a cookie as well, this sends it in a header too.
const token = new URLSearchParams(location.search).get("token");

// The start of the server this page was loaded from (/api/config): every change carries
// it, so a page left open while uss web was started again (perhaps on another line) changes
// nothing; the server says to reload it.
let start = null;

export function setStart(id) { start = id; }

function headers(extra = {}) {
  const h = { "X-Pyuss": "1", ...extra };
  if (token) h["X-Pyuss-Token"] = token;
  if (start) h["X-Pyuss-Start"] = start;
  return h;
}

export class ApiError extends Error {
  constructor(message, body) { super(message); this.body = body; }
}

async function handle(response) {
  let body = null;
  try { body = await response.json(); } catch { body = null; }
  if (!response.ok) {
    const message = body && body.error ? body.error : `${response.status} ${response.statusText}`;
    throw new ApiError(message, body);
  }
  return body;
}

export async function get(path) {
  return handle(await fetch(path, { headers: headers() }));
}

export async function post(path, data) {
  return handle(await fetch(path, {
    method: "POST",
    headers: headers({ "Content-Type": "application/json" }),
    body: JSON.stringify(data ?? {}),
  }));
}

export async function upload(path, file) {
  return handle(await fetch(path, {
    method: "POST",
    headers: headers({ "Content-Type": "application/octet-stream" }),
    body: file,
  }));
}

// A file the server sends (a backup): its name from Content-Disposition and its content.
export async function fetchFile(path) {
  const response = await fetch(path, { headers: headers() });
  if (!response.ok) await handle(response);
  const match = /filename="([^"]+)"/.exec(response.headers.get("Content-Disposition") || "");
  return { name: match ? match[1] : "download", blob: await response.blob() };
}

export function saveBlob(name, blob) {
  const link = document.createElement("a");
  link.href = URL.createObjectURL(blob);
  link.download = name;
  document.body.append(link);
  link.click();
  setTimeout(() => { URL.revokeObjectURL(link.href); link.remove(); }, 1000);
}

export function withToken(path) {
  return token ? `${path}${path.includes("?") ? "&" : "?"}token=${encodeURIComponent(token)}` : path;
}

export function socketUrl() {
  const scheme = location.protocol === "https:" ? "wss:" : "ws:";
  return withToken(`${scheme}//${location.host}/ws`);
}

export function download(name, text, type = "text/csv") {
  saveBlob(name, new Blob([text], { type }));
}

export function hex4(word) {
  return word == null ? "----" : word.toString(16).toUpperCase().padStart(4, "0") + "h";
}

export function el(tag, props = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(props)) {
    if (key === "class") node.className = value;
    else if (key === "dataset") Object.assign(node.dataset, value);
    else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value);
  }
  for (const child of children) node.append(child instanceof Node ? child : String(child ?? ""));
  return node;
}

// Ask before anything that can set a motor turning (or writes a whole parameter set);
// resolves true for "yes".
export function confirmMove(text, yes = "Yes, go") {
  const dialog = document.getElementById("confirm");
  document.getElementById("confirm-text").textContent = text;
  document.getElementById("confirm-yes").textContent = yes;
  return new Promise((resolve) => {
    dialog.addEventListener("close", () => resolve(dialog.returnValue === "yes"), { once: true });
    dialog.returnValue = "";
    dialog.showModal();
  });
}
