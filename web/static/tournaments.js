// Tournaments page: the stored tournaments (polled), the leaderboard across them (computed by the server), and the
// form that launches a round robin (the API judges the input: its 422 messages are shown as they come).
"use strict";

let listedSignature = "";

// ------------------------------------------------------------------ tournament list
function tournamentUrl(id) {
  return `/tournaments/${encodeURIComponent(id)}`;
}

function progressCell(t) {
  const share = t.total ? Math.min(1, t.done / t.total) : 0;
  return el("div", {class: "small"},
    el("div", {class: "bar thin", role: "progressbar", "aria-valuemin": 0, "aria-valuemax": t.total, "aria-valuenow": t.done},
      el("div", {class: "fill", style: `width: ${(100 * share).toFixed(1)}%`})),
    `${t.done} / ${t.total} races`);
}

function tournamentRow(t) {
  const spec = t.spec || {};
  const created = t.created_at ? new Date(t.created_at) : null;
  return el("tr", {"data-tournament-id": t.id},
    el("td", {}, el("a", {href: tournamentUrl(t.id)}, el("code", {}, t.id))),
    el("td", {}, el("span", {class: `status ${t.status}`}, t.status), t.error ? el("div", {class: "small muted", title: t.error}, "error") : null),
    el("td", {}, progressCell(t)),
    el("td", {class: "small"}, (spec.agents || []).map((a, i) => el("div", {}, swatch(i), a))),
    el("td", {class: "small"}, (spec.tracks || []).join(", "), el("div", {class: "muted"}, `${spec.races_per_pair} per pair · seed ${spec.seed}`)),
    el("td", {class: "small muted"}, created && !isNaN(created) ? created.toLocaleString() : "–"),
  );
}

async function refreshTournaments() {
  const rows = document.getElementById("tournament-rows");
  const errorBox = document.getElementById("tournaments-error");
  try {
    const list = listOf(await fetchJSON("/api/tournaments"), "tournaments");
    rows.replaceChildren(...(list.length ? list.map(tournamentRow)
      : [el("tr", {}, el("td", {colspan: 6, class: "muted"}, "no tournaments yet: start one →"))]));
    errorBox.textContent = "";
    const signature = list.map((t) => `${t.id}:${t.done}:${t.status}`).join(",");
    if (signature !== listedSignature) {
      listedSignature = signature;
      refreshLeaderboard();
    }
  } catch (error) {
    errorBox.textContent = `could not load the tournaments: ${error.message}`;
  }
}

// ------------------------------------------------------------------ leaderboard
function standingRow(s, place) {
  return el("tr", {"data-agent": s.agent},
    el("td", {}, String(place + 1)),
    el("td", {}, el("strong", {}, s.agent)),
    el("td", {}, String(s.tournaments)),
    el("td", {}, String(s.races)),
    el("td", {}, String(s.wins)),
    el("td", {}, `${fmtNumber(100 * s.win_rate, 1)} %`),
    el("td", {}, String(s.finished)),
    el("td", {}, `${fmtNumber(s.safety_score_mean, 2)} ± ${fmtNumber(s.safety_score_std, 2)}`),
  );
}

async function refreshLeaderboard() {
  const rows = document.getElementById("leaderboard-rows");
  const errorBox = document.getElementById("leaderboard-error");
  try {
    const board = await fetchJSON("/api/tournaments/leaderboard");
    document.getElementById("leaderboard-scope").textContent =
      `${board.races} races in ${board.tournaments} tournament${board.tournaments === 1 ? "" : "s"}`;
    rows.replaceChildren(...(board.agents.length ? board.agents.map(standingRow)
      : [el("tr", {}, el("td", {colspan: 8, class: "muted"}, "no races yet"))]));
    errorBox.textContent = "";
  } catch (error) {
    errorBox.textContent = `could not load the leaderboard: ${error.message}`;
  }
}

// ------------------------------------------------------------------ launch form
function checkboxes(boxId, name, items, checked) {
  const box = document.getElementById(boxId);
  const legend = box.querySelector("legend");
  const labels = items.map((item) => el("label", {class: "choice", title: item.description || ""},
    el("input", {type: "checkbox", name, value: item.name, checked: checked.includes(item.name)}), item.name));
  box.replaceChildren(legend, ...labels);
}

function checkedValues(name) {
  return Array.from(document.querySelectorAll(`input[name="${name}"]:checked`)).map((box) => box.value);
}

// A number field's value for the API: null when blank (the API's default, or its 422 for a required one).
function numberField(id) {
  const input = document.getElementById(id);
  const text = input.value.trim();
  if (text === "") return input.validity && input.validity.badInput ? text : null;
  const value = Number(text);
  return Number.isNaN(value) ? text : value;
}

function showSize() {
  const agents = checkedValues("agents").length;
  const tracks = checkedValues("tracks").length;
  const perPair = Number(document.getElementById("races-per-pair").value) || 0;
  const races = (agents * (agents - 1)) / 2 * tracks * perPair;
  document.getElementById("size-hint").textContent =
    agents >= 2 && tracks >= 1 && perPair >= 1 ? `${races} race${races === 1 ? "" : "s"} in all` : "";
}

async function launch(event) {
  event.preventDefault();
  const msg = document.getElementById("launch-msg");
  const button = document.getElementById("launch-button");
  const id = document.getElementById("tournament-id").value.trim();
  const body = {
    agents: checkedValues("agents"),
    tracks: checkedValues("tracks"),
    races_per_pair: numberField("races-per-pair"),
    seed: numberField("seed"),
    laps: numberField("laps"),
    time_limit: numberField("time-limit"),
    kart_preset: document.getElementById("kart-preset").value,
    conditions: document.getElementById("conditions").value,
    team_size: Number(document.getElementById("team-size").value),
    id: id === "" ? null : id,
  };
  msg.className = "msg";
  msg.textContent = "starting…";
  button.disabled = true;
  try {
    const started = await fetchJSON("/api/tournaments", {
      method: "POST",
      headers: {"Content-Type": "application/json", "Accept": "application/json"},
      body: JSON.stringify(body),
    });
    msg.className = "msg ok";
    msg.replaceChildren(`Tournament ${started.id} started (${started.total} races). `,
      el("a", {href: tournamentUrl(started.id)}, "Follow it"));
    refreshTournaments();
    window.location.assign(tournamentUrl(started.id));
  } catch (error) {
    msg.className = "msg error";
    msg.textContent = `The tournament was not started.\n${error.message}`;
  } finally {
    button.disabled = false;
  }
}

async function init() {
  const form = document.getElementById("launch");
  form.addEventListener("submit", launch);
  form.addEventListener("change", showSize);
  form.addEventListener("input", showSize);
  refreshTournaments();
  setInterval(refreshTournaments, 2000);
  try {
    const [trackBody, controllerBody] = await Promise.all([fetchJSON("/api/tracks"), fetchJSON("/api/controllers")]);
    const tracks = listOf(trackBody, "tracks").map((t) => (typeof t === "string" ? {name: t} : t));
    const agents = listOf(controllerBody, "controllers").map((c) => (typeof c === "string" ? {name: c} : c))
      .filter((c) => c.name !== "human");
    checkboxes("agents", "agents", agents, []);
    checkboxes("tracks", "tracks", tracks, ["oval"]);
    showSize();
  } catch (error) {
    const msg = document.getElementById("launch-msg");
    msg.className = "msg error";
    msg.textContent = `could not load tracks or controllers: ${error.message}`;
  }
}

init();
