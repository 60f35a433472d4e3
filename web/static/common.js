// Shared helpers of the pages (no framework, no external requests).
"use strict";

// One colour per grid slot, as web/frame.py KART_COLORS.
const KART_COLORS = [
  [230, 57, 70], [29, 114, 243], [255, 183, 3], [42, 157, 143],
  [155, 93, 229], [244, 132, 95], [96, 108, 56], [33, 33, 33],
];

// One colour per team, in the order the teams first stand on the grid, as web/frame.py TEAM_COLORS.
const TEAM_COLORS = [[255, 204, 0], [0, 180, 216], [214, 40, 160], [110, 190, 40]];

// Each team of karts (objects with .team, by grid slot) and its colour, as web/frame.py team_colors.
function teamColors(karts) {
  const colors = new Map();
  for (const kart of karts || []) {
    if (kart.team === null || kart.team === undefined || colors.has(kart.team)) continue;
    const c = TEAM_COLORS[colors.size % TEAM_COLORS.length];
    colors.set(kart.team, `rgb(${c[0]}, ${c[1]}, ${c[2]})`);
  }
  return colors;
}

// A kart's team in its colour's box (the roof plate's colour in the 3D view); null for a kart racing for itself.
function teamBadge(karts, team) {
  if (team === null || team === undefined) return null;
  return el("span", {class: "team", "data-team": team, style: `border-color: ${teamColors(karts).get(team)}`}, team);
}

function kartColor(i) {
  const c = KART_COLORS[((i % KART_COLORS.length) + KART_COLORS.length) % KART_COLORS.length];
  return `rgb(${c[0]}, ${c[1]}, ${c[2]})`;
}

// Build an element: el("a", {href: "/x", class: "y"}, "text", child, ...).
function el(tag, attrs, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs || {})) {
    if (value === undefined || value === null || value === false) continue;
    if (key === "class") node.className = value;
    else if (key.startsWith("on") && typeof value === "function") node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value === true ? "" : String(value));
  }
  for (const child of children.flat()) {
    if (child === undefined || child === null || child === false) continue;
    node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return node;
}

// A kart's label: its name, with its controller in brackets unless the name already says it (as web/frame.py).
function kartLabel(name, controller) {
  return !controller || String(name).includes(controller) ? String(name) : `${name} (${controller})`;
}

// "1 lap", "3 laps".
function plural(count, noun) {
  return `${count} ${noun}${count === 1 ? "" : "s"}`;
}

function swatch(i) {
  return el("span", {class: "swatch", style: `background: ${kartColor(i)}`});
}

// A readable message from an error response body (FastAPI 422 details included).
function describeError(status, body) {
  if (body && typeof body === "object") {
    const detail = body.detail !== undefined ? body.detail : body.error !== undefined ? body.error : body.message;
    if (Array.isArray(detail)) {
      return detail.map((d) => {
        if (d && typeof d === "object") {
          const loc = Array.isArray(d.loc) ? d.loc.filter((p) => p !== "body").join(" → ") : "";
          return (loc ? loc + ": " : "") + (d.msg || JSON.stringify(d));
        }
        return String(d);
      }).join("\n");
    }
    if (detail && typeof detail === "object") return JSON.stringify(detail);
    if (detail !== undefined) return String(detail);
    return JSON.stringify(body);
  }
  return body ? String(body) : `HTTP ${status}`;
}

// fetch JSON; throws Error(message) with the server's explanation on failure.
async function fetchJSON(url, options) {
  const response = await fetch(url, Object.assign({headers: {"Accept": "application/json"}}, options || {}));
  const text = await response.text();
  let body = null;
  try { body = text ? JSON.parse(text) : null; } catch (_) { body = text; }
  if (!response.ok) {
    const error = new Error(`${response.status}: ${describeError(response.status, body)}`);
    error.status = response.status;
    error.body = body;
    throw error;
  }
  return body;
}

// The list inside a response that is either a list or an object holding one ({races: [...]}, {items: [...]}).
function listOf(body, key) {
  if (Array.isArray(body)) return body;
  if (body && typeof body === "object") {
    for (const k of [key, "items", "data", "results"]) if (Array.isArray(body[k])) return body[k];
  }
  return [];
}

function fmtNumber(value, digits) {
  return typeof value === "number" && isFinite(value) ? value.toFixed(digits) : "–";
}
