// Scenarios page: the stored scenario runs (polled; one shown with its cells and pass thresholds, chosen by the
// URL's ?run=ID or a click), and the form that starts a run (the API judges the input: its 422 messages are shown
// as they come).
"use strict";

let shownRun = new URLSearchParams(window.location.search).get("run");

function choiceBoxes(boxId, items, checked) {
  const box = document.getElementById(boxId);
  const legend = box.querySelector("legend");
  box.replaceChildren(legend, ...items.map((item) => el("label", {class: "choice", title: item.description || ""},
    el("input", {type: "checkbox", name: boxId, value: item.name, checked: checked.includes(item.name)}), item.name)));
}

function checkedValues(name) {
  return Array.from(document.querySelectorAll(`input[name="${name}"]:checked`)).map((box) => box.value);
}

// A comma separated field: null when blank (the scenario's own), numbers where asked.
function listField(id, numeric) {
  const parts = document.getElementById(id).value.split(",").map((p) => p.trim()).filter((p) => p !== "");
  if (!parts.length) return null;
  return numeric ? parts.map((p) => (Number.isNaN(Number(p)) ? p : Number(p))) : parts;
}

function numberField(id) {
  const text = document.getElementById(id).value.trim();
  return text === "" ? null : Number.isNaN(Number(text)) ? text : Number(text);
}

function interval(ci) {
  return Array.isArray(ci) ? ` [${fmtNumber(ci[0], 2)}, ${fmtNumber(ci[1], 2)}]` : "";
}

function runRow(run) {
  const r = run.request || {};
  const created = run.created_at ? new Date(run.created_at) : null;
  return el("tr", {"data-run-id": run.id, class: run.id === shownRun ? "current" : null},
    el("td", {}, el("a", {href: `?run=${encodeURIComponent(run.id)}`, onclick: (e) => { e.preventDefault(); show(run.id); }},
      el("code", {}, run.id))),
    el("td", {}, el("span", {class: `status ${run.status}`}, run.status),
      run.error ? el("div", {class: "small muted", title: run.error}, "error") : null),
    el("td", {class: "small"}, (r.scenarios || []).join(", ")),
    el("td", {class: "small"}, (r.egos || []).join(", ")),
    el("td", {class: "small"}, (r.opponents || []).join(", ")),
    el("td", {}, String(r.attempts)),
    el("td", {class: "small muted"}, created && !isNaN(created) ? created.toLocaleString() : "–"),
  );
}

function cellRow(c) {
  return el("tr", {},
    el("td", {}, c.scenario), el("td", {}, c.track), el("td", {}, c.ego), el("td", {}, c.opponent),
    el("td", {}, String(c.pace)), el("td", {}, String(c.attempts)),
    el("td", {}, `${fmtNumber(c.pass_success, 2)}${interval(c.ci95)}`),
    el("td", {}, c.time_to_pass === null ? "–" : fmtNumber(c.time_to_pass, 1)),
    el("td", {}, `${fmtNumber(c.collisions_at_fault_per_attempt, 2)}${interval(c.collisions_ci95)}`),
    el("td", {}, `${fmtNumber(c.illegal_lane_changes_per_attempt, 2)}${interval(c.illegal_lane_changes_ci95)}`),
    el("td", {}, c.mean_place == null ? "–" : `${fmtNumber(c.mean_place, 2)}${interval(c.mean_place_ci95)}`));
}

function show(runId) {
  shownRun = runId;
  window.history.replaceState(null, "", `?run=${encodeURIComponent(runId)}`);
  refresh();
}

function showRun(run) {
  const card = document.getElementById("run-card");
  card.hidden = !run;
  if (!run) return;
  document.getElementById("run-id").textContent = run.id;
  const summary = run.summary;
  const cells = document.getElementById("cell-rows");
  const thresholds = document.getElementById("threshold-rows");
  if (!summary) {
    cells.replaceChildren(el("tr", {}, el("td", {colspan: 10, class: "muted"},
      run.status === "running" ? "running… (the figures come when every cell is done)" : `no figures (${run.status})`)));
    thresholds.replaceChildren();
    return;
  }
  cells.replaceChildren(...summary.cells.map(cellRow));
  const rows = [];
  for (const [ego, row] of Object.entries(summary.pass_threshold_r50 || {})) {
    for (const [opponent, r50] of Object.entries(row)) {
      rows.push(el("tr", {}, el("td", {}, ego), el("td", {}, opponent), el("td", {}, r50 === null ? "below every pace" : String(r50))));
    }
  }
  thresholds.replaceChildren(...(rows.length ? rows : [el("tr", {}, el("td", {colspan: 3, class: "muted"}, "no overtaking cells"))]));
}

async function refresh() {
  const rows = document.getElementById("run-rows");
  const errorBox = document.getElementById("runs-error");
  try {
    const runs = listOf(await fetchJSON("/api/scenarios/runs"), "runs");
    rows.replaceChildren(...(runs.length ? runs.map(runRow)
      : [el("tr", {}, el("td", {colspan: 7, class: "muted"}, "no runs yet: start one →"))]));
    errorBox.textContent = "";
    const run = runs.find((r) => r.id === shownRun) || (shownRun ? null : runs[0]);
    showRun(run || null);
  } catch (error) {
    errorBox.textContent = `could not load the runs: ${error.message}`;
  }
}

async function launch(event) {
  event.preventDefault();
  const msg = document.getElementById("launch-msg");
  const button = document.getElementById("launch-button");
  const body = {
    scenarios: checkedValues("scenarios"),
    egos: checkedValues("egos"),
    opponents: checkedValues("opponents"),
    tracks: listField("tracks", false),
    paces: listField("paces", true),
    attempts: numberField("attempts"),
    seed: numberField("seed"),
  };
  msg.className = "msg";
  msg.textContent = "starting…";
  button.disabled = true;
  try {
    const started = await fetchJSON("/api/scenarios/runs", {
      method: "POST",
      headers: {"Content-Type": "application/json", "Accept": "application/json"},
      body: JSON.stringify(body),
    });
    msg.className = "msg ok";
    msg.textContent = `Run ${started.id} started.`;
    show(started.id);
  } catch (error) {
    msg.className = "msg error";
    msg.textContent = `The run was not started.\n${error.message}`;
  } finally {
    button.disabled = false;
  }
}

async function init() {
  document.getElementById("launch").addEventListener("submit", launch);
  refresh();
  window.setInterval(refresh, 3000);
  try {
    const [scenarioBody, controllerBody] = await Promise.all([fetchJSON("/api/scenarios"), fetchJSON("/api/controllers")]);
    const agents = listOf(controllerBody, "controllers").map((c) => (typeof c === "string" ? {name: c} : c))
      .filter((c) => c.name !== "human");
    choiceBoxes("scenarios", listOf(scenarioBody, "scenarios"), ["overtake-straight"]);
    choiceBoxes("egos", agents, []);
    choiceBoxes("opponents", agents, []);
  } catch (error) {
    const msg = document.getElementById("launch-msg");
    msg.className = "msg error";
    msg.textContent = `could not load the scenarios or controllers: ${error.message}`;
  }
}

init();
