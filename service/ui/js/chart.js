// Bar charts as plain SVG: one series (horizontal bars) or grouped series (vertical bars with a legend).

import { fmt, h } from "./dom.js";

const NS = "http://www.w3.org/2000/svg";
export const COLORS = ["#1f6feb", "#d1242f", "#1a7f37", "#9a6700", "#8250df", "#bf3989", "#0a7ea4", "#57606a"];

function s(tag, attrs = {}, text) {
  const el = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  if (text !== undefined) el.textContent = text;
  return el;
}

function niceMax(x) {
  if (!(x > 0)) return 1;
  const p = 10 ** Math.floor(Math.log10(x));
  for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
  return 10 * p;
}

/** Horizontal bars: items [{label, value}] (at most ``limit``), titled by ``title``. */
export function barChart(items, { title = "", limit = 40, width = 720 } = {}) {
  const shown = items.filter((d) => Number.isFinite(d.value)).slice(0, limit);
  const labelW = Math.min(280, Math.max(60, ...shown.map((d) => d.label.length * 6.4)));
  const rowH = 18, top = title ? 26 : 8, height = top + shown.length * rowH + 24;
  const max = niceMax(Math.max(0, ...shown.map((d) => d.value)));
  const min = Math.min(0, ...shown.map((d) => d.value));
  const plotW = width - labelW - 70;
  const x = (v) => labelW + ((v - min) / (max - min || 1)) * plotW;
  const svg = s("svg", { class: "chart", width, height, viewBox: `0 0 ${width} ${height}`, role: "img", "aria-label": title });
  if (title) svg.append(s("text", { x: 4, y: 16, "font-weight": "600" }, title));
  for (let i = 0; i <= 4; i++) {
    const v = min + ((max - min) * i) / 4;
    svg.append(s("line", { class: "gridline", x1: x(v), x2: x(v), y1: top - 4, y2: height - 20 }));
    svg.append(s("text", { x: x(v), y: height - 6, "text-anchor": "middle", fill: "#66707a" }, fmt(v, 2)));
  }
  shown.forEach((d, i) => {
    const y = top + i * rowH;
    const label = d.label.length > 44 ? d.label.slice(0, 42) + "…" : d.label;
    svg.append(s("text", { x: labelW - 6, y: y + 12, "text-anchor": "end" }, label));
    const x0 = x(Math.min(0, d.value)), x1 = x(Math.max(0, d.value));
    const bar = s("rect", { x: x0, y: y + 2, width: Math.max(1, x1 - x0), height: rowH - 5, fill: COLORS[0], rx: 2 });
    bar.append(s("title", {}, `${d.label}: ${d.value}`));
    svg.append(bar);
    svg.append(s("text", { x: x1 + 4, y: y + 12, fill: "#57606a" }, fmt(d.value)));
  });
  const wrap = h("div", {}, svg);
  if (items.length > shown.length) wrap.append(h("div", { class: "muted small" }, `first ${shown.length} of ${items.length} rows`));
  return wrap;
}

/**
 * Grouped vertical bars: groups [label…], series [label…], value(group, series) → number | null,
 * note(group, series) → tooltip text.
 */
export function groupedBars(groups, series, value, { title = "", yLabel = "", width = 460, height = 240, note = null } = {}) {
  const top = 28, bottom = 36, left = 48, right = 8;
  const values = groups.flatMap((g) => series.map((sr) => value(g, sr))).filter((v) => Number.isFinite(v));
  const max = niceMax(Math.max(0, ...values));
  const plotH = height - top - bottom, plotW = width - left - right;
  const gw = plotW / Math.max(1, groups.length);
  const bw = Math.min(36, Math.max(3, (gw - 10) / Math.max(1, series.length)));
  const pad = (gw - bw * series.length) / 2;
  const y = (v) => top + plotH - (v / max) * plotH;
  const svg = s("svg", { class: "chart", width, height, viewBox: `0 0 ${width} ${height}`, role: "img", "aria-label": title });
  svg.append(s("text", { x: 4, y: 16, "font-weight": "600" }, title));
  if (yLabel) svg.append(s("text", { x: width - 4, y: 16, "text-anchor": "end", fill: "#66707a" }, yLabel));
  for (let i = 0; i <= 5; i++) {
    const v = (max * i) / 5;
    svg.append(s("line", { class: "gridline", x1: left, x2: width - right, y1: y(v), y2: y(v) }));
    svg.append(s("text", { x: left - 4, y: y(v) + 4, "text-anchor": "end", fill: "#66707a" }, fmt(v, 2)));
  }
  svg.append(s("line", { class: "axis", x1: left, x2: width - right, y1: y(0), y2: y(0) }));
  groups.forEach((g, gi) => {
    const gx = left + gi * gw + pad;
    series.forEach((sr, si) => {
      const v = value(g, sr);
      if (!Number.isFinite(v)) return;
      const bar = s("rect", { x: gx + si * bw, y: y(v), width: bw - 1, height: Math.max(0.5, y(0) - y(v)), fill: COLORS[si % COLORS.length] });
      bar.append(s("title", {}, `${sr} · ${g}: ${fmt(v)}${note ? " · " + note(g, sr) : ""}`));
      svg.append(bar);
    });
    svg.append(s("text", { x: left + gi * gw + gw / 2, y: height - bottom + 14, "text-anchor": "middle" }, g));
  });
  const legend = h("div", { class: "legend" }, series.map((sr, i) => h("span", {}, h("i", { style: `background:${COLORS[i % COLORS.length]}` }), sr)));
  return h("div", {}, svg, legend);
}
