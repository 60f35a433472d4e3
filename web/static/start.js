// Start page: the live and finished races (polled), and the form that launches a race.
"use strict";

const LIVE = new Set(["starting", "waiting", "countdown", "running", "live", "created", "pending"]);
let tracks = [];
let controllers = [];
// GET /api/limits: what the API accepts (the form allows the same) and the default kart names
let limits = {min_laps: 1, max_laps: 20, min_karts: 1, max_karts: 8, max_name_length: 32, default_name: "{controller} {number}"};
const kartChoices = []; // [{controller, name, nameEdited}]

// ------------------------------------------------------------------ race list
function kartCell(kart, i) {
  if (kart && typeof kart === "object") return kartLabel(kart.name || `kart ${i + 1}`, kart.controller || "");
  return String(kart);
}

function kartIndex(entry, karts) {
  if (typeof entry === "number") return entry;
  if (entry && typeof entry === "object") {
    for (const key of ["kart", "index", "kart_index", "slot"]) if (typeof entry[key] === "number") return entry[key];
    const name = entry.name || entry.display_name;
    const found = karts.findIndex((k) => k && k.name === name);
    if (found >= 0) return found;
  }
  return -1;
}

function standingsCell(race) {
  const karts = Array.isArray(race.karts) ? race.karts : [];
  const standings = race.standings || race.positions || race.order;
  if (!Array.isArray(standings) || standings.length === 0) return el("span", {class: "muted"}, "–");
  const items = standings.map((entry, place) => {
    const i = kartIndex(entry, karts);
    const label = i >= 0 && karts[i] ? (karts[i].name || `kart ${i + 1}`)
      : (entry && typeof entry === "object" ? (entry.name || JSON.stringify(entry)) : String(entry));
    let extra = "";
    if (entry && typeof entry === "object") {
      if (typeof entry.finish_time === "number") extra = ` ${entry.finish_time.toFixed(2)} s`;
      else if (entry.finished === false && race.status && !LIVE.has(race.status)) extra = " DNF";
    }
    return el("div", {}, `${place + 1}. `, i >= 0 ? swatch(i) : null, label, el("span", {class: "muted"}, extra));
  });
  return el("div", {class: "small"}, items);
}

function raceRow(race) {
  const id = String(race.id !== undefined ? race.id : race.race_id);
  const status = String(race.status || "unknown");
  const karts = Array.isArray(race.karts) ? race.karts : [];
  const live = LIVE.has(status);
  const viewerUrl = race.viewer_url || `/races/${encodeURIComponent(id)}/viewer/`;
  const resultUrl = race.result_url || `/api/races/${encodeURIComponent(id)}/result`;
  const replayUrl = race.replay_url || `/api/races/${encodeURIComponent(id)}/replay`;
  const track = typeof race.track === "object" && race.track ? (race.track.name || JSON.stringify(race.track)) : race.track;
  return el("tr", {"data-race-id": id},
    el("td", {}, el("code", {title: id}, id.length > 10 ? id.slice(0, 8) + "…" : id)),
    el("td", {}, track || "–", race.laps ? el("span", {class: "muted small"}, ` · ${plural(race.laps, "lap")}`) : null),
    el("td", {}, el("span", {class: `status ${status}`}, status)),
    el("td", {class: "small"}, karts.map((k, i) => el("div", {}, swatch(i), kartCell(k, i), teamBadge(karts, k && k.team)))),
    el("td", {}, standingsCell(race)),
    el("td", {class: "small"},
      live ? el("div", {}, el("a", {href: viewerUrl, target: "_blank", rel: "noopener"}, "viewer")) : null,
      el("div", {}, el("a", {href: `/races/${encodeURIComponent(id)}`, class: "race-page"}, "race page")),
      live ? null : el("div", {}, el("a", {href: `/races/${encodeURIComponent(id)}/replay/`, target: "_blank", rel: "noopener", class: "replay-3d"}, "3D replay")),
      live ? null : el("div", {}, el("a", {href: resultUrl, target: "_blank", rel: "noopener"}, "result")),
      live ? null : el("div", {}, el("a", {href: replayUrl, target: "_blank", rel: "noopener"}, "replay"))),
  );
}

async function refreshRaces() {
  const rows = document.getElementById("race-rows");
  const errorBox = document.getElementById("races-error");
  try {
    const races = listOf(await fetchJSON("/api/races"), "races");
    races.sort((a, b) => Number(LIVE.has(b.status)) - Number(LIVE.has(a.status)));
    rows.replaceChildren(...(races.length ? races.map(raceRow)
      : [el("tr", {}, el("td", {colspan: 6, class: "muted"}, "no races yet: start one →"))]));
    errorBox.textContent = "";
  } catch (error) {
    errorBox.textContent = `could not load the races: ${error.message}`;
  }
}

// ------------------------------------------------------------------ launch form
function selectedTrack() {
  const name = document.getElementById("track").value;
  return tracks.find((t) => t.name === name);
}

function showTrackInfo() {
  const track = selectedTrack();
  const info = document.getElementById("track-info");
  if (!track) { info.textContent = ""; return; }
  const parts = [];
  if (typeof track.length_m === "number") parts.push(`${track.length_m.toFixed(0)} m`);
  if (track.n_checkpoints !== undefined) parts.push(`${track.n_checkpoints} checkpoints`);
  if (track.lane_change_limit !== undefined) parts.push(`lane-change limit L = ${track.lane_change_limit}`);
  if (track.laps !== undefined) parts.push(`${plural(track.laps, "lap")} by default`);
  info.textContent = parts.join(" · ");
  if (track.laps !== undefined) document.getElementById("laps").value = track.laps;
}

function defaultName(controller, i) {
  return limits.default_name.replace("{controller}", controller || "kart").replace("{number}", String(i + 1));
}

// The form's limits, as the API's (GET /api/limits).
function applyLimits() {
  const laps = document.getElementById("laps");
  laps.min = limits.min_laps;
  laps.max = limits.max_laps;
  document.getElementById("laps-hint").textContent = `${limits.min_laps} to ${limits.max_laps}`;
  const count = document.getElementById("n-karts");
  const chosen = Number(count.value) || 2;
  const options = [];
  for (let n = limits.min_karts; n <= limits.max_karts; n++) options.push(el("option", {value: n, selected: n === chosen}, n));
  count.replaceChildren(...options);
}

function controllerHint(name) {
  const c = controllers.find((x) => x.name === name);
  return c && c.description ? c.description : "";
}

function renderKarts() {
  const n = Number(document.getElementById("n-karts").value);
  const box = document.getElementById("karts");
  if (controllers.length === 0) return;
  const defaults = ["mcts-lqng", "fixed-lqng"];
  while (kartChoices.length < n) {
    const i = kartChoices.length;
    const names = controllers.map((c) => c.name);
    const preferred = defaults[i] && names.includes(defaults[i]) ? defaults[i] : names.find((x) => x !== "human") || names[0];
    kartChoices.push({controller: preferred || "", name: defaultName(preferred, i), nameEdited: false});
  }
  const rows = [];
  for (let i = 0; i < n; i++) {
    const choice = kartChoices[i];
    const select = el("select", {"aria-label": `controller of kart ${i + 1}`, name: `controller-${i}`, title: controllerHint(choice.controller)},
      controllers.map((c) => el("option", {value: c.name, selected: c.name === choice.controller}, c.name)));
    const input = el("input", {type: "text", maxlength: limits.max_name_length, "aria-label": `name of kart ${i + 1}`, name: `name-${i}`, value: choice.name, required: true});
    select.addEventListener("change", () => {
      choice.controller = select.value;
      select.title = controllerHint(select.value);
      if (!choice.nameEdited) { choice.name = defaultName(select.value, i); input.value = choice.name; }
    });
    input.addEventListener("input", () => { choice.name = input.value; choice.nameEdited = true; });
    rows.push(el("div", {class: "kart"}, swatch(i), select, input));
  }
  box.replaceChildren(...rows);
}

function driveLinks(race) {
  const id = race.id;
  const links = [];
  const karts = Array.isArray(race.karts) ? race.karts : [];
  karts.forEach((kart, i) => {
    if (kart && kart.drive_url) links.push([i, kart.drive_url]);
  });
  if (links.length === 0 && race.drive_tokens && typeof race.drive_tokens === "object") {
    for (const [kart, token] of Object.entries(race.drive_tokens)) {
      links.push([Number(kart), `/races/${encodeURIComponent(id)}/drive?kart=${encodeURIComponent(kart)}&token=${encodeURIComponent(token)}`]);
    }
  }
  return links;
}

async function launch(event) {
  event.preventDefault();
  const msg = document.getElementById("launch-msg");
  const button = document.getElementById("launch-button");
  const n = Number(document.getElementById("n-karts").value);
  const body = {
    track: document.getElementById("track").value,
    laps: Number(document.getElementById("laps").value),
    seed: Number(document.getElementById("seed").value),
    start_lanes: null,
    kart_preset: "paper",
    karts: kartChoices.slice(0, n).map((k) => ({controller: k.controller, name: k.name.trim()})),
  };
  msg.className = "msg";
  msg.textContent = "starting…";
  button.disabled = true;
  try {
    const race = await fetchJSON("/api/races", {
      method: "POST",
      headers: {"Content-Type": "application/json", "Accept": "application/json"},
      body: JSON.stringify(body),
    });
    const viewer = race.viewer_url || `/races/${encodeURIComponent(race.id)}/viewer/`;
    const children = [`Race ${race.id} started. `, el("a", {href: viewer, target: "_blank", rel: "noopener"}, "Open the viewer")];
    for (const [kart, url] of driveLinks(race)) {
      children.push(el("div", {}, swatch(kart), el("a", {href: url, target: "_blank", rel: "noopener"}, `Drive kart ${kart + 1} (${(body.karts[kart] || {}).name || ""})`),
        el("span", {class: "muted"}, " — the link holds the kart's secret token")));
    }
    msg.className = "msg ok";
    msg.replaceChildren(...children);
    refreshRaces();
  } catch (error) {
    msg.className = "msg error";
    msg.textContent = `The race was not started.\n${error.message}`;
  } finally {
    button.disabled = false;
  }
}

async function init() {
  document.getElementById("launch").addEventListener("submit", launch);
  document.getElementById("n-karts").addEventListener("change", renderKarts);
  document.getElementById("track").addEventListener("change", showTrackInfo);
  document.getElementById("seed").value = Math.floor(Math.random() * 1000);
  refreshRaces();
  setInterval(refreshRaces, 2000);
  const msg = document.getElementById("launch-msg");
  try {
    const [trackBody, controllerBody, limitsBody] = await Promise.all(
      [fetchJSON("/api/tracks"), fetchJSON("/api/controllers"), fetchJSON("/api/limits")]);
    limits = limitsBody;
    applyLimits();
    tracks = listOf(trackBody, "tracks").map((t) => (typeof t === "string" ? {name: t} : t));
    controllers = listOf(controllerBody, "controllers").map((c) => (typeof c === "string" ? {name: c} : c));
    const trackSelect = document.getElementById("track");
    trackSelect.replaceChildren(...tracks.map((t) => el("option", {value: t.name, selected: t.name === "oval"}, t.name)));
    showTrackInfo();
    renderKarts();
  } catch (error) {
    msg.className = "msg error";
    msg.textContent = `could not load tracks or controllers: ${error.message}`;
  }
}

init();
