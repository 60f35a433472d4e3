// Tournament page: live progress (polled every second while it runs), stop / resume, its races linked to their
// results and replays, and once it stops the report's tables (laid out by the server, as the paper's) and plots.
"use strict";

const POLL_MS = 1000;
const TOURNAMENT_ID = decodeURIComponent(window.location.pathname.replace(/\/+$/, "").split("/").pop() || "");
const API = `/api/tournaments/${encodeURIComponent(TOURNAMENT_ID)}`;
let current = null; // the last GET answer
let renderedRaces = -1;
let resultsFor = -1; // races the shown results cover
let pollTimer = null;

function isRunning(t) {
  return Boolean(t && (t.running || t.status === "running"));
}

function message(text, kind) {
  const msg = document.getElementById("msg");
  msg.className = kind ? `msg ${kind}` : "msg";
  msg.textContent = text;
}

// ------------------------------------------------------------------ summary and progress
function specItems(spec) {
  const items = [
    ["agents", (spec.agents || []).join(", ")],
    ["tracks", (spec.tracks || []).join(", ")],
    ["races per pair", spec.races_per_pair],
    ["seed", spec.seed],
    ["laps", spec.laps === null || spec.laps === undefined ? "each track's" : spec.laps],
    ["time limit", spec.time_limit === null || spec.time_limit === undefined ? "the rules'" : `${spec.time_limit} s`],
    ["kart preset", spec.kart_preset],
    ["conditions", spec.conditions || "paper"],
    ["karts per agent", spec.team_size || 1],
  ];
  return items.flatMap(([name, value]) => [el("dt", {}, name), el("dd", {}, String(value))]);
}

function renderSummary(t) {
  document.title = `Tournament ${t.id} · HeadToHead Karting`;
  document.getElementById("title").textContent = `tournament ${t.id}`;
  document.getElementById("tournament-id").textContent = t.id;
  const status = document.getElementById("status");
  status.className = `status ${t.status}`;
  status.textContent = t.status;
  document.getElementById("spec").replaceChildren(...specItems(t.spec || {}));
  const share = t.total ? Math.min(1, t.done / t.total) : 0;
  const bar = document.getElementById("progress");
  bar.setAttribute("aria-valuemax", String(t.total));
  bar.setAttribute("aria-valuenow", String(t.done));
  document.getElementById("progress-fill").style.width = `${(100 * share).toFixed(1)}%`;
  document.getElementById("progress-text").textContent = `${t.done} / ${t.total} races`;
  document.getElementById("progress-extra").textContent =
    `(${fmtNumber(100 * share, 0)} %)${t.error ? ` · error: ${t.error}` : ""}`;
  document.getElementById("stop").hidden = !t.running;
  document.getElementById("resume").hidden = t.running || t.status === "finished";
}

// ------------------------------------------------------------------ races
function raceRow(race) {
  const winner = race.winner === null || race.winner === undefined ? el("span", {class: "muted"}, "nobody finished") : race.winner;
  const link = (href, text) => el("div", {}, el("a", {href, target: "_blank", rel: "noopener", class: text}, text));
  return el("tr", {"data-race-id": race.race_id},
    el("td", {}, String(race.index)),
    el("td", {}, el("code", {}, race.race_id)),
    el("td", {}, race.track),
    el("td", {class: "small"}, race.agents.map((agent, k) =>
      el("div", {}, swatch(k), agent, el("span", {class: "muted"}, ` (lane ${race.start_lanes[k]})`)))),
    el("td", {}, winner),
    el("td", {}, `${fmtNumber(race.duration, 2)} s`),
    el("td", {class: "muted"}, `${fmtNumber(race.wall_seconds, 1)} s`),
    el("td", {class: "small"}, link(race.url, "race"), link(race.result_url, "result"), link(race.replay_url, "replay"),
      el("div", {}, el("a", {href: `/races/${encodeURIComponent(race.race_id)}`, class: "race-page"}, "race page")),
      el("div", {}, el("a", {href: `/races/${encodeURIComponent(race.race_id)}/replay/`, target: "_blank", rel: "noopener", class: "replay-3d"}, "3D replay"))),
  );
}

function renderRaces(t) {
  const races = Array.isArray(t.races) ? t.races : [];
  if (races.length === renderedRaces) return;
  renderedRaces = races.length;
  document.getElementById("race-rows").replaceChildren(...(races.length ? races.map(raceRow)
    : [el("tr", {}, el("td", {colspan: 8, class: "muted"}, isRunning(t) ? "the first races are on their way…" : "no races"))]));
}

// ------------------------------------------------------------------ results: tables and plots
function table(rows, kind, track) {
  const [header, ...body] = rows;
  return el("table", {class: `races numeric report ${kind}`, "data-track": track},
    el("thead", {}, el("tr", {}, header.map((cell) => el("th", {scope: "col"}, cell)))),
    el("tbody", {}, body.map((row) => el("tr", {"data-agent": row[0]},
      el("th", {scope: "row"}, row[0]),
      row.slice(1).map((cell) => el("td", {class: cell.endsWith("*") ? "sig" : cell === "-" ? "muted" : null}, cell))))));
}

function shownTracks(tracks) {
  const names = Object.keys(tracks);
  return names.length === 2 && names.includes("combined") ? names.filter((n) => n !== "combined") : names;
}

function renderResults(report) {
  const tracks = shownTracks(report.tracks);
  const sections = tracks.map((track) => {
    const tables = report.tracks[track];
    return el("div", {class: "track-tables", "data-track": track},
      el("h3", {}, track === "combined" ? "All tracks" : `Track ${track}`),
      el("h4", {}, "Head-to-head wins, row agent against column agent"), table(tables.wins, "wins", track),
      el("h4", {}, "Pairs: win rates with 95% intervals, distinct outcomes and the grid's part"),
      table(tables.pairs, "pairs", track),
      el("h4", {}, "Safety per race (mean [95% interval] and std. dev. over all races)"), table(tables.safety, "safety", track),
      el("h4", {}, "Plan following (finished races) and passes"), table(tables.plan, "plan", track),
      el("h4", {}, "Wins by start lane (the pair's first agent; Fisher's exact test of the lane's effect)"),
      table(tables.start_lanes, "start-lanes", track));
  });
  const ratings = el("div", {class: "track-tables", "data-track": "ratings"},
    el("h3", {}, "Ratings from every race (Plackett–Luce, 95% intervals)"), table(report.ratings, "ratings", "all"));
  document.getElementById("tables").replaceChildren(ratings, ...sections);
  document.getElementById("tables-note").textContent = report.note;
  const plotted = new Set(tracks.map((t) => t.replace(/[^A-Za-z0-9_-]/g, "_")));
  const plots = report.plots.filter((p) => p.name === "finish_times" || plotted.has(p.name.replace(/^(wins|safety)_/, "")));
  document.getElementById("plots").replaceChildren(...plots.map((p) =>
    el("figure", {"data-plot": p.name}, el("img", {src: p.url, alt: p.title, loading: "lazy"}), el("figcaption", {}, p.title))));
  document.getElementById("results-scope").textContent =
    report.done < report.total ? `over the ${report.done} races so far of ${report.total}` : `over all ${report.done} races`;
  document.getElementById("results").hidden = false;
}

async function loadResults(t) {
  if (t.done === 0 || t.done === resultsFor) return;
  try {
    renderResults(await fetchJSON(`${API}/tables`));
    resultsFor = t.done;
  } catch (error) {
    message(`could not load the results: ${error.message}`, "error");
  }
}

// ------------------------------------------------------------------ polling, stop, resume
function schedule(ms) {
  clearTimeout(pollTimer);
  pollTimer = setTimeout(poll, ms);
}

async function poll() {
  try {
    const t = await fetchJSON(`${API}?stats=false`);
    current = t;
    renderSummary(t);
    renderRaces(t);
    if (isRunning(t)) {
      schedule(POLL_MS);
    } else {
      await loadResults(t);
    }
  } catch (error) {
    if (error.status === 404) {
      document.getElementById("progress-text").textContent = "";
      message(`No tournament ${TOURNAMENT_ID}. See the list of tournaments.`, "error");
      document.getElementById("race-rows").replaceChildren();
      return;
    }
    message(`could not load the tournament (retrying): ${error.message}`, "error");
    schedule(2 * POLL_MS);
  }
}

async function stop() {
  const button = document.getElementById("stop");
  button.disabled = true;
  message("stopping after the races in flight…");
  try {
    await fetchJSON(`${API}/stop`, {method: "POST"});
    message("stopped: resume it to run the races left", "ok");
  } catch (error) {
    message(`could not stop it: ${error.message}`, "error");
  } finally {
    button.disabled = false;
    schedule(0);
  }
}

async function resume() {
  if (!current) return;
  const spec = current.spec || {};
  const body = {id: current.id};
  for (const key of ["agents", "tracks", "races_per_pair", "seed", "laps", "time_limit", "kart_preset", "conditions", "team_size"]) body[key] = spec[key];
  const button = document.getElementById("resume");
  button.disabled = true;
  try {
    await fetchJSON("/api/tournaments", {
      method: "POST",
      headers: {"Content-Type": "application/json", "Accept": "application/json"},
      body: JSON.stringify(body),
    });
    message("resumed: the races left are running", "ok");
  } catch (error) {
    message(`could not resume it: ${error.message}`, "error");
  } finally {
    button.disabled = false;
    schedule(0);
  }
}

document.getElementById("stop").addEventListener("click", stop);
document.getElementById("resume").addEventListener("click", resume);
poll();
