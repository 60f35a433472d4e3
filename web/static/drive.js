// Drive page: keyboard and gamepad → a worker that sends {steer, throttle} at 50 Hz over the race's drive
// websocket; the live 3D view beside it, chasing this kart; the server's state, countdown and events on screen;
// at the end, this driver's result and a "race again" button.
//
// The race waits for this page's 3D view: the page connects with view=1 and says {"type": "ready"} once the
// view shows its kart (server/routes/drive.py), or after VIEW_GIVE_UP_MS if it never does.
"use strict";

const KEYS = {
  ArrowUp: "up", KeyW: "up", ArrowDown: "down", KeyS: "down",
  ArrowLeft: "left", KeyA: "left", ArrowRight: "right", KeyD: "right",
};
const VIEW_POLL_MS = 250;
const VIEW_GIVE_UP_MS = 25000; // the server waits a little longer (view_ready_wait_s), then starts anyway
const PAD_POLL_MS = 20;
const STICK_DEADZONE = 0.15; // of the stick's travel: no steer inside it
const TRIGGER_DEADZONE = 0.05;
const TOAST_MS = 2600;
const OVER = new Set(["finished", "stopped", "aborted"]);

const match = location.pathname.match(/^\/races\/([^/]+)\/drive\/?$/);
const raceId = match ? decodeURIComponent(match[1]) : "";
const params = new URLSearchParams(location.search);
const kart = params.get("kart");
const token = params.get("token");
const kartIndex = Number.isInteger(Number(kart)) ? Number(kart) : 0;

const pressed = new Set();
const input = {steer: 0, throttle: 0, seq: 0};
const pad = {active: false, steer: 0, throttle: 0, id: ""};
const worker = new Worker("/assets/drive-worker.js");
let race = null; // GET /api/races/{id}, for names and "race again"
let viewReady = false;
let ended = false;
let lastStatus = "";

function $(id) { return document.getElementById(id); }

function log(text, kind) {
  const list = $("log");
  const stamp = new Date().toLocaleTimeString();
  list.prepend(el("li", {class: kind || ""}, `${stamp} ${text}`));
  while (list.children.length > 60) list.lastChild.remove();
}

function toast(text, kind) {
  const item = el("li", {class: `toast ${kind || ""}`, "data-kind": kind || ""}, text);
  $("toasts").append(item);
  setTimeout(() => item.remove(), TOAST_MS);
}

function setConn(state, text) {
  const conn = $("conn");
  conn.className = `conn ${state}`;
  conn.textContent = text;
  $("reconnect").hidden = state !== "closed" || ended;
}

function kartName(index) {
  const karts = race && Array.isArray(race.karts) ? race.karts : [];
  const found = karts.find((k) => k.index === index);
  return found ? found.name : `kart ${index + 1}`;
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

// ------------------------------------------------------------------ gamepad (the browser's Gamepad API)
function deadzone(value, zone) {
  const v = Number(value) || 0;
  return Math.abs(v) <= zone ? 0 : Math.sign(v) * (Math.abs(v) - zone) / (1 - zone);
}

function buttonValue(button) {
  if (button === undefined || button === null) return 0;
  return typeof button === "object" ? Number(button.value) || (button.pressed ? 1 : 0) : Number(button) || 0;
}

// Standard mapping: axes[0] = left stick x (-1 left), buttons[6] / [7] = left / right trigger (0..1).
// Pads without triggers use the left stick's y for the pedals (up = throttle).
function readPad() {
  const pads = navigator.getGamepads ? Array.from(navigator.getGamepads() || []) : [];
  const found = pads.find((p) => p && p.connected !== false);
  if (!found) {
    if (pad.active) {
      Object.assign(pad, {active: false, steer: 0, throttle: 0, id: ""});
      worker.postMessage({cmd: "pad", active: false, steer: 0, throttle: 0});
      $("input-source").textContent = "keyboard";
      log("gamepad disconnected");
    }
    return;
  }
  const axes = found.axes || [];
  const buttons = found.buttons || [];
  const steer = -deadzone(axes[0], STICK_DEADZONE); // steer > 0 is left
  const throttle = buttons.length > 7
    ? deadzone(buttonValue(buttons[7]), TRIGGER_DEADZONE) - deadzone(buttonValue(buttons[6]), TRIGGER_DEADZONE)
    : -deadzone(axes[1], STICK_DEADZONE);
  if (!pad.active) {
    pad.id = String(found.id || "gamepad");
    $("input-source").textContent = `keyboard + gamepad`;
    log(`gamepad connected: ${pad.id}`);
  }
  if (!pad.active || steer !== pad.steer || throttle !== pad.throttle) {
    Object.assign(pad, {active: true, steer, throttle});
    worker.postMessage({cmd: "pad", active: true, steer, throttle});
  }
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

// ------------------------------------------------------------------ the 3D view
function viewerUrl() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const socket = `${scheme}://${location.host}/races/${encodeURIComponent(raceId)}/viewer?follow=${kartIndex}`;
  // viser's page takes its websocket from ?websocket=; the query asks the scene to chase this kart
  return `/races/${encodeURIComponent(raceId)}/viewer/?websocket=${encodeURIComponent(socket)}`;
}

function viewShowsKart(frame) {
  let mutable;
  try { mutable = frame.contentWindow && frame.contentWindow.__viserMutable; } catch (_) { return false; }
  if (!mutable || !mutable.nodeRefFromName) return false;
  const shown = mutable.nodeRefFromName[`/karts/kart${kartIndex}`];
  const canvas = mutable.canvas; // viser keeps it nearly transparent while an environment map loads
  return Boolean(shown) && (!canvas || ["", "1"].includes(canvas.style.opacity));
}

function setViewReady(why) {
  if (viewReady) return;
  viewReady = true;
  worker.postMessage({cmd: "ready"});
  log(why);
}

function watchView(frame) {
  const started = Date.now();
  const poll = () => {
    if (viewReady) return;
    if (viewShowsKart(frame)) setViewReady("3D view ready");
    else if (Date.now() - started > VIEW_GIVE_UP_MS) setViewReady("3D view still loading: ready anyway");
    else setTimeout(poll, VIEW_POLL_MS);
  };
  poll();
}

// ------------------------------------------------------------------ server messages
function showBanner(text, count) {
  $("grid-banner").hidden = !text && count === undefined;
  $("banner-text").textContent = text || "";
  $("countdown").hidden = count === undefined;
  if (count !== undefined) $("countdown").textContent = String(count);
}

function showState(message) {
  const mine = message.kart || {};
  const status = String(message.status || "");
  $("race-status").textContent = status;
  if (typeof message.time === "number") $("race-time").textContent = `${message.time.toFixed(1)} s`;
  if (mine.name) $("kart-name").textContent = mine.name;
  if (mine.finished) {
    $("speed").textContent = "–";
    $("lap").textContent = "finished" + (typeof mine.finish_time === "number" ? ` in ${mine.finish_time.toFixed(2)} s` : "");
  } else {
    if (typeof mine.speed === "number") $("speed").textContent = `${(mine.speed * 3.6).toFixed(0)} km/h`;
    const laps = race && race.laps;
    if (mine.lap !== undefined) $("lap").textContent = laps ? `${mine.lap} / ${laps}` : String(mine.lap);
  }
  if (mine.position !== undefined) $("position").textContent = `${mine.position} of ${race ? race.karts.length : "?"}`;
  $("braking").hidden = !(message.braking && status === "running" && !mine.finished);

  if (status === "countdown" && typeof message.countdown === "number") {
    showBanner("Get ready", Math.max(1, Math.ceil(message.countdown)));
  } else if (status === "waiting" || status === "starting") {
    const waiting = Array.isArray(message.waiting_for) ? message.waiting_for : [];
    const others = waiting.filter((name) => name !== mine.name);
    let text = "Starting the race…";
    if (!viewReady) text = "Loading your 3D view…";
    else if (others.length) text = `Waiting for ${others.join(", ")}`;
    showBanner(text);
  } else if (status !== lastStatus) {
    showBanner("");
  }
  lastStatus = status;
}

function onServerMessage(data) {
  let message;
  try { message = JSON.parse(data); } catch (_) { log(String(data)); return; }
  if (!message || typeof message !== "object") return;
  if (message.type === "error") {
    log(typeof message.error === "string" ? message.error : describeError(0, message), "error");
  } else if (message.type === "event") {
    toast(message.text, message.kind);
    log(message.text, message.kind === "wall_hit" || message.kind === "collision_at_fault" ? "error" : "");
  } else if (message.type === "end") {
    showEnd(message.status, message.result);
  } else if (message.type === "state") {
    showState(message);
  }
}

// ------------------------------------------------------------------ the end
function fmtTime(seconds) { return typeof seconds === "number" ? `${seconds.toFixed(2)} s` : "–"; }

function showEnd(status, result) {
  ended = true;
  $("reconnect").hidden = true;
  showBanner("");
  $("end").hidden = false;
  $("end-title").textContent = status === "finished" ? "Race finished" : `Race ${status}`;
  $("end-result").href = `/api/races/${encodeURIComponent(raceId)}/result`;
  const karts = result && Array.isArray(result.karts) ? result.karts : [];
  const me = karts.find((k) => k.index === kartIndex);
  if (me) {
    const place = `P${me.position} of ${karts.length}`;
    const time = me.finished ? `in ${fmtTime(me.finish_time)}` : "did not finish";
    $("end-you").textContent = `You (${me.name}): ${place}, ${time}`;
    $("end-safety").textContent = `Collisions at fault: ${me.collisions_at_fault} · illegal lane changes: `
      + `${me.illegal_lane_changes} · wall hits: ${me.wall_hits}`;
  } else {
    $("end-you").textContent = "No result was stored for this race.";
    $("end-safety").textContent = "";
  }
  const winner = karts.find((k) => k.winner);
  $("end-winner").textContent = !winner ? "No winner: nobody finished."
    : winner.index === kartIndex ? `You won, in ${fmtTime(winner.finish_time)}!`
      : `Winner: ${winner.name}, in ${fmtTime(winner.finish_time)}`;
  const list = $("end-standings");
  list.replaceChildren(...[...karts].sort((a, b) => a.position - b.position).map((k) => el(
    "li", {class: k.index === kartIndex ? "me" : ""}, swatch(k.index),
    `${k.name} · ${k.finished ? fmtTime(k.finish_time) : "did not finish"}`,
  )));
  log(`race over (${status})`);
  $("again").focus();
}

// "Race again": the same track, laps, seed, preset, start lanes and karts; then drive the same kart.
async function raceAgain() {
  const button = $("again");
  const msg = $("again-msg");
  button.disabled = true;
  msg.className = "msg";
  msg.textContent = "";
  try {
    const old = await fetchJSON(`/api/races/${encodeURIComponent(raceId)}`);
    const body = {
      track: old.track, laps: old.laps, seed: old.seed, kart_preset: old.kart_preset, start_lanes: old.start_lanes,
      karts: old.karts.map((k) => ({controller: k.controller, name: k.name, params: k.params || {}})),
    };
    const created = await fetchJSON("/api/races", {
      method: "POST", headers: {"Content-Type": "application/json", "Accept": "application/json"},
      body: JSON.stringify(body),
    });
    const mine = created.karts.find((k) => k.index === kartIndex);
    const others = created.karts.filter((k) => k.drive_url && k.index !== kartIndex);
    if (!others.length && mine && mine.drive_url) { location.assign(mine.drive_url); return; }
    // other people drive in this race too: they need their own links
    msg.className = "msg ok";
    msg.replaceChildren(
      "New race created. Send the other drivers their links: ",
      ...others.map((k) => el("a", {href: k.drive_url, target: "_blank"}, k.name)),
      el("br"), mine ? el("a", {href: mine.drive_url}, "drive your kart") : "",
    );
  } catch (error) {
    msg.className = "msg error";
    msg.textContent = `Could not start a new race: ${error.message}`;
    button.disabled = false;
  }
}

// ------------------------------------------------------------------ connection
worker.onmessage = (event) => {
  const m = event.data || {};
  if (m.kind === "input") {
    Object.assign(input, m);
    showInput();
  } else if (m.kind === "open") {
    setConn("open", "connected");
    log("connected");
  } else if (m.kind === "message") {
    onServerMessage(m.data);
  } else if (m.kind === "error") {
    if (!ended) log("connection error", "error");
  } else if (m.kind === "close") {
    const reason = m.reason ? `: ${m.reason}` : "";
    setConn("closed", ended ? "race over" : `closed (${m.code}${reason})`);
    if (!ended) log(`connection closed, code ${m.code}${reason}`, m.code === 1000 ? "" : "error");
  }
};

function connect() {
  if (!raceId || kart === null || !token) {
    setConn("closed", "no kart or token in the link");
    log("This page needs a link of the form /races/ID/drive?kart=K&token=T (shown when the race is created).", "error");
    $("reconnect").hidden = true;
    showBanner("This link has no kart or token.");
    return;
  }
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const query = `kart=${encodeURIComponent(kart)}&token=${encodeURIComponent(token)}&view=1`;
  const url = `${scheme}://${location.host}/api/races/${encodeURIComponent(raceId)}/drive?${query}`;
  setConn("connecting", "connecting…");
  worker.postMessage({cmd: "connect", url});
}

// Read the race (names, laps, whether it has a 3D view); false when it is already over (its result is shown).
async function loadRace(frame) {
  try {
    race = await fetchJSON(`/api/races/${encodeURIComponent(raceId)}`);
  } catch (error) {
    log(`Could not read the race: ${error.message}`, "error");
  }
  $("kart-name").textContent = kartName(kartIndex);
  if (race && OVER.has(race.status)) {
    ended = true;
    $("reconnect").hidden = true;
    let result = null;
    try { result = await fetchJSON(`/api/races/${encodeURIComponent(raceId)}/result`); } catch (_) { /* none */ }
    setConn("closed", "race over");
    showEnd(race.status, result);
    return false;
  }
  if (race && race.viewer_url) {
    frame.src = viewerUrl();
    watchView(frame);
  } else {
    setViewReady(race ? "this server has no 3D view" : "no 3D view");
  }
  return true;
}

function init() {
  $("title").textContent = `race ${raceId} · kart ${kart !== null ? kartIndex + 1 : "?"}`;
  $("kart-swatch").style.background = kartColor(kartIndex);
  $("kart-name").textContent = `kart ${kartIndex + 1}`;
  const frame = $("viewer");
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
  window.addEventListener("gamepadconnected", readPad);
  window.addEventListener("gamepaddisconnected", readPad);
  setInterval(readPad, PAD_POLL_MS);
  $("focus-hint").addEventListener("click", () => $("panel").focus());
  $("reconnect").addEventListener("click", connect);
  $("again").addEventListener("click", raceAgain);
  document.addEventListener("visibilitychange", () => { if (document.hidden) releaseAll(); });
  loadRace(frame).then((live) => { if (live) connect(); });
  $("panel").focus();
}

init();
