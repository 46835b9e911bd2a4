// The graph browser: extractors → parameters → configurations → measurements (conditions, provenance,
// source); conditions and their values; rules, program statements and context shapes with what they
// prune, adjust or bound (from the compiled table) and what they cite. Any IRI opens as its triples.

import { api, select, val } from "./api.js";
import { PREFIXES, clear, contextText, expand, fmt, h, iriLink, rowsTable, short } from "./dom.js";
import { termCell } from "./results.js";

const NFEX = PREFIXES.nfex;
let effectsCache = null;

function effects() {
  effectsCache ??= api("/v1/rule-effects").catch(() => ({ rules: [], contexts: 0 }));
  return effectsCache;
}

function effectList(rule, total) {
  return h("ul", { class: "plain" }, rule.effects.map((e) => h("li", {},
    h("b", {}, e.what), ` in ${e.contexts} of ${total} contexts`, h("span", { class: "muted small" }, ` — e.g. ${contextText(e.example)}`))));
}


const lit = (b, k) => (b[k] ? termCell(b[k]) : "");
const link = (b, k, label) => (b[k] ? iriLink(b[k].value, label && b[label] ? b[label].value : undefined) : "");

async function extractorSection(iri, token) {
  const [spec, configs, fx] = await Promise.all([
    api(`/v1/extractors/${encodeURIComponent(token)}`),
    select(`SELECT ?cfg ?label (COUNT(?m) AS ?windows) (SUM(COALESCE(?ate, 0.0)) / COUNT(?ate) AS ?meanAte) (COUNT(?ate) AS ?withAte) WHERE {
      ?cfg nfex:ofExtractor <${iri}> . OPTIONAL { ?cfg rdfs:label ?label }
      OPTIONAL { ?m sosa:usedProcedure ?cfg . OPTIONAL { ?m nfex:ateRmse ?ate } }
    } GROUP BY ?cfg ?label ORDER BY DESC(?windows) ?meanAte LIMIT 60`),
    effects(),
  ]);
  const params = Object.entries(spec.parameters);
  const mine = fx.rules.filter((r) => r.effects.some((e) => new RegExp(`\\b${token}\\b`).test(e.what)));
  return [
    h("h2", {}, `Extractor ${spec.name}`, h("span", { class: "muted small" }, `  ${spec.constructor} · ${spec.norm} · ${spec.descriptor_kind}`)),
    h("h3", {}, "Parameters"),
    rowsTable(["parameter", "role", "datatype", "default", "range", "tunable"], params, ([n, p]) => [
      iriLink(p.iri, n), p.role, p.datatype, fmt(p.default, 6),
      p.allowed ? p.allowed.join(", ") : `${p.min ?? "−∞"} … ${p.max ?? "∞"}`, p.tunable ? "yes" : "no"], [3]),
    h("h3", {}, "Configurations and their measurements"),
    rowsTable(["configuration", "measurements", "with ATE", "mean ATE (m)"], configs, (b) => [link(b, "cfg", "label"), lit(b, "windows"), lit(b, "withAte"), lit(b, "meanAte")], [1, 2, 3]),
    h("h3", {}, "Rules, statements and shapes that act on it"),
    mine.length ? h("ul", { class: "plain" }, mine.map((r) => h("li", {}, h("span", { class: "tag" }, r.kind), " ", iriLink(r.iri, r.label), " ",
      h("span", { class: "muted small" }, r.effects.filter((e) => e.what.includes(token)).map((e) => `${e.what} in ${e.contexts}`).join("; "))))) : h("p", { class: "muted" }, "none"),
  ];
}

async function configurationSection(iri) {
  const [settings, ms] = await Promise.all([
    select(`SELECT ?p ?param ?value WHERE { <${iri}> nfex:hasSetting ?s . ?s nfex:parameter ?p ; nfex:value ?value . OPTIONAL { ?p nfex:opencvName ?param } } ORDER BY ?param`),
    select(`SELECT ?m ?seq ?ate ?ms ?start ?end (GROUP_CONCAT(DISTINCT ?cv; separator=", ") AS ?conditions) WHERE {
      ?m sosa:usedProcedure <${iri}> . OPTIONAL { ?m nfex:sequence ?seq } OPTIONAL { ?m nfex:ateRmse ?ate } OPTIONAL { ?m nfex:extractionMs ?ms }
      OPTIONAL { ?m nfex:windowStart ?start } OPTIONAL { ?m nfex:windowEnd ?end }
      OPTIONAL { ?m nfex:underCondition/nfex:token ?cv } } GROUP BY ?m ?seq ?ate ?ms ?start ?end ORDER BY ?seq ?start LIMIT 200`),
  ]);
  return [
    h("h2", {}, "Configuration"),
    h("h3", {}, "Settings (α, Θ)"),
    rowsTable(["parameter", "value"], settings, (b) => [link(b, "p", "param"), lit(b, "value")], [1]),
    h("h3", {}, `Measurements (${ms.length}${ms.length === 200 ? "+" : ""})`),
    rowsTable(["measurement", "sequence", "window", "conditions", "ATE (m)", "extraction ms"], ms, (b) => [
      link(b, "m"), link(b, "seq"), b.start ? `${val(b, "start")}–${val(b, "end")}` : "", val(b, "conditions") || "",
      b.ate ? lit(b, "ate") : h("span", { class: "tag bad" }, "failed"), lit(b, "ms")], [4, 5]),
  ];
}

async function measurementSection(iri) {
  const [prov, metrics] = await Promise.all([
    select(`SELECT ?run ?runLabel ?agent ?agentLabel ?agentType ?code ?command ?cpu ?started ?attributed ?attributedLabel WHERE {
      OPTIONAL { <${iri}> prov:wasGeneratedBy ?run . OPTIONAL { ?run rdfs:label ?runLabel } OPTIONAL { ?run nfex:codeVersion ?code }
        OPTIONAL { ?run nfex:command ?command } OPTIONAL { ?run prov:startedAtTime ?started }
        OPTIONAL { ?run prov:wasAssociatedWith ?agent . OPTIONAL { ?agent rdfs:label ?agentLabel } OPTIONAL { ?agent nfex:cpuModel ?cpu } OPTIONAL { ?agent a ?agentType } } }
      OPTIONAL { <${iri}> prov:wasAttributedTo ?attributed . OPTIONAL { ?attributed rdfs:label ?attributedLabel } } } LIMIT 5`),
    select(`SELECT ?metric ?value WHERE { <${iri}> nfex:hasMetricResult ?r . ?r nfex:metric ?metric ; nfex:value ?value } ORDER BY ?metric`),
  ]);
  const p = prov[0] || {};
  return [
    h("h2", {}, "Measurement"),
    h("h3", {}, "Provenance and source"),
    h("dl", { class: "kv", id: "provenance" },
      h("dt", {}, "generated by"), h("dd", {}, link(p, "run", "runLabel"), p.started ? h("span", { class: "muted" }, `  started ${val(p, "started")}`) : null),
      h("dt", {}, "run by"), h("dd", {}, link(p, "agent", "agentLabel"), p.agentType ? h("span", { class: "muted" }, ` (${short(val(p, "agentType"))})`) : null, p.cpu ? ` on ${val(p, "cpu")}` : null),
      h("dt", {}, "attributed to"), h("dd", {}, p.attributed ? link(p, "attributed", "attributedLabel") : h("span", { class: "muted" }, "— (a sweep: the run's machine)")),
      h("dt", {}, "code"), h("dd", {}, val(p, "code") || ""),
      h("dt", {}, "command"), h("dd", { class: "mono small" }, val(p, "command") || "")),
    h("h3", {}, "Quality metrics over the window"),
    rowsTable(["metric", "mean"], metrics, (b) => [link(b, "metric"), lit(b, "value")], [1]),
  ];
}

async function conditionValueSection(iri) {
  const [by, statements] = await Promise.all([
    select(`SELECT ?x (COUNT(?m) AS ?windows) (COUNT(?ate) AS ?withAte) (SUM(COALESCE(?ate, 0.0)) / COUNT(?ate) AS ?meanAte) WHERE {
      ?m nfex:underCondition <${iri}> ; sosa:usedProcedure/nfex:ofExtractor/nfex:token ?x . OPTIONAL { ?m nfex:ateRmse ?ate } } GROUP BY ?x ORDER BY ?meanAte`),
    select(`SELECT DISTINCT ?st ?label WHERE { ?st nfex:hasCondition/nfex:oneOf <${iri}> ; rdfs:label ?label } ORDER BY ?label LIMIT 100`),
  ]);
  return [
    h("h2", {}, "Condition value"),
    h("h3", {}, "Measured under it"),
    rowsTable(["extractor", "measurements", "with ATE", "mean ATE (m)"], by, (b) => [val(b, "x"), lit(b, "windows"), lit(b, "withAte"), lit(b, "meanAte")], [1, 2, 3]),
    h("h3", {}, "Program statements that name it"),
    rowsTable(["statement"], statements, (b) => [link(b, "st", "label")]),
  ];
}

async function ruleSection(iri, types) {
  const fx = await effects();
  const rule = fx.rules.find((r) => r.iri === iri);
  const out = [h("h2", {}, "What it does")];
  if (types.includes(NFEX + "SparqlRule")) {
    const q = await select(`SELECT ?q WHERE { <${iri}> nfex:query ?q }`);
    if (q.length) out.push(h("h3", {}, "Query (context variables ?agent, ?light, … are bound per context)"), h("pre", { class: "triples" }, val(q[0], "q")));
  }
  if (!rule) {
    out.push(h("p", { class: "muted" }, `It shapes no decision in any of the ${fx.contexts} contexts at this graph version (disabled, or its conditions never hold).`));
    return out;
  }
  out.push(effectList(rule, fx.contexts));
  if (rule.reasons.length) out.push(h("h3", {}, "What it cites"), h("ul", {}, rule.reasons.map((r) => h("li", {}, r))));
  if (rule.source) out.push(h("p", { class: "muted small" }, `source: ${rule.source}`));
  return out;
}

async function home(root) {
  const [xs, conds, fx, progs, sparqlRules] = await Promise.all([api("/v1/extractors"), api("/v1/conditions"), effects(), api("/v1/programs"), api("/v1/rules")]);
  const byKind = { sparql: [] };
  for (const r of fx.rules) (byKind[r.kind] ??= []).push(r);
  for (const r of sparqlRules.rules) {  // a SPARQL rule that prunes nowhere at this version is listed too
    if (!fx.rules.some((x) => x.iri === r.iri)) byKind.sparql.push({ iri: r.iri, label: r.label + (r.enabled ? "" : " (disabled)"), effects: [] });
  }
  const kinds = { sparql: "SPARQL pruning rules", shape: "Context shapes", require: "require statements", prune: "prune statements", adjust: "adjust statements",
    weight: "weight statements", prefer: "prefer statements", budget: "budget rules" };
  const jump = h("input", { type: "text", placeholder: "an IRI or nfex:Name", "aria-label": "IRI", style: "width:340px" });
  clear(root,
    h("h1", {}, "Browse the graph"),
    h("form", { class: "toolbar", onsubmit: (e) => { e.preventDefault(); location.hash = `#/browse?iri=${encodeURIComponent(expand(jump.value.trim()))}`; } }, jump, h("button", {}, "Open")),
    h("h2", {}, "Extractors"),
    h("div", { class: "cards", id: "extractor-cards" }, xs.extractors.map((x) => h("div", { class: "panel" },
      h("h3", {}, iriLink(x.iri, x.name), x.label && x.label !== x.name ? h("span", { class: "muted small" }, `  ${x.label}`) : null),
      h("div", { class: "small muted" }, `${x.constructor} · ${x.descriptor_kind} · ${x.norm}`),
      h("div", { class: "small" }, Object.keys(x.parameters).join(", "))))),
    h("h2", {}, "Conditions"),
    h("div", { class: "cards" }, Object.entries(conds.dimensions).map(([d, spec]) => h("div", { class: "panel" },
      h("h3", {}, iriLink(spec.iri, d), spec.estimable ? h("span", { class: "tag" }, "estimated from frames") : null),
      h("div", {}, Object.entries(spec.values).map(([v, x], i) => [i ? ", " : "", iriLink(x.iri, v)]))))),
    h("h2", { id: "rules" }, "Rules, statements and context shapes"),
    h("p", { class: "muted" }, `Effects over the ${fx.contexts} contexts of graph version ${fx.graph_version}, from the compiled rule table. Programs: `,
      progs.programs.map((p, i) => [i ? ", " : "", h("a", { href: `#/programs?name=${encodeURIComponent(p.name)}` }, p.name)])),
    Object.entries(byKind).map(([k, list]) => h("div", { class: "panel" }, h("h3", {}, kinds[k] || k, h("span", { class: "muted small" }, ` (${list.length})`)),
      rowsTable(["rule", "effects"], list, (r) => [iriLink(r.iri, r.label),
        r.effects.length ? h("span", { class: "small" }, r.effects.slice(0, 3).map((e) => `${e.what} in ${e.contexts}`).join("; ") + (r.effects.length > 3 ? "; …" : ""))
          : h("span", { class: "small muted" }, "prunes nothing in any context at this graph version")]))));
  if (new URLSearchParams(location.hash.split("?")[1] || "").get("section") === "rules") document.getElementById("rules").scrollIntoView();
}

export async function view(root, params) {
  const iri = params.get("iri");
  if (!iri) return home(root);
  if (/[<>"{}|^`\\\s]/.test(iri)) return clear(root, h("div", { class: "error" }, `not an IRI: ${iri}`));
  const [out, inc] = await Promise.all([
    select(`SELECT ?p ?o WHERE { <${iri}> ?p ?o } ORDER BY ?p ?o LIMIT 500`),
    select(`SELECT ?s ?p WHERE { ?s ?p <${iri}> } ORDER BY ?p ?s LIMIT 300`),
  ]);
  const types = out.filter((b) => b.p.value === PREFIXES.rdf + "type").map((b) => b.o.value);
  const label = out.find((b) => b.p.value === PREFIXES.rdfs + "label");
  const comment = out.find((b) => b.p.value === PREFIXES.rdfs + "comment" || b.p.value === PREFIXES.sh + "message");
  const token = out.find((b) => b.p.value === NFEX + "token");
  let special = [];
  const has = (t) => types.includes(NFEX + t);
  if (has("FeatureExtractor") && token) special = await extractorSection(iri, token.o.value);
  else if (has("Configuration")) special = await configurationSection(iri);
  else if (has("Measurement")) special = await measurementSection(iri);
  else if (has("ConditionValue")) special = await conditionValueSection(iri);
  else if (has("SparqlRule") || has("ContextShape") || has("MeasuredRule") || types.some((t) => /Statement$/.test(t))) special = await ruleSection(iri, types);
  else if (has("Program")) special = [h("p", {}, h("a", { href: `#/programs?name=${encodeURIComponent(label ? label.o.value : "")}` }, "Open this program in the editor"))];
  clear(root,
    h("p", { class: "small" }, h("a", { href: "#/browse" }, "Browse"), " / ", types.map((t, i) => [i ? ", " : "", iriLink(t)])),
    h("h1", {}, label ? label.o.value : short(iri), h("span", { class: "muted small" }, "  " + iri)),
    comment ? h("p", {}, comment.o.value) : null,
    h("div", { class: "panel", id: "browse-special" }, special.length ? special : h("p", { class: "muted" }, "Its triples:")),
    h("div", { class: "row" },
      h("div", { class: "panel grow" }, h("h3", {}, `Outgoing (${out.length}${out.length === 500 ? "+" : ""})`),
        rowsTable(["predicate", "object"], out, (b) => [iriLink(b.p.value), termCell(b.o)])),
      h("div", { class: "panel grow" }, h("h3", {}, `Incoming (${inc.length}${inc.length === 300 ? "+" : ""})`),
        rowsTable(["subject", "predicate"], inc, (b) => [termCell(b.s), iriLink(b.p.value)]))));
}
