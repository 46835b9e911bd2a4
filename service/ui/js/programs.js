// Rules and programs: read a DSL program, edit it with a live check (errors at line:column with the
// known names), preview what it would change in the decisions, apply it with the editor token.

import { Problem, api } from "./api.js";
import { refreshVersion } from "./app.js";
import { clear, contextText, debounce, fmt, h, iriLink } from "./dom.js";
import { codeEditor } from "./editor.js";

const KEYWORDS = "prune adjust weight prefer require by when and is not one of because".split(" ");

async function vocabularyNames() {
  const v = await api("/v1/vocabulary");
  const names = new Set(KEYWORDS);
  for (const [x, spec] of Object.entries(v.extractors)) {
    names.add(x);
    for (const p of Object.keys(spec.parameters)) names.add(`${x}.${p}`);
  }
  for (const [d, spec] of Object.entries(v.context)) { names.add(d); spec.values.forEach((x) => names.add(x)); }
  Object.keys(v.metrics).forEach((m) => names.add(m));
  return [...names].sort();
}

function dslCompleter(names) {
  return (before) => {
    const m = /(?:^|[\s(,])([A-Za-z_][A-Za-z0-9_.]*)$/.exec(before);
    if (!m) return null;
    const typed = m[1];
    const items = names.list.filter((n) => n.startsWith(typed) && n !== typed).map((n) => ({ label: n, insert: n }));
    return { from: before.length - typed.length, items };
  };
}

function problemView(doc, editor) {
  const known = doc.allowed ? doc.allowed.slice(0, 40).join(", ") + (doc.allowed.length > 40 ? ", …" : "") : null;
  return h("div", { class: "problem", onclick: () => doc.line && editor.goTo(doc.line, doc.column) },
    doc.line ? h("b", {}, `${doc.line}:${doc.column} `) : null, doc.detail.replace(/^(?:[^:\s]+:)?\d+:\d+: /, "").replace(/; known: .*$/, ""),
    known ? h("span", { class: "known" }, `known ${doc.kind || "names"}: ${known}`) : null);
}

function outcomeText(o) {
  return o.extractor ? o.extractor : h("span", { class: "tag bad", title: o.error || "" }, "no candidate");
}

function previewView(p) {
  const rows = p.changes.slice(0, 300).map((c) => {
    const params = Object.entries(c.params_changed).map(([k, v]) => h("div", {}, `${k}: ${fmt(v.from)} → `, h("b", {}, fmt(v.to))));
    return h("tr", {},
      h("td", {}, contextText(c.context)),
      h("td", {}, outcomeText(c.before)),
      h("td", { class: c.alpha_changed ? "changed" : null }, outcomeText(c.after)),
      h("td", {}, c.alpha_changed ? h("span", { class: "muted" }, "new extractor") : params));
  });
  return h("div", { id: "preview" },
    h("p", {}, h("b", {}, `${p.changed} of ${p.contexts} contexts change`), `: ${p.alpha_changed} get another extractor α, ${p.params_changed} other parameters Θ′ `,
      h("span", { class: "muted" }, `(graph v${p.graph_version}; +${p.added} −${p.removed} triples; ${fmt(p.elapsed_ms / 1000, 1)} s). `),
      p.conforms ? h("span", { class: "tag ok" }, "SHACL: conforms") : h("span", { class: "tag bad" }, `SHACL: ${p.violations.length} violations`)),
    p.violations.length ? h("div", { class: "error" }, p.violations.map((v) => `${v.focus_node}: ${v.message}\n`)) : null,
    p.changes.length ? h("div", { class: "scroll" }, h("table", { class: "grid", id: "preview-table" },
      h("thead", {}, h("tr", {}, ["context (no frame)", "α now", "α after", "Θ′ changes"].map((x) => h("th", {}, x)))),
      h("tbody", {}, rows))) : h("p", { class: "muted" }, "No context's α or Θ′ changes (the answers without a frame; on a frame F_metrics may still differ)."),
    p.changes.length > rows.length || p.truncated ? h("p", { class: "muted small" }, `first ${rows.length} of ${p.changed} shown`) : null);
}

export async function view(root, params) {
  const [list, rules] = await Promise.all([api("/v1/programs"), api("/v1/rules").catch(() => ({ rules: [] }))]);
  const name = params.get("name") || (list.programs[0] && list.programs[0].name) || "my_program";
  const existing = list.programs.find((p) => p.name === name);
  const names = { list: KEYWORDS };
  vocabularyNames().then((n) => { names.list = n; }).catch(() => {});

  const status = h("div", { id: "check-status", "aria-live": "polite" });
  const out = h("div", { id: "program-out" });
  let text = `program ${name}\n# prune EXTRACTOR when DIMENSION is VALUE because "why"\n`;
  if (existing) text = (await api(`/v1/programs/${encodeURIComponent(name)}`)).text;
  const editor = codeEditor({ value: text, language: "nfex", rows: 18, label: "program text", complete: dslCompleter(names), onChange: debounce(check, 350) });

  let lastCheck = null;
  async function check() {
    const body = editor.value;
    try {
      const r = await api(`/v1/programs/${encodeURIComponent(name)}/check`, { method: "POST", body, headers: { "Content-Type": "text/plain" } });
      if (body !== editor.value) return; // typed on meanwhile: the next check reports
      lastCheck = r;
      if (r.valid) {
        editor.clearError();
        clear(status, h("div", { class: "okmsg" }, `✓ valid: ${r.statements} statement${r.statements === 1 ? "" : "s"}, every name known to the graph`));
      } else {
        const first = r.problems[0];
        editor.markError(first.line, first.column);
        clear(status, h("div", { class: "error", id: "check-problems" }, h("b", {}, `${r.problems.length} problem${r.problems.length > 1 ? "s" : ""}`),
          r.problems.map((d) => problemView(d, editor))));
      }
    } catch (e) {
      clear(status, h("div", { class: "error" }, e.message));
    }
  }
  async function preview() {
    clear(out, h("p", { class: "muted" }, "Comparing the decisions for every context (a few seconds)…"));
    try {
      const p = await api(`/v1/programs/${encodeURIComponent(name)}/preview`, { method: "POST", body: editor.value, headers: { "Content-Type": "text/plain" } });
      clear(out, h("h2", {}, "What it would change"), previewView(p));
    } catch (e) {
      clear(out, failure(e));
    }
  }
  async function apply() {
    clear(out, h("p", { class: "muted" }, "Applying…"));
    try {
      const r = await api(`/v1/programs/${encodeURIComponent(name)}`, { method: "PUT", body: editor.value, headers: { "Content-Type": "text/plain" }, auth: true });
      refreshVersion();
      clear(out, h("div", { class: "okmsg", id: "apply-result" }, r.changed ? `Applied: graph version ${r.version} (+${r.added} −${r.removed} triples). ` : `Nothing changed (graph version ${r.version}). `,
        h("a", { href: `#/versions?v=${r.version}` }, "See it in the versions"), " · ", h("a", { href: `#/programs?name=${encodeURIComponent(name)}` }, "reload")));
    } catch (e) {
      clear(out, failure(e));
    }
  }
  function failure(e) {
    if (!(e instanceof Problem)) return h("div", { class: "error" }, String(e));
    const d = e.doc;
    if (d.line) editor.markError(d.line, d.column);
    const more = (d.problems || []).length > 1 ? d.problems.slice(1) : [];
    const extra = d.violations ? d.violations.map((v) => `\n${v.focus_node}: ${v.message}`) : more.map((x) => `\n${x}`);
    return h("div", { class: "error", id: "apply-error", role: "alert" }, h("b", {}, `${d.title || "Error"} (${e.status}): `), d.detail, extra, " — nothing was applied.");
  }

  const newName = h("input", { type: "text", placeholder: "new program name", "aria-label": "new program name", pattern: "[A-Za-z][A-Za-z0-9_.-]*" });
  clear(root,
    h("h1", {}, "Rules and programs"),
    h("div", { class: "row" },
      h("div", { class: "side" },
        h("div", { class: "panel" }, h("h3", {}, "Programs"), h("ul", { class: "plain", id: "program-list" }, list.programs.map((p) =>
          h("li", {}, h("a", { href: `#/programs?name=${encodeURIComponent(p.name)}`, class: p.name === name ? "active" : null }, p.name),
            h("span", { class: "muted small" }, ` ${p.statements} statements`)))),
          h("form", { class: "toolbar", onsubmit: (e) => { e.preventDefault(); if (newName.value) location.hash = `#/programs?name=${encodeURIComponent(newName.value)}`; } },
            newName, h("button", { type: "submit" }, "New"))),
        h("div", { class: "panel" }, h("h3", {}, "SPARQL pruning rules"), h("ul", { class: "plain" }, rules.rules.map((r) =>
          h("li", {}, iriLink(r.iri, r.label), r.enabled ? null : h("span", { class: "tag bad" }, "disabled")))),
          h("p", { class: "small muted" }, "What each rule prunes: open it in ", h("a", { href: "#/browse?section=rules" }, "Browse"), "."))),
      h("div", { class: "grow" },
        h("div", { class: "panel" },
          h("h2", {}, `Program ${name}`, existing ? h("span", { class: "muted small" }, `  ${existing.iri}${existing.source ? " · from " + existing.source : ""}`) : h("span", { class: "tag" }, "new")),
          editor.el, status,
          h("div", { class: "toolbar" },
            h("button", { onclick: preview, id: "preview-btn" }, "Preview changes"),
            h("button", { class: "primary", onclick: apply, id: "apply-btn" }, "Apply"),
            h("span", { class: "muted small" }, "Apply needs an editor token (top right); it is one SHACL-checked, versioned transaction."))),
        out)));
  check();
}
