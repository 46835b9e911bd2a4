// Graph versions: the list, one version's change set, the net diff between two, rollback (editor token).

import { Problem, api } from "./api.js";
import { refreshVersion } from "./app.js";
import { clear, h, short } from "./dom.js";

const shortTriple = (t) => t.replace(/<([^<>\s]+)>/g, (m, iri) => (short(iri) === iri ? m : short(iri)));

function triples(change) {
  const lines = [
    ...change.removed.map((t) => h("div", { class: "diff-del" }, "− " + shortTriple(t))),
    ...change.added.map((t) => h("div", { class: "diff-add" }, "+ " + shortTriple(t))),
  ];
  return h("div", {},
    h("p", {}, h("span", { class: "diff-add" }, `+${change.added_count} added`), " · ", h("span", { class: "diff-del" }, `−${change.removed_count} removed`),
      change.truncated ? h("span", { class: "muted" }, " (first 5,000 of each shown)") : null),
    lines.length ? h("div", { class: "triples" }, lines) : h("p", { class: "muted" }, "no triples"));
}

export async function view(root, params) {
  const data = await api("/v1/graph/versions?limit=200");
  const head = data.versions.length ? data.versions[0].version : 0;
  const detail = h("div", { id: "version-detail" });
  const since = h("input", { type: "number", min: "0", value: String(Math.max(0, head - 1)), "aria-label": "since", style: "width:80px" });
  const until = h("input", { type: "number", min: "0", value: String(head), "aria-label": "until", style: "width:80px" });

  async function show(n) {
    clear(detail, h("p", { class: "muted" }, "Loading…"));
    try {
      const v = await api(`/v1/graph/versions/${n}`);
      clear(detail, h("div", { class: "panel" },
        h("h2", {}, `Version ${v.version}`, h("span", { class: "muted small" }, `  ${v.author} · ${v.time || ""}`)),
        h("p", {}, v.message),
        triples(v),
        v.version < head ? h("div", { class: "toolbar" },
          h("button", { class: "danger", id: "rollback-btn", onclick: () => rollback(v.version) }, `Roll back to version ${v.version}`),
          h("span", { class: "muted small" }, "restores this version's knowledge as a new version (history is kept); needs the editor token")) : null));
    } catch (e) {
      clear(detail, h("div", { class: "error" }, e.message));
    }
  }
  async function diff() {
    clear(detail, h("p", { class: "muted" }, "Loading…"));
    try {
      const d = await api(`/v1/graph/diff?since=${Number(since.value)}&until=${Number(until.value)}`);
      clear(detail, h("div", { class: "panel" }, h("h2", {}, `Net change from version ${d.since} to ${d.until}`), triples(d)));
    } catch (e) {
      clear(detail, h("div", { class: "error" }, e.message));
    }
  }
  async function rollback(n) {
    try {
      const r = await api("/v1/graph/rollback", { method: "POST", json: { to: n }, headers: { "If-Match": `"${head}"` }, auth: true });
      refreshVersion();
      location.hash = `#/versions?v=${r.version}`;
    } catch (e) {
      const d = e instanceof Problem ? e.doc : { detail: String(e) };
      detail.prepend(h("div", { class: "error", role: "alert" }, h("b", {}, `${d.title || "Error"}: `), d.detail));
    }
  }

  const selected = Number(params.get("v") || head);
  clear(root,
    h("h1", {}, "Graph versions"),
    h("div", { class: "row" },
      h("div", { class: "grow" },
        h("div", { class: "panel" },
          h("div", { class: "toolbar" }, "Net diff from ", since, " to ", until, h("button", { onclick: diff, id: "diff-btn" }, "Diff")),
          h("div", { class: "scroll" }, h("table", { class: "grid", id: "versions-table" },
            h("thead", {}, h("tr", {}, ["version", "author", "time", "message", "+", "−"].map((x) => h("th", {}, x)))),
            h("tbody", {}, data.versions.map((v) => h("tr", { class: v.version === selected ? "changed" : null },
              h("td", {}, h("a", { href: `#/versions?v=${v.version}` }, String(v.version))),
              h("td", {}, v.author), h("td", { class: "small" }, (v.time || "").replace("T", " ").slice(0, 19)),
              h("td", {}, v.message), h("td", { class: "num diff-add" }, String(v.added)), h("td", { class: "num diff-del" }, String(v.removed))))))))),
      h("div", { class: "grow" }, detail)));
  if (selected) show(selected);
}
