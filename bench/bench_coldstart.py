"""Cold start and small updates on the shipped graph (issue 17).

    python bench/bench_coldstart.py [--updates 20] [--triples 6]

On this checkout's ontology/ (with its measurements) and rules/, each in a fresh temporary folder:

- **seed**: ``open_graph`` on an empty store, in process, beside the baseline measured in the same run:
  the same content committed through the validated commit path (whole-graph SHACL), as seeding did before;
- **empty store → ready**: ``nfex serve`` (one uvicorn worker, loopback port) on an empty store, from the
  process start to the first 200 of ``/healthz`` (lifespan done: the store is open and seeded) and of
  ``/readyz`` (the rule table compiled); once with an empty cache folder (``XDG_CACHE_HOME``: a first start
  on a fresh machine) and once with the cache the first start left;
- **seeded store → ready**: ``nfex serve`` again on the store the first start seeded;
- **small update**: p50 of --updates ``INSERT DATA`` of --triples triples, each describing a fresh IRI, over
  HTTP (``POST /sparql/update``, editor token) on that service — an editor's write answers once the rule
  table of the new version is compiled (read-your-writes, ``service/deps.py``), so /readyz's last
  ``compile_ms`` is printed beside it; in process on a copy of the store, the
  change computation (``change_of_update``) beside the baseline (``change_by_copy``: the whole default
  graph copied and diffed, as every update did before) and the commit that follows (incremental SHACL);
  and the same for an edit of a hub node (``nfex:ORB rdfs:seeAlso <fresh IRI>``, the API's example).
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from _timing import free_port  # noqa: E402

from nfex_core.config import Settings  # noqa: E402
from nfex_core.kg import sparql_update  # noqa: E402
from nfex_core.kg.changes import ChangeSet, graph_triples  # noqa: E402
from nfex_core.kg.sparql_query import with_prefixes  # noqa: E402
from nfex_core.kg.store import KnowledgeGraph  # noqa: E402
from nfex_core.knowledge import open_graph, seed_graph  # noqa: E402

TOKEN = "bench-editor-token"


def new_node(i: int, triples: int) -> str:
    """INSERT DATA of ``triples`` triples about a fresh IRI."""
    s = f"<urn:nfex:bench:note:{time.time_ns()}-{i}>"
    body = [f"{s} rdfs:label \"bench note {i}\"", f"{s} rdfs:seeAlso nfex:ORB"]
    body += [f"{s} rdfs:comment \"comment {k}\"" for k in range(max(0, triples - len(body)))]
    return "INSERT DATA { " + " . ".join(body[:triples]) + " . }"


def hub_edit(i: int, triples: int) -> str:
    return f"INSERT DATA {{ nfex:ORB rdfs:seeAlso <https://example.org/bench/{time.time_ns()}-{i}> }}"


def p50(xs: list[float]) -> float:
    return statistics.median(xs)


def start(store: Path, cache: Path) -> tuple[subprocess.Popen[bytes], str, float, float]:
    """``nfex serve`` on ``store``: the process, its URL, and seconds to /healthz and /readyz answering 200."""
    port = free_port()
    env = dict(os.environ, NFEX_STORE=str(store), NFEX_LOG_LEVEL="warning", PYTHONPATH=str(ROOT), XDG_CACHE_HOME=str(cache),
               NFEX_TOKENS=f"bench:{TOKEN}:editor")
    t = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port), "--log-level", "warning"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    base = f"http://127.0.0.1:{port}"
    marks: dict[str, float] = {}
    while "readyz" not in marks:
        if proc.poll() is not None:
            raise SystemExit(f"nfex serve exited with {proc.returncode}")
        for path in ("healthz", "readyz"):
            if path in marks:
                continue
            try:
                if httpx.get(f"{base}/{path}", timeout=2).status_code == 200:
                    marks[path] = time.perf_counter() - t
            except httpx.HTTPError:
                break
        time.sleep(0.02)
        if time.perf_counter() - t > 300:
            raise SystemExit(f"{base}/readyz did not answer 200 in 300 s")
    return proc, base, marks["healthz"], marks["readyz"]


def stop(proc: subprocess.Popen[bytes]) -> None:
    proc.terminate()
    proc.wait(30)


def http_updates(base: str, n: int, make: Callable[[int, int], str], triples: int) -> list[float]:
    out = []
    with httpx.Client(base_url=base, timeout=120, headers={"Authorization": f"Bearer {TOKEN}",
                                                              "Content-Type": "application/sparql-update"}) as c:
        for i in range(n + 2):
            t = time.perf_counter()
            r = c.post("/sparql/update", content=make(i, triples))
            ms = (time.perf_counter() - t) * 1000
            if r.status_code != 200:
                raise SystemExit(f"/sparql/update answered {r.status_code}: {r.text[:300]}")
            if i >= 2:  # the first two warm the parsers and the shapes cache
                out.append(ms)
    return out


def in_process(kg: KnowledgeGraph, n: int, make: Callable[[int, int], str], triples: int) -> dict[str, float]:
    """p50 ms of the change computation (new and baseline) and of the commit after it."""
    copy = getattr(sparql_update, "change_by_copy", None)
    new, old, commit = [], [], []
    for i in range(n + 2):
        update = with_prefixes(make(i, triples))
        t = time.perf_counter()
        change = sparql_update.change_of_update(kg.backend, update)
        t1 = time.perf_counter()
        if copy is not None and i < 5 + 2:  # the baseline is seconds a call: a handful is enough
            baseline = copy(kg.backend, update)
            assert baseline == change, "change_of_update and change_by_copy disagree"
        t2 = time.perf_counter()
        kg.commit(change, author="bench", message="bench update")
        t3 = time.perf_counter()
        if i >= 2:
            new.append((t1 - t) * 1000)
            commit.append((t3 - t2) * 1000)
            if copy is not None and i < 5 + 2:
                old.append((t2 - t1) * 1000)
    return {"change": p50(new), "baseline": p50(old) if old else float("nan"), "commit": p50(commit)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--updates", type=int, default=20)
    ap.add_argument("--triples", type=int, default=6, help="triples per INSERT DATA (≤ 10 in issue 17)")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="nfex-bench-coldstart-"))
    os.environ["XDG_CACHE_HOME"] = str(work / "cache-inprocess")
    settings = Settings.from_env()
    rows: list[tuple[str, str, str]] = []
    try:
        t = time.perf_counter()
        kg = open_graph(str(work / "seed"), settings=settings)
        seed_s = time.perf_counter() - t
        triples = kg.triple_count()
        kg.close()
        t = time.perf_counter()
        kg = open_graph(str(work / "seed-again"), settings=settings)
        again_s = time.perf_counter() - t
        kg.close()
        t = time.perf_counter()
        base = KnowledgeGraph.open(str(work / "validated"), settings=settings)
        base.commit(ChangeSet.adding(graph_triples(seed_graph(settings))), author="nfex seed", message="seed from ontology/ and rules/")
        baseline_s = time.perf_counter() - t
        base.close()
        rows.append(("seed an empty store, in process (empty cache)", f"{seed_s:.2f} s",
                     f"{baseline_s:.2f} s computed + validated commit"))
        rows.append(("seed another empty store, in process", f"{again_s:.2f} s", ""))

        cold, warm = work / "cache-cold", work / "cache-warm"
        proc, url, health, ready = start(work / "served", cold)
        stop(proc)
        rows.append(("empty store → /healthz, /readyz (empty cache)", f"{health:.2f} s, {ready:.2f} s", ""))
        shutil.copytree(cold, warm) if cold.exists() else warm.mkdir()
        proc, url, health, ready = start(work / "served-warm", warm)
        stop(proc)
        rows.append(("empty store → /healthz, /readyz (warm cache)", f"{health:.2f} s, {ready:.2f} s", ""))
        proc, url, health, ready = start(work / "served", warm)
        rows.append(("seeded store → /healthz, /readyz", f"{health:.2f} s, {ready:.2f} s", ""))
        try:
            for name, make in (("new node", new_node), ("hub edit", hub_edit)):
                ms = http_updates(url, args.updates, make, args.triples)
                compile_ms = httpx.get(f"{url}/readyz", timeout=30).json().get("rule_table", {}).get("compile_ms", float("nan"))
                rows.append((f"/sparql/update p50, {name}", f"{p50(ms):.0f} ms",
                             f"max {max(ms):.0f} ms over {len(ms)}; the editor's read-your-writes compile in each: "
                             f"{compile_ms:.0f} ms (last)"))
        finally:
            stop(proc)

        shutil.copytree(work / "seed", work / "updates", ignore=shutil.ignore_patterns("LOCK"))
        kg = KnowledgeGraph.open(str(work / "updates"), settings=settings)
        for name, make in (("new node", new_node), ("hub edit", hub_edit)):
            r = in_process(kg, args.updates, make, args.triples)
            rows.append((f"change of update p50, {name}", f"{r['change']:.1f} ms", f"{r['baseline']:.0f} ms copy-the-graph"))
            rows.append((f"commit after it p50, {name}", f"{r['commit']:.0f} ms", "incremental SHACL + write"))
        kg.close()
    finally:
        shutil.rmtree(work, ignore_errors=True)

    print(f"shipped graph: {triples} triples; INSERT DATA of {args.triples} triples (new node) or 1 (hub edit)\n")
    print(f"{'measurement':<48} {'this checkout':>16}   baseline (same run)")
    for name, value, baseline in rows:
        print(f"{name:<48} {value:>16}   {baseline}")


if __name__ == "__main__":
    main()
