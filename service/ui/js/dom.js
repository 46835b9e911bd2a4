// Small DOM helpers: h() builds elements, fmt() prints numbers, short() prints IRIs with nFEX's prefixes.

export const PREFIXES = {
  nfex: "https://w3id.org/nfex#",
  rdf: "http://www.w3.org/1999/02/22-rdf-syntax-ns#",
  rdfs: "http://www.w3.org/2000/01/rdf-schema#",
  owl: "http://www.w3.org/2002/07/owl#",
  xsd: "http://www.w3.org/2001/XMLSchema#",
  sh: "http://www.w3.org/ns/shacl#",
  sosa: "http://www.w3.org/ns/sosa/",
  prov: "http://www.w3.org/ns/prov#",
  dcterms: "http://purl.org/dc/terms/",
};

/** h("div", {class: "x", onclick: fn}, child, "text", [more]) */
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith("on") && typeof v === "function") el.addEventListener(k.slice(2), v);
    else if (k === "class") el.className = v;
    else if (k === "dataset") Object.assign(el.dataset, v);
    else if (k === "value") el.value = v;
    else el.setAttribute(k, v === true ? "" : v);
  }
  append(el, children);
  return el;
}

function append(el, children) {
  for (const c of children) {
    if (c === undefined || c === null || c === false) continue;
    if (Array.isArray(c)) append(el, c);
    else el.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
}

export function clear(el, ...children) {
  el.replaceChildren();
  append(el, children);
  return el;
}

export function short(iri) {
  for (const [p, ns] of Object.entries(PREFIXES)) {
    if (iri.startsWith(ns) && /^[A-Za-z0-9_.-]*$/.test(iri.slice(ns.length))) return `${p}:${iri.slice(ns.length)}`;
  }
  return iri;
}

export function expand(name) {
  const m = /^([a-z]+):(.*)$/.exec(name);
  return m && PREFIXES[m[1]] ? PREFIXES[m[1]] + m[2] : name;
}

export function fmt(x, digits = 3) {
  if (x === null || x === undefined || x === "") return "";
  if (typeof x === "boolean") return String(x);
  const n = Number(x);
  if (!Number.isFinite(n)) return String(x);
  if (Number.isInteger(n)) return String(n);
  const a = Math.abs(n);
  return a !== 0 && (a < 1e-3 || a >= 1e6) ? n.toExponential(2) : String(Number(n.toFixed(digits)));
}

export function iriLink(iri, label) {
  return h("a", { href: "#/browse?iri=" + encodeURIComponent(iri), title: iri, class: "iri" }, label || short(iri));
}

/** A scrolling table of ``data``: cells(item) gives a row's cells; columns in ``numeric`` align right. */
export function rowsTable(headers, data, cells, numeric = []) {
  if (!data.length) return h("p", { class: "muted" }, "none");
  return h("div", { class: "scroll" }, h("table", { class: "grid" },
    h("thead", {}, h("tr", {}, headers.map((x) => h("th", {}, x)))),
    h("tbody", {}, data.map((r) => h("tr", {}, cells(r).map((c, i) => h("td", { class: numeric.includes(i) ? "num" : null }, c)))))));
}

export function contextText(ctx) {
  const parts = Object.entries(ctx || {}).filter(([, v]) => v !== null && v !== undefined).map(([d, v]) => `${d} = ${v}`);
  return parts.length ? parts.join(", ") : "(nothing known)";
}

export function debounce(fn, ms) {
  let t = null;
  return (...args) => { clearTimeout(t); t = setTimeout(() => fn(...args), ms); };
}
