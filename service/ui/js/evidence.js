// Evidence: measured ATE by extractor and condition (what an expert asks for first), the sources of the
// measurements (runs, machines, clients) and the feedback clients reported.

import { select, val } from "./api.js";
import { groupedBars } from "./chart.js";
import { clear, fmt, h, iriLink, rowsTable } from "./dom.js";
import { termCell } from "./results.js";

export const ATE_BY_CONDITION = `SELECT ?extractor ?dimension ?value (SUM(COALESCE(?ate, 0.0)) / COUNT(?ate) AS ?meanAte) (COUNT(?m) AS ?windows) (COUNT(?ate) AS ?withAte) WHERE {
  ?m a nfex:Measurement ; sosa:usedProcedure/nfex:ofExtractor/nfex:token ?extractor ; nfex:underCondition ?c .
  ?c nfex:token ?value ; nfex:inDimension/nfex:token ?dimension .
  OPTIONAL { ?m nfex:ateRmse ?ate }
} GROUP BY ?extractor ?dimension ?value ORDER BY ?dimension ?value ?extractor`;

const SOURCES = `SELECT ?run ?runLabel ?agent ?agentLabel ?cpu (COUNT(?m) AS ?measurements) (MIN(?started) AS ?since) WHERE {
  ?m a nfex:Measurement ; prov:wasGeneratedBy ?run .
  OPTIONAL { ?run rdfs:label ?runLabel } OPTIONAL { ?run prov:startedAtTime ?started }
  OPTIONAL { ?run prov:wasAssociatedWith ?agent . OPTIONAL { ?agent rdfs:label ?agentLabel } OPTIONAL { ?agent nfex:cpuModel ?cpu } }
} GROUP BY ?run ?runLabel ?agent ?agentLabel ?cpu ORDER BY DESC(?measurements)`;

const FEEDBACK = `SELECT ?m ?agent ?agentLabel ?run ?runLabel ?extractor ?ate ?lost ?seq ?time (GROUP_CONCAT(DISTINCT ?cv; separator=", ") AS ?conditions) WHERE {
  ?m a nfex:Measurement ; prov:wasAttributedTo ?agent ; sosa:usedProcedure/nfex:ofExtractor/nfex:token ?extractor .
  OPTIONAL { ?agent rdfs:label ?agentLabel } OPTIONAL { ?m prov:wasGeneratedBy ?run . ?run rdfs:label ?runLabel }
  OPTIONAL { ?m nfex:ateRmse ?ate } OPTIONAL { ?m nfex:trackingLost ?lost }
  OPTIONAL { ?m nfex:sequence ?seq } OPTIONAL { ?m sosa:resultTime ?time } OPTIONAL { ?m nfex:underCondition/nfex:token ?cv }
} GROUP BY ?m ?agent ?agentLabel ?run ?runLabel ?extractor ?ate ?lost ?seq ?time ORDER BY DESC(?time) LIMIT 200`;

const sparqlLink = (q) => h("a", { href: `#/sparql?query=${encodeURIComponent(q)}`, class: "small" }, "open the query");


export async function view(root) {
  const [ates, sources, feedback] = await Promise.all([select(ATE_BY_CONDITION), select(SOURCES), select(FEEDBACK)]);
  const extractors = [...new Set(ates.map((b) => val(b, "extractor")))].sort();
  const dims = [...new Set(ates.map((b) => val(b, "dimension")))];
  const cell = {};
  for (const b of ates) cell[`${val(b, "dimension")}|${val(b, "value")}|${val(b, "extractor")}`] = b;
  const charts = dims.map((d) => {
    const values = [...new Set(ates.filter((b) => val(b, "dimension") === d).map((b) => val(b, "value")))];
    const get = (v, x) => cell[`${d}|${v}|${x}`];
    return groupedBars(values, extractors, (v, x) => (get(v, x) && get(v, x).meanAte ? Number(val(get(v, x), "meanAte")) : NaN), {
      title: d, yLabel: "mean ATE (m)",
      note: (v, x) => { const b = get(v, x); return b ? `${val(b, "windows")} windows, ${Number(val(b, "windows")) - Number(val(b, "withAte"))} failed` : ""; },
    });
  });
  clear(root,
    h("h1", {}, "Evidence"),
    h("div", { class: "panel", id: "ate-by-condition" },
      h("h2", {}, "Measured ATE by extractor and condition ", sparqlLink(ATE_BY_CONDITION)),
      h("p", { class: "muted" }, "Mean ATE RMSE (m) over the measurement windows made under each condition value; a window counts for every condition it was measured under. ",
        "Failed windows (tracking lost, no ATE) are counted in the tooltip. Lower is better."),
      ates.length ? h("div", { class: "charts" }, charts) : h("p", { class: "muted" }, "The graph holds no measurements yet (nfex sweep, or client feedback, adds them)."),
      ates.length ? h("details", {}, h("summary", {}, "numbers"), rowsTable(["dimension", "value", "extractor", "mean ATE (m)", "windows", "with ATE"], ates,
        (b) => [val(b, "dimension"), val(b, "value"), val(b, "extractor"), fmt(val(b, "meanAte"), 4), val(b, "windows"), val(b, "withAte")], [3, 4, 5])) : null),
    h("div", { class: "panel", id: "sources" },
      h("h2", {}, "Where the measurements come from ", sparqlLink(SOURCES)),
      rowsTable(["run", "associated with", "machine", "measurements", "started"], sources,
        (b) => [b.run ? iriLink(val(b, "run"), val(b, "runLabel")) : "", b.agent ? iriLink(val(b, "agent"), val(b, "agentLabel")) : "", val(b, "cpu") || "",
          val(b, "measurements"), (val(b, "since") || "").replace("T", " ").slice(0, 19)], [3])),
    h("div", { class: "panel", id: "feedback" },
      h("h2", {}, "Feedback from clients ", sparqlLink(FEEDBACK)),
      h("p", { class: "muted" }, "Measurements reported through POST /v1/feedback, attributed to the reporter whose token sent them; the run names the session or client. They steer selections once corroborated (GET /v1/feedback says which)."),
      rowsTable(["measurement", "reporter", "run", "extractor", "ATE (m)", "tracking lost", "sequence", "conditions", "time"], feedback,
        (b) => [iriLink(val(b, "m")), b.agent ? iriLink(val(b, "agent"), val(b, "agentLabel")) : "", b.run ? iriLink(val(b, "run"), val(b, "runLabel")) : "",
          val(b, "extractor"), b.ate ? termCell(b.ate) : "",
          val(b, "lost") ?? "", b.seq ? iriLink(val(b, "seq")) : "", val(b, "conditions") || "", (val(b, "time") || "").replace("T", " ").slice(0, 19)], [4, 5])));
}
