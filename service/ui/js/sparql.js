// The SPARQL editor: highlighting, prefix completion, saved queries, results as a table and a chart,
// downloads, the error of a bad query at its line and column, and share links (#/sparql?query=…).

import { Problem, api, select, sparql } from "./api.js";
import { codeEditor } from "./editor.js";
import { PREFIXES, clear, h } from "./dom.js";
import { renderResults } from "./results.js";

export const EXAMPLES = [
  { name: "extractors", title: "Feature extractors and their labels",
    query: "SELECT ?x ?label WHERE { ?x a nfex:FeatureExtractor ; rdfs:label ?label }" },
  { name: "parameters", title: "Every parameter: role, default and range",
    query: "SELECT ?extractor ?parameter ?role ?default ?min ?max WHERE {\n  ?p a nfex:Parameter ; nfex:parameterOf/nfex:token ?extractor ; nfex:opencvName ?parameter ;\n     nfex:role/nfex:token ?role .\n  OPTIONAL { ?p nfex:defaultValue ?default } OPTIONAL { ?p nfex:minValue ?min } OPTIONAL { ?p nfex:maxValue ?max }\n} ORDER BY ?extractor ?parameter" },
  { name: "ate-by-extractor", title: "Mean measured ATE by extractor",
    query: "SELECT ?extractor (AVG(?ate) AS ?meanAte) (COUNT(?m) AS ?windows) WHERE {\n  ?m a nfex:Measurement ; sosa:usedProcedure/nfex:ofExtractor/nfex:token ?extractor ; nfex:ateRmse ?ate .\n} GROUP BY ?extractor ORDER BY ?meanAte" },
  { name: "rules", title: "SPARQL pruning rules",
    query: "SELECT ?rule ?label ?source WHERE { ?rule a nfex:SparqlRule ; rdfs:label ?label . OPTIONAL { ?rule nfex:sourceFile ?source } }" },
];

let namesPromise = null;

/** Local names per prefix, for completion: classes, properties and the graph's named things. */
function names() {
  namesPromise ??= select(`SELECT DISTINCT ?t WHERE {
  { ?s ?t ?o } UNION { ?s a ?t } UNION
  { ?t a ?c . VALUES ?c { owl:Class owl:ObjectProperty owl:DatatypeProperty owl:AnnotationProperty owl:NamedIndividual
      nfex:FeatureExtractor nfex:Parameter nfex:ConditionDimension nfex:ConditionValue nfex:QualityMetric nfex:Role
      nfex:SparqlRule nfex:Program nfex:ContextShape nfex:Operation nfex:Dataset nfex:Sequence nfex:Corruption } }
  FILTER (isIRI(?t))
} LIMIT 20000`).then((rows) => {
    const out = Object.fromEntries(Object.keys(PREFIXES).map((p) => [p, new Set()]));
    for (const r of rows) {
      for (const [p, ns] of Object.entries(PREFIXES)) {
        const v = r.t.value;
        if (v.startsWith(ns) && /^[A-Za-z0-9_-]+$/.test(v.slice(ns.length))) out[p].add(v.slice(ns.length));
      }
    }
    return Object.fromEntries(Object.entries(out).map(([p, s]) => [p, [...s].sort()]));
  }).catch(() => ({}));
  return namesPromise;
}

export function completer(known) {
  return (before) => {
    const m = /(?:^|[^A-Za-z0-9_?$<:])([A-Za-z][A-Za-z0-9_-]*):([A-Za-z0-9_-]*)$/.exec(before);
    if (m && PREFIXES[m[1]]) {
      const typed = m[2].toLowerCase();
      const list = (known[m[1]] || []).filter((n) => n.toLowerCase().startsWith(typed));
      return { from: before.length - m[1].length - 1 - m[2].length, items: list.map((n) => ({ label: `${m[1]}:${n}`, insert: `${m[1]}:${n}` })) };
    }
    const w = /(?:^|[\s{(.;,/^|!])([A-Za-z][A-Za-z0-9_-]*)$/.exec(before);
    if (w) {
      const list = Object.keys(PREFIXES).filter((p) => p.startsWith(w[1].toLowerCase()) && p !== w[1]);
      return { from: before.length - w[1].length, items: list.map((p) => ({ label: `${p}:  <${PREFIXES[p]}>`, insert: `${p}:` })) };
    }
    return null;
  };
}

/** (line, column) of a query error as the service reports it: problem members, else "error at L:C" in the detail. */
export function errorPosition(doc) {
  if (Number.isInteger(doc.line)) return { line: doc.line, column: doc.column || 1 };
  const m = /error at (\d+):(\d+)/.exec(doc.detail || "");
  return m ? { line: Number(m[1]), column: Number(m[2]) } : null;
}

function download(name, type, text) {
  const url = URL.createObjectURL(new Blob([text], { type }));
  const a = h("a", { href: url, download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

export async function view(root, params) {
  const known = {};
  names().then((n) => { Object.assign(known, n); root.dataset.names = "ready"; });
  const out = h("div", { id: "sparql-out" });
  const editor = codeEditor({
    value: params.get("query") || EXAMPLES[0].query, language: "sparql", rows: 10, label: "SPARQL query",
    complete: completer(known), onSubmit: () => run(),
  });
  const examples = h("select", { id: "examples", "aria-label": "examples" }, h("option", { value: "" }, "Examples and saved queries…"));
  const addExamples = (group, list) => examples.append(h("optgroup", { label: group }, list.map((q) => h("option", { value: q.query }, q.title))));
  addExamples("Examples", EXAMPLES);
  api("/v1/queries").then((r) => r.queries.length && addExamples("Saved queries (docs/queries)", r.queries)).catch(() => {});
  examples.addEventListener("change", () => { if (examples.value) { editor.value = examples.value; examples.value = ""; } });

  async function run() {
    const query = editor.value;
    clear(out, h("p", { class: "muted" }, "Running…"));
    const t0 = performance.now();
    try {
      const res = await sparql(query);
      editor.clearError();
      clear(out, renderResults(res, performance.now() - t0));
    } catch (e) {
      if (!(e instanceof Problem)) throw e;
      const at = errorPosition(e.doc);
      const lines = query.split("\n").length;
      editor.markError(at && at.line <= lines ? at.line : null, at ? at.column : null);
      const where = at ? h("b", {}, `Line ${at.line}, column ${at.column}` + (at.line > lines ? ` (the query has ${lines} line${lines > 1 ? "s" : ""})` : "") + ": ") : null;
      const box = h("div", { class: "error", id: "sparql-error", role: "alert", onclick: () => at && editor.goTo(at.line, at.column) },
        h("b", {}, `${e.doc.title || "Error"} (${e.status})`), "\n", where, e.doc.detail);
      clear(out, box);
    }
  }
  async function save(format) {
    const types = { csv: ["text/csv", "results.csv"], json: ["application/sparql-results+json", "results.json"] };
    try {
      const text = await api("/sparql", { method: "POST", body: editor.value, headers: { "Content-Type": "application/sparql-query" }, accept: types[format][0], raw: true }).then((r) => r.text());
      download(types[format][1], types[format][0], text);
    } catch (e) {
      clear(out, h("div", { class: "error" }, e.message));
    }
  }
  function share() {
    const link = `${location.origin}${location.pathname}#/sparql?query=${encodeURIComponent(editor.value)}`;
    history.replaceState(null, "", link);
    navigator.clipboard?.writeText(link).catch(() => {});
    shareNote.textContent = "Link to this query copied to the address bar" + (navigator.clipboard ? " and clipboard" : "");
  }
  const shareNote = h("span", { class: "muted small" });
  clear(root,
    h("h1", {}, "SPARQL"),
    h("p", { class: "muted" }, "Read-only SPARQL 1.1 over the knowledge graph; nfex:, sosa:, prov:, rdfs:, owl:, sh:, xsd:, dcterms: are predeclared. ",
      "Type a prefix and a colon for names (Ctrl+Space completes), Ctrl+Enter runs."),
    h("div", { class: "panel" },
      h("div", { class: "toolbar" }, examples),
      editor.el,
      h("div", { class: "toolbar" },
        h("button", { class: "primary", id: "run", onclick: run }, "Run"),
        h("button", { onclick: () => save("csv"), id: "download-csv" }, "Download CSV"),
        h("button", { onclick: () => save("json"), id: "download-json" }, "Download JSON"),
        h("button", { onclick: share, id: "share" }, "Share link"), shareNote)),
    out);
  if (params.get("query")) await run();
}
