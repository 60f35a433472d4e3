// Small SVG charts for the pages, drawn from data already in the page (no library, no external requests).
"use strict";

const SVG_NS = "http://www.w3.org/2000/svg";

function svgEl(tag, attrs, ...children) {
  const node = document.createElementNS(SVG_NS, tag);
  for (const [key, value] of Object.entries(attrs || {})) {
    if (value !== undefined && value !== null) node.setAttribute(key, String(value));
  }
  for (const child of children.flat()) {
    if (child === undefined || child === null) continue;
    node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return node;
}

// Round tick values covering [lo, hi]: about `count` of them at 1, 2 or 5 times a power of ten.
function niceTicks(lo, hi, count, integer) {
  if (!(hi > lo)) hi = lo + 1;
  const raw = (hi - lo) / Math.max(count, 1);
  const power = Math.pow(10, Math.floor(Math.log10(raw)));
  let step = [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw) || raw;
  if (integer) step = Math.max(1, Math.round(step));
  const ticks = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) ticks.push(Number(v.toFixed(10)));
  return ticks;
}

// A line chart: series = [{name, color, points: [[x, y] or null (a break), ...]}].
// options: {name, xLabel, yLabel, xMin, xMax, yMin, yMax, invertY, integerX, integerY, width, height}.
function lineChart(series, options) {
  const o = Object.assign({width: 440, height: 240}, options || {});
  const pad = {left: 46, right: 12, top: 10, bottom: 34};
  const all = series.flatMap((s) => s.points.filter((p) => p && isFinite(p[0]) && isFinite(p[1])));
  const xs = all.map((p) => p[0]);
  const ys = all.map((p) => p[1]);
  const xMin = o.xMin ?? (xs.length ? Math.min(...xs) : 0);
  const xMax = o.xMax ?? (xs.length ? Math.max(...xs) : 1);
  const yMin = o.yMin ?? (ys.length ? Math.min(...ys) : 0);
  const yMax = o.yMax ?? (ys.length ? Math.max(...ys) : 1);
  const w = o.width - pad.left - pad.right;
  const h = o.height - pad.top - pad.bottom;
  const xSpan = xMax > xMin ? xMax - xMin : 1;
  const ySpan = yMax > yMin ? yMax - yMin : 1;
  const sx = (x) => pad.left + ((x - xMin) / xSpan) * w;
  const sy = (y) => o.invertY ? pad.top + ((y - yMin) / ySpan) * h : pad.top + h - ((y - yMin) / ySpan) * h;
  const svg = svgEl("svg", {class: "chart", viewBox: `0 0 ${o.width} ${o.height}`, role: "img",
    "data-chart": o.name || "", "aria-label": o.label || o.name || "chart"});
  for (const t of niceTicks(yMin, yMax, 5, o.integerY)) {
    if (t < yMin - 1e-9 || t > yMax + 1e-9) continue;
    svg.append(svgEl("line", {class: "grid", x1: pad.left, x2: pad.left + w, y1: sy(t), y2: sy(t)}),
      svgEl("text", {x: pad.left - 5, y: sy(t) + 4, "text-anchor": "end"}, String(t)));
  }
  for (const t of niceTicks(xMin, xMax, 6, o.integerX)) {
    if (t < xMin - 1e-9 || t > xMax + 1e-9) continue;
    svg.append(svgEl("line", {class: "axis", x1: sx(t), x2: sx(t), y1: pad.top + h, y2: pad.top + h + 4}),
      svgEl("text", {x: sx(t), y: pad.top + h + 16, "text-anchor": "middle"}, String(t)));
  }
  svg.append(svgEl("line", {class: "axis", x1: pad.left, x2: pad.left + w, y1: pad.top + h, y2: pad.top + h}),
    svgEl("line", {class: "axis", x1: pad.left, x2: pad.left, y1: pad.top, y2: pad.top + h}));
  if (o.xLabel) svg.append(svgEl("text", {x: pad.left + w / 2, y: o.height - 4, "text-anchor": "middle"}, o.xLabel));
  if (o.yLabel) {
    svg.append(svgEl("text", {x: 12, y: pad.top + h / 2, "text-anchor": "middle",
      transform: `rotate(-90 12 ${pad.top + h / 2})`}, o.yLabel));
  }
  for (const s of series) {
    let run = [];
    const runs = [];
    for (const p of s.points) {
      if (p && isFinite(p[0]) && isFinite(p[1])) run.push(p);
      else if (run.length) { runs.push(run); run = []; }
    }
    if (run.length) runs.push(run);
    const group = svgEl("g", {"data-series": s.name}, svgEl("title", {}, s.name));
    for (const r of runs) {
      if (r.length === 1 || o.markers) {
        for (const p of r) group.append(svgEl("circle", {cx: sx(p[0]), cy: sy(p[1]), r: 3, fill: s.color}));
      }
      if (r.length > 1) {
        group.append(svgEl("polyline", {class: "series", stroke: s.color,
          points: r.map((p) => `${sx(p[0]).toFixed(1)},${sy(p[1]).toFixed(1)}`).join(" ")}));
      }
    }
    svg.append(group);
  }
  return svg;
}

// A legend of coloured names: items = [{name, color}].
function chartLegend(items) {
  return el("div", {class: "legend"}, items.map((i) => el("span", {}, el("span", {class: "swatch", style: `background: ${i.color}`}), i.name)));
}
