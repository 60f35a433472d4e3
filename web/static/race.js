// A race's page: summary and links, standings, laps and sectors, charts and incidents (from the race's own
// data: /api/races/{id}, /result and /report). A live race's page waits for the end, then fills in.
"use strict";

const OVER = new Set(["finished", "stopped", "aborted"]);
const WAIT_MS = 3000;
const KINDS = {
  collision_at_fault: {label: "collision at fault", color: "#c62828", shape: "diamond"},
  illegal_lane_change: {label: "illegal lane change", color: "#c77700", shape: "triangle"},
  wall_hit: {label: "wall hit", color: "#55555a", shape: "square"},
  pass: {label: "pass", color: "#14a03c", shape: "circle"},
};

const raceId = decodeURIComponent(location.pathname.replace(/^\/races\//, "").replace(/\/$/, ""));
const msg = document.getElementById("msg");

function seconds(value) { return typeof value === "number" && isFinite(value) ? value.toFixed(2) : "–"; }
function kmh(value) { return typeof value === "number" && isFinite(value) ? (value * 3.6).toFixed(0) : "–"; }
function kartName(race, index) {
  const kart = (race.karts || []).find((k) => k.index === index);
  return kart ? kart.name : `kart ${index + 1}`;
}
function kartCell(race, index) {
  const kart = (race.karts || []).find((k) => k.index === index);
  const controller = kart && kart.controller !== kart.name ? el("span", {class: "muted"}, ` (${kart.controller})`) : null;
  return el("td", {}, swatch(index), kartName(race, index), controller, teamBadge(race.karts, kart ? kart.team : null));
}
function showMessage(text, kind) { msg.textContent = text; msg.className = `msg ${kind || ""}`; }

// ------------------------------------------------------------------ summary
function showSummary(race) {
  document.getElementById("race-id").textContent = race.id;
  const status = document.getElementById("status");
  status.textContent = race.status;
  status.className = `status ${race.status}`;
  document.getElementById("title").textContent = `${race.track} · ${race.laps} ${race.laps === 1 ? "lap" : "laps"}`;
  document.title = `Race ${race.id} · HeadToHead Karting`;
  const spec = [["track", race.track], ["laps", race.laps], ["seed", race.seed], ["kart preset", race.kart_preset],
    ["start lanes", race.start_lanes.join(", ")], ["race time", `${seconds(race.time)} s`],
    ["started", new Date(race.created_at).toLocaleString()]];
  document.getElementById("spec").replaceChildren(...spec.flatMap(([k, v]) => [el("dt", {}, k), el("dd", {}, String(v))]));
  const live = !OVER.has(race.status);
  const links = [];
  if (race.viewer_url) links.push(el("a", {href: race.viewer_url, id: "viewer-link"}, live ? "live 3D view" : "3D replay"));
  if (!live) {
    links.push(el("a", {href: race.result_url, id: "result-link"}, "result (JSON)"));
    links.push(el("a", {href: race.replay_url, id: "replay-json-link"}, "replay (JSON)"));
    links.push(el("a", {href: race.report_url, id: "report-link"}, "figures (JSON)"));
  }
  document.getElementById("links").replaceChildren(...links);
}

// ------------------------------------------------------------------ standings
function showStandings(race, result, report) {
  const byIndex = new Map(report ? report.karts.map((k) => [k.index, k]) : []);
  const head = el("thead", {}, el("tr", {}, ["pos", "kart", "finish [s]", "gap [s]", "laps", "best lap [s]",
    "top speed [km/h]", "collisions at fault", "illegal lane changes", "safety score", "wall hits", "passes",
    "controller faults"].map((h) => el("th", {}, h))));
  const rows = [...result.karts].sort((a, b) => a.position - b.position).map((k) => {
    const figures = byIndex.get(k.index);
    const best = figures && figures.best_lap ? figures.laps.find((l) => l.lap === figures.best_lap) : null;
    let gap = "–";
    if (figures && figures.gap_to_winner !== null) gap = figures.gap_to_winner === 0 ? "winner" : `+${seconds(figures.gap_to_winner)}`;
    else if (!k.finished) gap = "DNF";
    return el("tr", {"data-kart": k.index},
      el("td", {}, k.position), kartCell(race, k.index), el("td", {}, k.finished ? seconds(k.finish_time) : "DNF"),
      el("td", {}, gap), el("td", {}, k.laps), el("td", {}, best ? `${seconds(best.time)} (lap ${best.lap})` : "–"),
      el("td", {}, figures ? kmh(figures.top_speed) : "–"), el("td", {}, k.collisions_at_fault),
      el("td", {}, k.illegal_lane_changes), el("td", {}, k.safety_score), el("td", {}, k.wall_hits),
      el("td", {}, k.passes ?? "–"), el("td", {}, k.controller_faults));
  });
  document.getElementById("standings").replaceChildren(head, el("tbody", {}, rows));
  document.getElementById("standings-card").hidden = false;
}

// ------------------------------------------------------------------ laps and sectors
function showLaps(race, report) {
  const nSectors = report.sector_ends.length;
  const laps = report.karts.flatMap((k) => k.laps.map((lap) => ({kart: k.index, ...lap})));
  const bestLap = Math.min(...laps.map((l) => l.time));
  const bestSector = [...Array(nSectors).keys()].map((j) => Math.min(...laps.map((l) => l.sectors[j])));
  const head = el("thead", {}, el("tr", {}, ["kart", "lap", "time [s]", ...[...Array(nSectors).keys()].map((j) => `S${j + 1} [s]`),
    "position", "gap [s]", "speed over the line [km/h]", "tyre wear [%]"].map((h) => el("th", {}, h))));
  const rows = laps.sort((a, b) => a.kart - b.kart || a.lap - b.lap).map((l) => el("tr", {"data-kart": l.kart, "data-lap": l.lap},
    kartCell(race, l.kart), el("td", {}, l.lap), el("td", {class: l.time === bestLap ? "best" : null}, seconds(l.time)),
    l.sectors.map((s, j) => el("td", {class: s === bestSector[j] ? "best" : null}, seconds(s))),
    el("td", {}, l.position), el("td", {}, l.gap === 0 ? "–" : `+${seconds(l.gap)}`), el("td", {}, kmh(l.speed)),
    el("td", {}, (l.wear * 100).toFixed(1))));
  document.getElementById("laps").replaceChildren(head, el("tbody", {}, rows.length ? rows
    : [el("tr", {}, el("td", {colspan: 8, class: "muted"}, "no lap was completed"))]));
  const ends = report.sector_ends.map((c) => `checkpoint ${c}`).join(", ");
  document.getElementById("laps-note").textContent = `Sectors end at ${ends} of ${report.n_checkpoints}; lap 1 is timed from the start signal. ` +
    `Best lap and best sectors in green. Gaps are to the first kart to complete the same lap.` +
    (report.pose_error > 1e-6 ? ` (Re-simulated figures: the re-simulation strays up to ${report.pose_error.toFixed(2)} m from the recording.)` : "");
  document.getElementById("laps-card").hidden = false;
}

// ------------------------------------------------------------------ charts
function kartSeries(race, report, points) {
  return report.karts.map((k) => ({name: kartName(race, k.index), color: kartColor(k.index), points: points(k)}));
}

function showCharts(race, report) {
  const legend = () => chartLegend(report.karts.map((k) => ({name: kartName(race, k.index), color: kartColor(k.index)})));
  const nKarts = report.karts.length;
  document.getElementById("chart-positions").replaceChildren(lineChart(
    kartSeries(race, report, (k) => k.laps.map((l) => [l.lap, l.position])),
    {name: "positions", label: "positions by lap", xLabel: "lap", yLabel: "position", xMin: 1, xMax: Math.max(report.laps, 2),
      yMin: 1, yMax: Math.max(nKarts, 2), invertY: true, integerX: true, integerY: true, markers: true}), legend());
  document.getElementById("chart-gaps").replaceChildren(lineChart(
    kartSeries(race, report, (k) => k.laps.map((l) => [l.lap, l.gap])),
    {name: "gaps", label: "gap to the leader by lap", xLabel: "lap", yLabel: "gap [s]", xMin: 1, xMax: Math.max(report.laps, 2),
      yMin: 0, integerX: true, markers: true}), legend());
  const select = document.getElementById("speed-lap");
  select.replaceChildren(...[...Array(report.laps).keys()].map((i) => el("option", {value: i}, `lap ${i + 1}`)));
  const drawSpeed = () => {
    const lap = Number(select.value) || 0;
    document.getElementById("chart-speed").replaceChildren(lineChart(
      kartSeries(race, report, (k) => (k.speed_by_lap[lap] || []).map((v, j) => v === null ? null : [report.distance_bins[j], v * 3.6])),
      {name: "speed", label: `speed along lap ${lap + 1}`, xLabel: "distance along the lap [m]", yLabel: "km/h",
        xMin: 0, xMax: report.track_length, yMin: 0}), legend());
  };
  select.onchange = drawSpeed;
  drawSpeed();
  document.getElementById("chart-wear").replaceChildren(lineChart(
    kartSeries(race, report, (k) => k.wear.map((w, i) => [report.wear_times[i], w * 100])),
    {name: "wear", label: "tyre wear over the race", xLabel: "race time [s]", yLabel: "wear [%]", xMin: 0,
      xMax: Math.max(report.duration, 1)}), legend());
  document.getElementById("charts-card").hidden = false;
}

// ------------------------------------------------------------------ incidents
function marker(shape, x, y, color) {
  const r = 5;
  if (shape === "circle") return svgEl("circle", {cx: x, cy: y, r, fill: color});
  if (shape === "square") return svgEl("rect", {x: x - r, y: y - r, width: 2 * r, height: 2 * r, fill: color});
  const points = shape === "triangle" ? [[x, y - r - 1], [x + r + 1, y + r], [x - r - 1, y + r]]
    : [[x, y - r - 1], [x + r + 1, y], [x, y + r + 1], [x - r - 1, y]];
  return svgEl("polygon", {points: points.map((p) => p.join(",")).join(" "), fill: color});
}

function incidentText(race, incident) {
  const kind = KINDS[incident.kind] ? KINDS[incident.kind].label : incident.kind;
  const other = incident.other !== null && incident.other !== undefined ? kartName(race, incident.other) : null;
  if (incident.kind === "pass") return `${kartName(race, incident.kart)} passes ${other || "a kart"}`;
  if (incident.kind === "collision_at_fault") return `${kartName(race, incident.kart)}: ${kind}${other ? ` with ${other}` : ""}`;
  return `${kartName(race, incident.kart)}: ${kind}`;
}

function showIncidents(race, report) {
  const width = 900;
  const rowH = 28;
  const pad = {left: 130, right: 14, top: 10, bottom: 30};
  const h = rowH * report.karts.length;
  const duration = Math.max(report.duration, 1);
  const sx = (t) => pad.left + (t / duration) * (width - pad.left - pad.right);
  const svg = svgEl("svg", {class: "chart", viewBox: `0 0 ${width} ${h + pad.top + pad.bottom}`, role: "img",
    "data-chart": "incidents", "aria-label": "incidents over the race"});
  report.karts.forEach((k, row) => {
    const y = pad.top + row * rowH + rowH / 2;
    svg.append(svgEl("line", {class: "grid", x1: pad.left, x2: width - pad.right, y1: y, y2: y}),
      svgEl("text", {x: pad.left - 8, y: y + 4, "text-anchor": "end"}, kartName(race, k.index)),
      svgEl("rect", {x: pad.left - 124, y: y - 5, width: 10, height: 10, fill: kartColor(k.index)}));
  });
  for (const t of niceTicks(0, duration, 10, false)) {
    if (t > duration) continue;
    svg.append(svgEl("line", {class: "axis", x1: sx(t), x2: sx(t), y1: pad.top + h, y2: pad.top + h + 4}),
      svgEl("text", {x: sx(t), y: pad.top + h + 16, "text-anchor": "middle"}, String(t)));
  }
  svg.append(svgEl("line", {class: "axis", x1: pad.left, x2: width - pad.right, y1: pad.top + h, y2: pad.top + h}),
    svgEl("text", {x: (pad.left + width) / 2, y: h + pad.top + pad.bottom - 2, "text-anchor": "middle"}, "race time [s]"));
  const rowOf = new Map(report.karts.map((k, row) => [k.index, row]));
  for (const incident of report.incidents) {
    const kind = KINDS[incident.kind] || {color: "#000", shape: "circle"};
    const y = pad.top + rowOf.get(incident.kart) * rowH + rowH / 2;
    svg.append(svgEl("g", {class: "incident", "data-kind": incident.kind, "data-kart": incident.kart},
      svgEl("title", {}, `${seconds(incident.time)} s (lap ${incident.lap}): ${incidentText(race, incident)}`),
      marker(kind.shape, sx(incident.time), y, kind.color)));
  }
  const legend = el("div", {class: "legend"}, Object.entries(KINDS).map(([key, kind]) => {
    const count = report.incidents.filter((i) => i.kind === key).length;
    const icon = svgEl("svg", {width: 14, height: 14, viewBox: "0 0 14 14"}, marker(kind.shape, 7, 7, kind.color));
    return el("span", {"data-kind": key}, icon, ` ${kind.label} (${count})`);
  }));
  document.getElementById("chart-incidents").replaceChildren(svg, legend);
  const head = el("thead", {}, el("tr", {}, ["time [s]", "lap", "kart", "what"].map((x) => el("th", {}, x))));
  const rows = report.incidents.map((i) => el("tr", {"data-kind": i.kind},
    el("td", {}, seconds(i.time)), el("td", {}, i.lap), kartCell(race, i.kart), el("td", {}, incidentText(race, i))));
  document.getElementById("incidents").replaceChildren(head, el("tbody", {}, rows.length ? rows
    : [el("tr", {}, el("td", {colspan: 4, class: "muted"}, "a clean race: no incidents"))]));
  document.getElementById("incidents-card").hidden = false;
}

// ------------------------------------------------------------------ loading
async function load() {
  let race;
  try {
    race = await fetchJSON(`/api/races/${encodeURIComponent(raceId)}`);
  } catch (error) {
    document.getElementById("race-id").textContent = raceId;
    showMessage(error.status === 404 ? `There is no race ${raceId}.` : `Could not load the race: ${error.message}`, "error");
    return;
  }
  showSummary(race);
  if (!OVER.has(race.status)) {
    showMessage(`The race is ${race.status}: this page fills in once it is over.`);
    setTimeout(load, WAIT_MS);
    return;
  }
  try {
    const result = await fetchJSON(race.result_url);
    let report = null;
    try {
      report = await fetchJSON(race.report_url);
    } catch (error) {
      showMessage(`No lap figures for this race: ${error.message}`);
    }
    showStandings(race, result, report);
    if (report) {
      showLaps(race, report);
      showCharts(race, report);
      showIncidents(race, report);
      if (!msg.classList.contains("error")) showMessage("");
    }
    document.body.dataset.ready = "true";
  } catch (error) {
    showMessage(`No result for this race: ${error.message}`, error.status === 409 ? "" : "error");
  }
}

load();
