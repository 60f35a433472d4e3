// Drive page: keyboard → a worker that ramps {steer, throttle} and sends it at 50 Hz over the race's drive
// websocket; the live 3D view beside it; the server's messages shown in the panel.
"use strict";

const KEYS = {
  ArrowUp: "up", KeyW: "up", ArrowDown: "down", KeyS: "down",
  ArrowLeft: "left", KeyA: "left", ArrowRight: "right", KeyD: "right",
};

const match = location.pathname.match(/^\/races\/([^/]+)\/drive\/?$/);
const raceId = match ? decodeURIComponent(match[1]) : "";
const params = new URLSearchParams(location.search);
const kart = params.get("kart");
const token = params.get("token");
const kartIndex = Number.isInteger(Number(kart)) ? Number(kart) : 0;

const pressed = new Set();
const input = {steer: 0, throttle: 0, seq: 0};
const worker = new Worker("/assets/drive-worker.js");

function $(id) { return document.getElementById(id); }

function log(text, kind) {
  const list = $("log");
  const stamp = new Date().toLocaleTimeString();
  list.prepend(el("li", {class: kind || ""}, `${stamp} ${text}`));
  while (list.children.length > 60) list.lastChild.remove();
}

function setConn(state, text) {
  const conn = $("conn");
  conn.className = `conn ${state}`;
  conn.textContent = text;
  $("reconnect").hidden = state !== "closed";
}

// ------------------------------------------------------------------ keyboard
function sendKeys() { worker.postMessage({cmd: "keys", pressed: [...pressed]}); }

function onKey(event) {
  const action = KEYS[event.code] || KEYS[event.key];
  if (!action) return;
  const had = pressed.has(action);
  if (event.type === "keydown") pressed.add(action); else pressed.delete(action);
  if (had !== pressed.has(action)) sendKeys();
  event.preventDefault();
  event.stopImmediatePropagation(); // the 3D view would also move its camera with these keys
}

function releaseAll() {
  if (pressed.size) { pressed.clear(); sendKeys(); }
}

function attachKeys(target) {
  target.addEventListener("keydown", onKey, true);
  target.addEventListener("keyup", onKey, true);
  target.addEventListener("blur", releaseAll);
}

function showInput() {
  const bar = (id, value, leftward) => {
    const fill = $(id);
    const width = Math.abs(value) * 50;
    fill.style.width = `${width}%`;
    fill.style.left = leftward ? `${50 - width}%` : "50%";
    fill.style.background = id === "throttle-bar" && value < 0 ? "var(--bad)" : "var(--accent)";
  };
  bar("steer-bar", input.steer, input.steer > 0); // steer > 0 is left: drawn left of the middle
  bar("throttle-bar", input.throttle, input.throttle < 0);
}

// ------------------------------------------------------------------ server messages
function pick(objects, keys) {
  for (const object of objects) {
    if (!object || typeof object !== "object") continue;
    for (const key of keys) if (object[key] !== undefined && object[key] !== null) return object[key];
  }
  return undefined;
}

function ownKart(message) {
  for (const c of [message.kart, message.you, message.self]) if (c && typeof c === "object") return c;
  const karts = message.karts || (message.frame && message.frame.karts);
  if (Array.isArray(karts)) {
    return karts.find((k) => k && (k.index === kartIndex || k.kart === kartIndex)) || karts[kartIndex];
  }
  return null;
}

function showState(message) {
  const mine = ownKart(message);
  const sources = [mine, message, message.frame];
  const speed = pick(sources, ["speed", "speed_mps", "v"]);
  if (typeof speed === "number") $("speed").textContent = `${(speed * 3.6).toFixed(0)} km/h (${speed.toFixed(1)} m/s)`;
  const lap = pick(sources, ["lap", "current_lap"]);
  const laps = pick([message, message.frame], ["laps", "total_laps"]);
  if (lap !== undefined) $("lap").textContent = laps !== undefined ? `${lap} / ${laps}` : String(lap);
  const position = pick([mine, message], ["position", "place", "rank"]);
  if (position !== undefined) $("position").textContent = String(position);
  const status = pick([message, message.frame, message.race], ["status", "race_status"]);
  if (status !== undefined) $("race-status").textContent = String(status);
  const time = pick([message, message.frame], ["time", "race_time"]);
  if (typeof time === "number") $("race-time").textContent = `${time.toFixed(1)} s`;
  if (mine && mine.name) $("kart-name").textContent = mine.name;
  if (mine && mine.finished) {
    $("lap").textContent = "finished" + (typeof mine.finish_time === "number" ? ` in ${mine.finish_time.toFixed(2)} s` : "");
  }
  if (typeof message.braking === "boolean") $("braking").hidden = !message.braking;
}

function onServerMessage(data) {
  let message;
  try { message = JSON.parse(data); } catch (_) { log(String(data)); return; }
  if (!message || typeof message !== "object") { log(String(message)); return; }
  const type = String(message.type || message.kind || "");
  if (message.error !== undefined || /error|reject|invalid/i.test(type)) {
    const problem = message.error !== undefined ? message.error : message.detail;
    log(typeof problem === "string" ? problem : describeError(0, message), "error");
    return;
  }
  if (type === "end" || type === "result") {
    const result = message.result && typeof message.result === "object" ? message.result : null;
    const winner = result && result.winner !== undefined && result.winner !== null ? `, winner: kart ${Number(result.winner) + 1}` : "";
    log(`race over (${message.status || "finished"})${winner}`);
  }
  const text = message.message || message.text || message.detail;
  if (typeof text === "string" && text) log(type ? `${type}: ${text}` : text);
  else if (/^(info|notice|event|start|started|waiting|countdown|hello|welcome|ready)$/i.test(type)) log(type);
  showState(message);
}

worker.onmessage = (event) => {
  const m = event.data || {};
  if (m.kind === "input") {
    Object.assign(input, m);
    showInput();
  } else if (m.kind === "open") {
    setConn("open", "connected: driving");
    log("connected");
  } else if (m.kind === "message") {
    onServerMessage(m.data);
  } else if (m.kind === "error") {
    log("connection error", "error");
  } else if (m.kind === "close") {
    const reason = m.reason ? `: ${m.reason}` : "";
    setConn("closed", `closed (${m.code}${reason})`);
    log(`connection closed, code ${m.code}${reason}`, m.code === 1000 ? "" : "error");
  }
};

// ------------------------------------------------------------------ connection
function connect() {
  if (!raceId || kart === null || !token) {
    setConn("closed", "no kart or token in the link");
    log("This page needs a link of the form /races/ID/drive?kart=K&token=T (shown when the race is created).", "error");
    $("reconnect").hidden = true;
    return;
  }
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const url = `${scheme}://${location.host}/api/races/${encodeURIComponent(raceId)}/drive?kart=${encodeURIComponent(kart)}&token=${encodeURIComponent(token)}`;
  setConn("connecting", "connecting…");
  worker.postMessage({cmd: "connect", url});
}

function init() {
  $("title").textContent = `race ${raceId} · kart ${kart !== null ? kartIndex + 1 : "?"}`;
  $("kart-swatch").style.background = kartColor(kartIndex);
  $("kart-name").textContent = `kart ${kartIndex + 1}`;
  const frame = $("viewer");
  frame.src = `/races/${encodeURIComponent(raceId)}/viewer/`;
  attachKeys(window);
  frame.addEventListener("load", () => {
    try { attachKeys(frame.contentWindow); } catch (_) { /* not same-origin: keys work when the panel has focus */ }
  });
  window.addEventListener("blur", () => {
    // focus moved into the (same-origin) viewer keeps driving; elsewhere release the keys
    setTimeout(() => {
      const inViewer = document.activeElement === frame;
      if (!inViewer) releaseAll();
      $("focus-hint").hidden = inViewer || document.hasFocus();
    }, 0);
  });
  window.addEventListener("focus", () => { $("focus-hint").hidden = true; });
  window.addEventListener("pagehide", () => worker.postMessage({cmd: "close"}));
  $("focus-hint").addEventListener("click", () => $("panel").focus());
  $("reconnect").addEventListener("click", connect);
  document.addEventListener("visibilitychange", () => { if (document.hidden) releaseAll(); });
  connect();
  $("panel").focus();
}

init();
