// The workbench's shell: hash routes (#/view?param=…), the editor token (sessionStorage), the graph version.

import { Problem, api, token } from "./api.js";
import { clear, h } from "./dom.js";

const VIEWS = {
  sparql: () => import("./sparql.js"),
  browse: () => import("./browse.js"),
  programs: () => import("./programs.js"),
  versions: () => import("./versions.js"),
  frame: () => import("./frame.js"),
  evidence: () => import("./evidence.js"),
};

export function route() {
  const hash = location.hash.replace(/^#\/?/, "");
  const [name, query = ""] = hash.split(/\?(.*)/s);
  return { name: VIEWS[name] ? name : "sparql", params: new URLSearchParams(query) };
}

let rendering = 0;

async function render() {
  const { name, params } = route();
  const root = document.getElementById("view");
  const mine = ++rendering;
  for (const a of document.querySelectorAll("#nav a")) a.classList.toggle("active", a.dataset.view === name);
  document.title = `nFEX workbench · ${document.querySelector(`#nav a[data-view=${name}]`).textContent}`;
  refreshVersion();
  try {
    const mod = await VIEWS[name]();
    if (mine !== rendering) return;
    const el = h("div", { class: "view", id: `view-${name}` });
    clear(root, el);
    await mod.view(el, params);
  } catch (e) {
    if (mine !== rendering) return;
    const detail = e instanceof Problem ? e.doc.detail || e.message : `${e.name}: ${e.message}`;
    root.append(h("div", { class: "error", role: "alert" }, h("b", {}, "This view failed: "), detail));
    console.error(e);
  }
}

export async function refreshVersion() {
  try {
    const head = await api("/v1/graph");
    document.getElementById("graph-version").textContent = `graph v${head.version} · ${head.triples} triples`;
  } catch {
    document.getElementById("graph-version").textContent = "service unreachable";
  }
}

function setupToken() {
  const form = document.getElementById("token-form");
  const input = document.getElementById("token");
  const forget = document.getElementById("token-forget");
  const show = () => {
    const held = !!token.get();
    form.classList.toggle("held", held);
    forget.hidden = !held;
    input.placeholder = held ? "token held for this tab" : "editor token";
  };
  form.addEventListener("submit", (e) => {
    e.preventDefault();
    if (input.value.trim()) token.set(input.value.trim());
    input.value = "";
    show();
  });
  forget.addEventListener("click", () => { token.set(""); show(); });
  show();
}

setupToken();
window.addEventListener("hashchange", render);
render();
