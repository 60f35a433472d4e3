// Drive page: keyboard → ramped {steer, throttle} at 50 Hz over the race's drive websocket, live view beside it.
"use strict";

const SEND_PERIOD_MS = 20; // 50 Hz
const STEER_RATE = 3.0; // [1/s] steer ramp towards the pressed direction
const STEER_RETURN_RATE = 5.0; // [1/s] back to centre when released
const THROTTLE_RATE = 2.5; // [1/s]
const BRAKE_RATE = 6.0; // [1/s]
const RELEASE_RATE = 4.0; // [1/s] throttle back to 0 when released
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
const input = {steer: 0, throttle: 0};
let socket = null;
let lastTick = performance.now();

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
function onKey(event) {
  const action = KEYS[event.code] || KEYS[event.key];
  if (!action) return;
  if (event.type === "keydown") pressed.add(action); else pressed.delete(action);
  event.preventDefault();
  event.stopImmediatePropagation(); // the 3D view would also move its camera with these keys
}

function releaseAll() { pressed.clear(); }

function attachKeys(target) {
  target.addEventListener("keydown", onKey, true);
  target.addEventListener("keyup", onKey, true);
  target.addEventListener("blur", releaseAll);
}

function approach(value, target, rate, dt) {
  const step = rate * dt;
  return Math.abs(target - value) <= step ? target : value + Math.sign(target - value) * step;
}

function ramp(dt) {
  const steerTarget = (pressed.has("left") ? 1 : 0) - (pressed.has("right") ? 1 : 0); // steer > 0 = left
  const steerRate = steerTarget === 0 || Math.sign(steerTarget) !== Math.sign(input.steer) && input.steer !== 0
    ? STEER_RETURN_RATE : STEER_RATE;
  input.steer = approach(input.steer, steerTarget, steerRate, dt);
  const throttleTarget = (pressed.has("up") ? 1 : 0) - (pressed.has("down") ? 1 : 0);
  let rate = RELEASE_RATE;
  if (throttleTarget > 0) rate = THROTTLE_RATE;
  else if (throttleTarget < 0) rate = BRAKE_RATE;
  input.throttle = approach(input.throttle, throttleTarget, rate, dt);
}

function showInput() {
  const bar = (id, value) => {
    const fill = $(id);
    const width = Math.abs(value) * 50;
    fill.style.width = `${width}%`;
    // steer > 0 is left: draw it to the left of the middle
    const leftward = id === "steer-bar" ? value > 0 : value < 0;
    fill.style.left = leftward ? `${50 - width}%` : "50%";
    fill.style.background = id === "throttle-bar" && value < 0 ? "var(--bad)" : "var(--accent)";
  };
  bar("steer-bar", input.steer);
  bar("throttle-bar", input.throttle);
}

function tick() {
  const now = performance.now();
  const dt = Math.min((now - lastTick) / 1000, 0.1);
  lastTick = now;
  ramp(dt);
  showInput();
  if (socket && socket.readyState === WebSocket.OPEN) {
    socket.send(JSON.stringify({steer: Number(input.steer.toFixed(3)), throttle: Number(input.throttle.toFixed(3))}));
  }
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
  const candidates = [message.kart, message.you, message.self, message.state];
  for (const c of candidates) if (c && typeof c === "object") return c;
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
  const time = pick([message, message.frame], ["time", "race_time", "t"]);
  if (typeof time === "number") $("race-time").textContent = `${time.toFixed(1)} s`;
  if (mine && mine.name) $("kart-name").textContent = mine.name;
  if (mine && mine.finished) $("lap").textContent = "finished" + (typeof mine.finish_time === "number" ? ` in ${mine.finish_time.toFixed(2)} s` : "");
}

function onMessage(event) {
  let message;
  try { message = JSON.parse(event.data); } catch (_) { log(String(event.data)); return; }
  if (!message || typeof message !== "object") { log(String(message)); return; }
  const type = String(message.type || message.kind || "");
  if (message.error !== undefined || /error|reject|invalid/i.test(type)) {
    const problem = message.error !== undefined ? message.error : message.detail;
    log(typeof problem === "string" ? problem : describeError(0, message), "error");
    return;
  }
  const text = message.message || message.text || message.detail;
  if (typeof text === "string" && text) log(type ? `${type}: ${text}` : text);
  else if (/^(info|notice|event|start|started|finish|finished|waiting|countdown|hello|welcome|ready)$/i.test(type)) log(type);
  showState(message);
}

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
  socket = new WebSocket(url);
  socket.addEventListener("open", () => { setConn("open", "connected: driving"); log("connected"); });
  socket.addEventListener("message", onMessage);
  socket.addEventListener("close", (event) => {
    const reason = event.reason ? `: ${event.reason}` : "";
    setConn("closed", `closed (${event.code}${reason})`);
    log(`connection closed, code ${event.code}${reason}`, event.code === 1000 ? "" : "error");
    socket = null;
  });
  socket.addEventListener("error", () => log("connection error", "error"));
}

function init() {
  $("title").textContent = `race ${raceId} · kart ${kart !== null ? Number(kart) + 1 : "?"}`;
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
  $("focus-hint").addEventListener("click", () => $("panel").focus());
  $("reconnect").addEventListener("click", connect);
  document.addEventListener("visibilitychange", () => { if (document.hidden) releaseAll(); });
  connect();
  setInterval(tick, SEND_PERIOD_MS);
  $("panel").focus();
}

init();
