// SPARQL results (application/sparql-results+json) as a table whose IRIs link into the browser, and a
// bar chart of a numeric column against the first text column.

import { barChart } from "./chart.js";
import { fmt, h, iriLink } from "./dom.js";

const NUMERIC = /#(integer|decimal|double|float|int|long|short|byte|nonNegativeInteger|positiveInteger|negativeInteger|nonPositiveInteger|unsignedInt|unsignedLong)$/;

export function isNumeric(term) {
  return term && term.type !== "uri" && term.type !== "bnode" && NUMERIC.test(term.datatype || "") && Number.isFinite(Number(term.value));
}

export function termCell(term) {
  if (!term) return "";
  if (term.type === "uri") return iriLink(term.value);
  if (term.type === "bnode") return h("span", { class: "muted" }, "_:" + term.value);
  if (isNumeric(term)) return fmt(term.value, 6);
  const out = [h("span", { class: "lit" }, term.value)];
  if (term["xml:lang"]) out.push(h("span", { class: "lang" }, " @" + term["xml:lang"]));
  return out;
}

function numericColumns(vars, rows) {
  return vars.filter((v) => rows.length && rows.some((r) => r[v]) && rows.every((r) => !r[v] || isNumeric(r[v])));
}

function labelOf(term) {
  if (!term) return "";
  if (term.type === "uri") {
    const i = Math.max(term.value.lastIndexOf("#"), term.value.lastIndexOf("/"));
    return term.value.slice(i + 1) || term.value;
  }
  return term.value;
}

/** The view of one result: ASK → yes/no; SELECT → count, table, chart of a numeric column. */
export function renderResults(res, elapsedMs) {
  if (typeof res.boolean === "boolean") {
    return h("div", { class: "panel", id: "results" }, h("b", {}, "ASK: "), h("span", { class: res.boolean ? "tag ok" : "tag bad" }, String(res.boolean)));
  }
  const vars = res.head.vars;
  const rows = res.results.bindings;
  const nums = numericColumns(vars, rows);
  const info = h("div", { class: "muted small" }, `${rows.length} row${rows.length === 1 ? "" : "s"}` + (elapsedMs ? ` · ${fmt(elapsedMs, 1)} ms` : ""));
  const tbl = h("table", { class: "grid", id: "results-table" },
    h("thead", {}, h("tr", {}, vars.map((v) => h("th", {}, "?" + v)))),
    h("tbody", {}, rows.map((r) => h("tr", {}, vars.map((v) => h("td", { class: nums.includes(v) ? "num" : null }, termCell(r[v])))))));
  const out = h("div", { class: "panel", id: "results" }, info, h("div", { class: "scroll" }, tbl));
  if (nums.length && rows.length > 1) {
    const labelVar = vars.find((v) => !nums.includes(v));
    const pick = h("select", { "aria-label": "column to chart" }, nums.map((v) => h("option", { value: v }, "?" + v)));
    const chartBox = h("div", { class: "chart-box" });
    const draw = () => {
      const v = pick.value;
      const items = rows.map((r, i) => ({
        label: labelVar ? vars.filter((x) => !nums.includes(x)).map((x) => labelOf(r[x])).join(" · ") : `row ${i + 1}`,
        value: r[v] ? Number(r[v].value) : NaN,
      }));
      chartBox.replaceChildren(barChart(items, { title: `?${v}` + (labelVar ? ` by ${vars.filter((x) => !nums.includes(x)).map((x) => "?" + x).join(", ")}` : "") }));
    };
    pick.addEventListener("change", draw);
    out.append(h("h3", {}, "Chart ", pick), chartBox);
    draw();
  }
  return out;
}
