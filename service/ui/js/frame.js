// Try a frame: upload an image (or pick a dataset frame) and a context; show α*, Θ′ with each adjustment
// and its reason, the pruned candidates and what pruned them, the scores, the estimated conditions with
// their confidence, and the chosen extractor's keypoints drawn on the frame.

import { Problem, api } from "./api.js";
import { clear, fmt, h, iriLink } from "./dom.js";

function cite(c) {
  return h("div", { class: "small" }, iriLink(c.rule, c.label), c.source ? h("span", { class: "muted" }, ` (${c.source})`) : null,
    c.reason ? h("div", { class: "muted" }, c.reason) : null);
}

async function drawFrame(canvas, blob, keypoints) {
  const img = await createImageBitmap(blob);
  canvas.width = img.width;
  canvas.height = img.height;
  const g = canvas.getContext("2d");
  g.drawImage(img, 0, 0);
  if (!keypoints) return;
  const sx = img.width / keypoints.width, sy = img.height / keypoints.height;
  g.lineWidth = Math.max(1, img.width / 900);
  g.strokeStyle = "rgba(0, 230, 118, 0.9)";
  keypoints.xy.forEach(([x, y], i) => {
    const r = Math.min(12, Math.max(2, (keypoints.size[i] || 4) / 2)) * sx;
    g.beginPath();
    g.arc(x * sx, y * sy, r, 0, 2 * Math.PI);
    g.stroke();
  });
}

function selectionView(sel) {
  const chosen = sel.candidates.find((c) => c.extractor === sel.extractor) || { adjustments: [], evidence: {} };
  const adjusted = Object.fromEntries(chosen.adjustments.map((a) => [a.parameter, a]));
  const theta = Object.entries(sel.params).map(([k, v]) => {
    const a = adjusted[k];
    return h("tr", { class: a ? "changed" : null }, h("td", { class: "mono" }, k), h("td", { class: "num" }, fmt(v, 6)),
      h("td", {}, a ? [h("div", { class: "small" }, `${fmt(a.from, 6)} → ${fmt(a.to, 6)} (× ${fmt(a.factor)})${a.clamped ? " clamped to the range" : ""}`), a.because.map(cite)] : null));
  });
  const config = chosen.evidence.configuration;
  const scores = sel.candidates.map((c) => h("tr", { class: c.extractor === sel.extractor ? "changed" : null },
    h("td", {}, h("b", {}, c.extractor)), h("td", { class: "num" }, fmt(c.score, 4)), h("td", { class: "num" }, fmt(c.evidence.f_metrics, 4)),
    h("td", { class: "num" }, fmt(c.bonus)), h("td", { class: "num" }, fmt(c.evidence.measured_accuracy)),
    h("td", { class: "num" }, fmt(c.evidence.ate_m, 4)), h("td", { class: "num" }, c.evidence.windows ?? ""),
    h("td", { class: "num" }, c.keypoints ?? ""), h("td", { class: "num" }, fmt(c.extraction_ms, 1)),
    h("td", { class: "small mono" }, Object.entries(c.metrics).map(([m, v]) => `${m} ${fmt(v, 2)}`).join(" · "))));
  const pruned = sel.pruned.map((p) => h("tr", {}, h("td", {}, h("b", {}, p.extractor)),
    h("td", {}, p.because.map((c) => h("div", {}, h("span", { class: "tag" }, c.kind), " ", cite(c))))));
  const conditions = sel.context.map((c) => h("tr", {}, h("td", {}, c.dimension), h("td", {}, c.value ?? h("span", { class: "muted" }, "unknown")),
    h("td", {}, c.source), h("td", {}, c.confidence !== undefined ? [h("span", { class: "conf" }, h("span", { class: "bar", style: `width:${Math.round(80 * c.confidence)}px` })), fmt(c.confidence, 2)] : "")));
  return h("div", { id: "selection" },
    h("div", { class: "panel" },
      h("div", {}, h("span", { class: "muted" }, "α* "), h("span", { class: "alpha", id: "alpha" }, sel.extractor),
        h("span", { class: "muted" }, `  mode ${sel.mode} · ${sel.opencv.constructor} · ${sel.opencv.norm} · graph v${sel.versions.graph} · ${fmt(sel.timings_ms.total, 1)} ms`)),
      sel.warnings.length ? h("div", { class: "note" }, sel.warnings.join("\n")) : null,
      config ? h("p", { class: "small" }, "Θ′ is the configuration measured best here: ", iriLink(config.iri), ` (median ATE ${fmt(config.ate_m)} m over ${config.windows} windows)`) : null,
      h("h3", {}, "Θ′ and why"), h("table", { class: "grid", id: "theta" }, h("thead", {}, h("tr", {}, ["parameter", "value", "adjustments and reasons"].map((x) => h("th", {}, x)))), h("tbody", {}, theta))),
    h("div", { class: "panel" }, h("h3", {}, "Scores"),
      h("div", { class: "scroll" }, h("table", { class: "grid", id: "scores" },
        h("thead", {}, h("tr", {}, ["candidate", "score", "F_metrics", "bonus", "A (measured)", "median ATE m", "windows", "keypoints", "ms", "metrics"].map((x) => h("th", {}, x)))),
        h("tbody", {}, scores)))),
    h("div", { class: "row" },
      h("div", { class: "panel grow" }, h("h3", {}, "Pruned candidates"), pruned.length ? h("table", { class: "grid", id: "pruned" }, h("tbody", {}, pruned)) : h("p", { class: "muted" }, "none")),
      h("div", { class: "panel grow" }, h("h3", {}, "Conditions"), h("table", { class: "grid", id: "conditions" },
        h("thead", {}, h("tr", {}, ["dimension", "value", "source", "confidence"].map((x) => h("th", {}, x)))), h("tbody", {}, conditions)))));
}

export async function view(root, params) {
  const [vocab, samples] = await Promise.all([api("/v1/vocabulary"), api("/v1/samples").catch(() => ({ samples: [] }))]);
  let blob = null, name = "frame.png";
  const file = h("input", { type: "file", accept: "image/png,image/jpeg", id: "frame-file", "aria-label": "frame file" });
  const sample = h("select", { id: "sample", "aria-label": "dataset frame" }, h("option", { value: "" }, samples.samples.length ? "or pick a dataset frame…" : "(no dataset folder)"),
    samples.samples.map((s) => h("option", { value: s.id }, `${s.dataset} ${s.sequence} #${s.index}`)));
  const dims = Object.entries(vocab.context);
  const selects = Object.fromEntries(dims.map(([d, spec]) => [d, h("select", { name: d, "aria-label": d },
    h("option", { value: "" }, spec.estimable ? "estimate from the frame" : "unknown"), spec.values.map((v) => h("option", { value: v }, v)))]));
  const budget = h("input", { type: "number", min: "0", step: "1", placeholder: "none", "aria-label": "budget ms", style: "width:90px" });
  const canvas = h("canvas", { id: "frame-canvas", width: "640", height: "200" });
  const info = h("div", { class: "muted small", id: "keypoint-info" });
  const out = h("div", { id: "frame-out" });
  const go = h("button", { class: "primary", id: "select-btn", disabled: true, onclick: run }, "Select");

  async function useBlob(b, n) {
    blob = b; name = n;
    go.disabled = false;
    clear(info, `${n}`);
    await drawFrame(canvas, blob, null);
  }
  file.addEventListener("change", () => { if (file.files[0]) { sample.value = ""; useBlob(file.files[0], file.files[0].name); } });
  sample.addEventListener("change", async () => {
    const s = samples.samples.find((x) => x.id === sample.value);
    if (!s) return;
    for (const [d, v] of Object.entries(s.context)) if (selects[d]) selects[d].value = v;
    const r = await api(`/v1/samples/${encodeURIComponent(s.id)}`, { raw: true });
    await useBlob(await r.blob(), s.file);
  });

  async function run() {
    const context = {};
    for (const [d, sel] of Object.entries(selects)) if (sel.value) context[d] = sel.value;
    if (budget.value) context.budget_ms = budget.value;
    const form = new FormData();
    form.append("frame", blob, name);
    form.append("context", JSON.stringify(context));
    clear(out, h("p", { class: "muted" }, "Selecting…"));
    try {
      const sel = await api("/v1/select?keypoints=true", { method: "POST", body: form });
      await drawFrame(canvas, blob, sel.keypoints);
      clear(info, `${name}: ${sel.keypoints.count} ${sel.keypoints.extractor} keypoints with Θ′ on the full ${sel.keypoints.width}×${sel.keypoints.height} frame` +
        (sel.keypoints.count > sel.keypoints.xy.length ? ` (the strongest ${sel.keypoints.xy.length} drawn)` : "") + `, extracted in ${fmt(sel.keypoints.extraction_ms, 1)} ms`);
      clear(out, selectionView(sel));
    } catch (e) {
      const d = e instanceof Problem ? e.doc : { detail: String(e) };
      const pruned = d.pruned ? d.pruned.map((p) => `\n${p.extractor}: ${p.because.map((c) => c.reason).join("; ")}`) : [];
      clear(out, h("div", { class: "error", role: "alert" }, h("b", {}, `${d.title || "Error"}: `), d.detail, d.allowed ? `\nallowed: ${d.allowed.join(", ")}` : "", pruned));
    }
  }

  clear(root,
    h("h1", {}, "Try a frame"),
    h("div", { class: "row" },
      h("div", { class: "panel side", style: "width:330px" },
        h("h3", {}, "Frame"), file, h("div", { class: "toolbar" }, sample),
        h("h3", {}, "Context"),
        h("div", { class: "context-form" }, dims.map(([d]) => [h("label", {}, d), selects[d]]), h("label", {}, "budget ms"), budget),
        h("div", { class: "toolbar" }, go)),
      h("div", { class: "grow" }, h("div", { class: "panel" }, h("div", { class: "frame-wrap" }, canvas), info), out)));
  if (params.get("sample")) { sample.value = params.get("sample"); sample.dispatchEvent(new Event("change")); }
}
