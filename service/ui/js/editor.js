// A code editor without dependencies: a transparent <textarea> over a syntax-highlighted <pre>, a gutter
// with line numbers, an error marker at (line, column) and a completion list at the caret.

import { h } from "./dom.js";

const SPARQL_KEYWORDS = ("SELECT DISTINCT REDUCED WHERE FILTER OPTIONAL UNION MINUS GRAPH SERVICE BIND VALUES AS ORDER BY ASC DESC " +
  "LIMIT OFFSET GROUP HAVING PREFIX BASE ASK CONSTRUCT DESCRIBE FROM NAMED NOT EXISTS IN COUNT SUM AVG MIN MAX SAMPLE " +
  "GROUP_CONCAT SEPARATOR STR LANG LANGMATCHES DATATYPE BOUND IRI URI BNODE RAND ABS CEIL FLOOR ROUND CONCAT STRLEN UCASE " +
  "LCASE ENCODE_FOR_URI CONTAINS STRSTARTS STRENDS STRBEFORE STRAFTER YEAR MONTH DAY HOURS MINUTES SECONDS NOW COALESCE IF " +
  "sameTerm isIRI isURI isBLANK isLITERAL isNUMERIC REGEX REPLACE true false UNDEF").split(" ");
const DSL_KEYWORDS = "program prune adjust weight prefer require by when and is not one of because true false".split(" ");

const word = (list) => new RegExp(`^(?:${list.join("|")})$`, "i");

export const LANGUAGES = {
  sparql: {
    rules: [
      [/#[^\n]*/y, "com"],
      [/<[^<>"{}|^`\\\s]*>/y, "iri"],
      [/"""[\s\S]*?"""|'''[\s\S]*?'''|"(?:[^"\\\n]|\\.)*"|'(?:[^'\\\n]|\\.)*'/y, "str"],
      [/[?$][A-Za-z_][A-Za-z0-9_]*/y, "var"],
      [/(?:[A-Za-z][A-Za-z0-9_-]*)?:(?:[A-Za-z0-9_](?:[A-Za-z0-9_.-]*[A-Za-z0-9_-])?)?/y, "pn"],
      [/[+-]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?/y, "num"],
      [/[A-Za-z_][A-Za-z0-9_]*/y, (t) => (t === "a" || word(SPARQL_KEYWORDS).test(t) ? "kw" : null)],
      [/[{}().;,=<>!&|*/+-]/y, "op"],
    ],
  },
  nfex: {
    rules: [
      [/#[^\n]*/y, "com"],
      [/"(?:[^"\\\n]|\\.)*"/y, "str"],
      [/[+-]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?/y, "num"],
      [/[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)?/y, (t) => (word(DSL_KEYWORDS).test(t) ? "kw" : t.includes(".") ? "pn" : "var")],
      [/<=|>=|[<>=(),]/y, "op"],
    ],
  },
};

/** [{start, end, cls}] covering the classified parts of ``text`` */
export function tokenize(text, language) {
  const rules = LANGUAGES[language].rules;
  const out = [];
  let i = 0;
  outer: while (i < text.length) {
    for (const [re, cls] of rules) {
      re.lastIndex = i;
      const m = re.exec(text);
      if (m && m[0].length) {
        const c = typeof cls === "function" ? cls(m[0]) : cls;
        if (c) out.push({ start: i, end: i + m[0].length, cls: c });
        i += m[0].length;
        continue outer;
      }
    }
    i += 1;
  }
  return out;
}

const esc = (s) => s.replace(/[&<>]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;" })[c]);

/** HTML of ``text`` highlighted; the token at offset ``errorAt`` (or that one character) gets .hl-err */
export function highlight(text, language, errorAt = null) {
  const tokens = tokenize(text, language);
  let err = null;
  if (errorAt !== null && errorAt >= 0) {
    const t = tokens.find((x) => x.start <= errorAt && errorAt < x.end);
    err = t ? [t.start, t.end] : [errorAt, Math.min(text.length, errorAt + 1)];
  }
  // cut points: token bounds and the error range; each piece is wrapped by its token class
  const cuts = new Set([0, text.length]);
  for (const t of tokens) { cuts.add(t.start); cuts.add(t.end); }
  if (err) { cuts.add(err[0]); cuts.add(err[1]); }
  const points = [...cuts].sort((a, b) => a - b);
  let html = "";
  let k = 0;
  for (let p = 0; p < points.length - 1; p++) {
    const a = points[p], b = points[p + 1];
    while (k < tokens.length && tokens[k].end <= a) k++;
    const tok = tokens[k] && tokens[k].start <= a && a < tokens[k].end ? tokens[k] : null;
    let piece = esc(text.slice(a, b));
    if (tok) piece = `<span class="hl-${tok.cls}">${piece}</span>`;
    if (err && a >= err[0] && b <= err[1]) piece = `<span class="hl-err">${piece || " "}</span>`;
    html += piece;
  }
  if (err && err[0] >= text.length) html += `<span class="hl-err"> </span>`;
  return html + "\n";
}

/** offset of 1-based (line, column) in ``text``; columns past the line's end stop at its end */
export function offsetOf(text, line, column) {
  const lines = text.split("\n");
  if (line < 1 || line > lines.length) return null;
  let off = 0;
  for (let i = 0; i < line - 1; i++) off += lines[i].length + 1;
  return off + Math.min(Math.max(column - 1, 0), lines[line - 1].length);
}

/**
 * codeEditor({value, language, rows, complete, onChange, onSubmit}):
 * complete(textBeforeCaret) → {from, items: [{label, insert}]} | null (``from``: offset where the replaced word starts)
 */
export function codeEditor({ value = "", language = "sparql", rows = 12, complete = null, onChange = null, onSubmit = null, label = "code" }) {
  const lineNumbers = h("div", { class: "numbers" });
  const gutter = h("div", { class: "gutter", "aria-hidden": "true" }, lineNumbers);
  const pre = h("pre", { "aria-hidden": "true" });
  const ta = h("textarea", { spellcheck: "false", autocapitalize: "off", autocomplete: "off", rows: String(rows), "aria-label": label, wrap: "off" });
  const popup = h("div", { class: "complete", hidden: true, role: "listbox" });
  const el = h("div", { class: "editor", dataset: { language } }, gutter, h("div", { class: "code" }, pre, ta, popup));
  let error = null; // {line, column}
  let items = [], selected = 0, from = 0;

  function render() {
    const text = ta.value;
    const at = error ? offsetOf(text, error.line, error.column) : null;
    pre.innerHTML = highlight(text, language, at);
    const n = text.split("\n").length;
    lineNumbers.replaceChildren(...Array.from({ length: n }, (_, i) =>
      h("span", { class: error && error.line === i + 1 ? "err" : null }, String(i + 1))));
    gutter.style.width = `${String(n).length * 8 + 22}px`;
    sync();
  }
  function sync() {
    pre.scrollTop = ta.scrollTop;
    pre.scrollLeft = ta.scrollLeft;
    lineNumbers.style.transform = `translateY(${-ta.scrollTop}px)`;
  }
  function closePopup() { popup.hidden = true; items = []; }
  function charWidth() {
    const probe = h("span", { style: "visibility:hidden;position:absolute" }, "0000000000");
    pre.append(probe);
    const w = probe.getBoundingClientRect().width / 10;
    probe.remove();
    return w || 7.8;
  }
  function openPopup() {
    if (!complete) return;
    const before = ta.value.slice(0, ta.selectionStart);
    const found = complete(before);
    if (!found || !found.items.length) return closePopup();
    items = found.items.slice(0, 200);
    from = found.from;
    selected = 0;
    drawPopup();
    const lines = before.split("\n");
    const line = lines.length - 1, col = lines[lines.length - 1].length;
    popup.style.left = `${10 + col * charWidth() - ta.scrollLeft}px`;
    popup.style.top = `${8 + (line + 1) * 19 - ta.scrollTop}px`;
    popup.hidden = false;
  }
  function drawPopup() {
    popup.replaceChildren(...items.map((it, i) => h("div", {
      class: i === selected ? "sel" : null, role: "option",
      onmousedown: (e) => { e.preventDefault(); selected = i; accept(); },
    }, it.label)));
    const s = popup.children[selected];
    if (s) s.scrollIntoView({ block: "nearest" });
  }
  function accept() {
    const it = items[selected];
    if (!it) return closePopup();
    const end = ta.selectionStart;
    ta.setRangeText(it.insert, from, end, "end");
    closePopup();
    changed();
  }
  function changed() {
    render();
    if (onChange) onChange(ta.value);
  }

  ta.addEventListener("input", (e) => {
    error = null;
    changed();
    if (e.inputType && e.inputType.startsWith("insert")) openPopup(); else closePopup();
  });
  ta.addEventListener("scroll", sync);
  ta.addEventListener("blur", () => setTimeout(closePopup, 150));
  ta.addEventListener("keydown", (e) => {
    if (!popup.hidden) {
      if (e.key === "ArrowDown") { selected = (selected + 1) % items.length; drawPopup(); e.preventDefault(); return; }
      if (e.key === "ArrowUp") { selected = (selected - 1 + items.length) % items.length; drawPopup(); e.preventDefault(); return; }
      if (e.key === "Enter" || e.key === "Tab") { accept(); e.preventDefault(); return; }
      if (e.key === "Escape") { closePopup(); e.preventDefault(); return; }
    }
    if (e.key === " " && e.ctrlKey) { openPopup(); e.preventDefault(); return; }
    if (e.key === "Enter" && (e.ctrlKey || e.metaKey) && onSubmit) { onSubmit(); e.preventDefault(); return; }
    if (e.key === "Tab" && !e.shiftKey) { ta.setRangeText("  ", ta.selectionStart, ta.selectionEnd, "end"); changed(); e.preventDefault(); }
  });
  new ResizeObserver(sync).observe(ta);

  ta.value = value;
  render();
  return {
    el, textarea: ta,
    get value() { return ta.value; },
    set value(v) { ta.value = v; error = null; render(); },
    markError(line, column) { error = line ? { line, column: column || 1 } : null; render(); },
    clearError() { error = null; render(); },
    goTo(line, column) {
      const off = offsetOf(ta.value, line, column || 1);
      if (off === null) return;
      ta.focus();
      ta.setSelectionRange(off, off);
    },
  };
}
