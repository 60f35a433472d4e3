// Drive page worker: owns the drive websocket and sends the input at 50 Hz on its own thread, so a busy page (the
// 3D view renders on the page's thread, slowly with software WebGL) does not starve the kart of input. Keys ramp
// the input smoothly; while no key is pressed, a gamepad's analog values (read by the page) are sent as they are.
// Once the page's 3D view is ready it says so to the server ({"type": "ready"}), again after a reconnect.
"use strict";

const SEND_PERIOD_MS = 20; // 50 Hz
const STEER_RATE = 3.0; // [1/s] steer ramp towards the pressed direction
const STEER_RETURN_RATE = 5.0; // [1/s] back to centre (and when reversing direction)
const THROTTLE_RATE = 2.5; // [1/s]
const BRAKE_RATE = 6.0; // [1/s]
const RELEASE_RATE = 4.0; // [1/s] throttle back to 0 when released
const REPORT_PERIOD_MS = 100; // input shown on the page at 10 Hz

let pressed = new Set();
const input = {steer: 0, throttle: 0};
let pad = {active: false, steer: 0, throttle: 0};
let viewReady = false;
let socket = null;
let seq = 0;
let lastTick = performance.now();
let lastReport = 0;

function clamp(value) { return Math.max(-1, Math.min(1, Number(value) || 0)); }

function approach(value, target, rate, dt) {
  const step = rate * dt;
  return Math.abs(target - value) <= step ? target : value + Math.sign(target - value) * step;
}

function ramp(dt) {
  if (pressed.size === 0 && pad.active) {
    input.steer = pad.steer;
    input.throttle = pad.throttle;
    return;
  }
  const steerTarget = (pressed.has("left") ? 1 : 0) - (pressed.has("right") ? 1 : 0); // steer > 0 = left
  const reversing = steerTarget !== 0 && input.steer !== 0 && Math.sign(steerTarget) !== Math.sign(input.steer);
  input.steer = approach(input.steer, steerTarget, steerTarget === 0 || reversing ? STEER_RETURN_RATE : STEER_RATE, dt);
  const throttleTarget = (pressed.has("up") ? 1 : 0) - (pressed.has("down") ? 1 : 0);
  const rate = throttleTarget > 0 ? THROTTLE_RATE : throttleTarget < 0 ? BRAKE_RATE : RELEASE_RATE;
  input.throttle = approach(input.throttle, throttleTarget, rate, dt);
}

function tick() {
  const now = performance.now();
  const dt = Math.min((now - lastTick) / 1000, 0.1);
  lastTick = now;
  ramp(dt);
  let sent = false;
  if (socket && socket.readyState === WebSocket.OPEN) {
    seq += 1;
    socket.send(JSON.stringify({steer: Number(input.steer.toFixed(3)), throttle: Number(input.throttle.toFixed(3)), seq}));
    sent = true;
  }
  if (now - lastReport >= REPORT_PERIOD_MS) {
    lastReport = now;
    postMessage({kind: "input", steer: input.steer, throttle: input.throttle, seq, sending: sent});
  }
}

function connect(url) {
  if (socket) socket.close(1000, "reconnecting");
  const ws = new WebSocket(url);
  socket = ws;
  ws.addEventListener("open", () => {
    if (viewReady) ws.send(JSON.stringify({type: "ready"}));
    postMessage({kind: "open"});
  });
  ws.addEventListener("message", (event) => postMessage({kind: "message", data: String(event.data)}));
  ws.addEventListener("error", () => postMessage({kind: "error"}));
  ws.addEventListener("close", (event) => {
    if (socket === ws) socket = null;
    postMessage({kind: "close", code: event.code, reason: event.reason});
  });
}

onmessage = (event) => {
  const command = event.data || {};
  if (command.cmd === "connect") connect(command.url);
  else if (command.cmd === "keys") pressed = new Set(command.pressed || []);
  else if (command.cmd === "pad") pad = {active: Boolean(command.active), steer: clamp(command.steer), throttle: clamp(command.throttle)};
  else if (command.cmd === "ready") {
    viewReady = true;
    if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify({type: "ready"}));
  }
  else if (command.cmd === "close" && socket) socket.close(1000, "page closed");
};

setInterval(tick, SEND_PERIOD_MS);
