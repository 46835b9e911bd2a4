// The service's HTTP API, same origin. Errors arrive as RFC 9457 problem+json and are thrown as Problem.
// The editor token lives in sessionStorage (this tab only) and goes in the Authorization header, never a URL.

const TOKEN_KEY = "nfex.token";

export class Problem extends Error {
  constructor(status, doc) {
    super(doc.detail || doc.title || `HTTP ${status}`);
    this.status = status;
    this.doc = doc;
  }
}

export const token = {
  get: () => sessionStorage.getItem(TOKEN_KEY) || "",
  set: (v) => (v ? sessionStorage.setItem(TOKEN_KEY, v) : sessionStorage.removeItem(TOKEN_KEY)),
};

/** fetch a path of the service; JSON bodies in and out; throws Problem on an error status. */
export async function api(path, { method = "GET", json, body, headers = {}, accept, auth = false, raw = false } = {}) {
  const h = { ...headers };
  if (json !== undefined) { h["Content-Type"] = "application/json"; body = JSON.stringify(json); }
  if (accept) h["Accept"] = accept;
  if (auth) {
    const t = token.get();
    if (!t) throw new Problem(401, { title: "No token", detail: "this change needs an editor token: enter it at the top right" });
    h["Authorization"] = "Bearer " + t;
  }
  let r;
  try {
    r = await fetch(path, { method, headers: h, body });
  } catch (e) {
    throw new Problem(0, { title: "Service unreachable", detail: `the nFEX service did not answer (${e.message})` });
  }
  if (!r.ok) {
    let doc;
    try { doc = await r.json(); } catch { doc = { title: r.statusText, detail: `HTTP ${r.status}` }; }
    throw new Problem(r.status, doc);
  }
  if (raw) return r;
  const type = r.headers.get("content-type") || "";
  return type.includes("json") ? r.json() : r.text();
}

/** A SELECT/ASK query's JSON results (nFEX's prefixes are predeclared by the service). */
export async function sparql(query, accept = "application/sparql-results+json") {
  return api("/sparql", { method: "POST", body: query, headers: { "Content-Type": "application/sparql-query" }, accept });
}

/** rows of a SELECT as plain objects: variable → {type, value, datatype?, "xml:lang"?} */
export async function select(query) {
  const res = await sparql(query);
  return res.results.bindings;
}

export const val = (b, k) => (b[k] ? b[k].value : null);
export const num = (b, k) => (b[k] ? Number(b[k].value) : null);
