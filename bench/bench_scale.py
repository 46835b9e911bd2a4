"""How nFEX scales with the size of its graph (issue 17): one table over graph sizes, embedded and remote store.

    python bench/bench_scale.py [--sizes 30000,300000,3000000] [--modes embedded,remote] [--remote-seed auto]
                                [--plot scale.png] [--rows rows.json]
    python bench/bench_scale.py --replot a.json b.json --plot scale.png     # one table and plot from several runs

For each size N: the shipped seed (ontology/ with its measurements, rules/; ~34k statements) plus synthetic
Measurements drawn like the shipped sweeps (bench/_synthetic.py) up to N statements, written into an empty
store as one version with ``KnowledgeGraph.load_validated`` — an embedded store, and a fresh `oxigraph serve`:
over HTTP (its staged writes), or with ``--remote-seed bulk`` (``auto``: above 1M statements, where the staged
HTTP write of 3M broke the server's connection) by ``oxigraph load`` of the embedded store's N-Quads dump (the
same data, its version history included) before the server starts. Then, per store, `nfex serve` (one uvicorn
worker, symbolic advisor, reporter tokens, its own NFEX_COMPILED_CACHE) is started and measured:

- seed: the load_validated write of the N statements and the compaction of it (remote, bulk: the ``oxigraph load``,
  and the server's work on the loaded store once it opens it);
- cold start: from starting the process to ``/readyz`` 200 (import, open, first compile from scratch);
- restart: the same for a second start after the first stopped, which reads the rule table the first kept
  (nfex_core/rules/persisted.py);
- full compile: ``/readyz`` ``rule_table.compile_ms`` of the first snapshot;
- compile per report: the same after one more report (the compile carries from the last table what the
  report cannot have touched: docs/architecture.md);
- select p50/p99 idle, and during a stream of --reports feedback reports from --threads reporters
  (bench_fleet.measure), with the reports/s of that stream (acknowledged reports only; any failed report, select or
  restart is printed and makes the script exit 1);
- a SPARQL aggregate (windows and mean ATE per extractor) through nFEX's ``/sparql``, p50, against the same
  query sent straight to `oxigraph serve` holding the same data (the baseline of both rows).

A seed includes the storage's compaction of what it wrote, which would otherwise run beside the first start on 2
cores: for the embedded store, RocksDB compacts only once a later update schedules it (the first `nfex serve`
as it opens: ~6 s of CPU at 3M statements in a probe), so ``seed_store`` sends an update that writes nothing and
waits until its compaction threads idle; `oxigraph serve` compacts a bulk-loaded store as it opens it (~5 s of CPU
at 3M), and the seconds until it idles are added to the bulk seed. The seeds' writes are synced to disk before any
start is timed.

The plot (--plot) draws the time columns over N, log-log, one line per store.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _synthetic import synthetic  # noqa: E402
from _timing import free_port, settle, wait_ok  # noqa: E402
from bench_fleet import measure, pct  # noqa: E402

from nfex_core.config import Settings  # noqa: E402
from nfex_core.kg import KnowledgeGraph  # noqa: E402
from nfex_core.kg.backends import RemoteBackend  # noqa: E402
from nfex_core.kg.history import ChangeText  # noqa: E402
from nfex_core.knowledge import seed_graph  # noqa: E402
from nfex_core.knowledge.seed_content import seed_content  # noqa: E402

AGGREGATE = """PREFIX nfex: <https://w3id.org/nfex#>
PREFIX sosa: <http://www.w3.org/ns/sosa/>
SELECT ?x (COUNT(?m) AS ?windows) (AVG(?ate) AS ?mean_ate) WHERE {
  ?m a nfex:Measurement ; sosa:usedProcedure ?c ; nfex:ateRmse ?ate . ?c nfex:ofExtractor ?x } GROUP BY ?x"""
COLUMNS = [  # (key, header, unit)
    ("seed_s", "seed", "s"), ("cold_s", "cold start to ready", "s"), ("restart_s", "restart to ready", "s"), ("compile_s", "full compile", "s"),
    ("report_compile_s", "compile per report", "s"), ("idle_p50", "select p50 idle", "ms"),
    ("idle_p99", "select p99 idle", "ms"), ("stream_p50", "select p50 in stream", "ms"),
    ("stream_p99", "select p99 in stream", "ms"), ("reports_s", "reports/s", ""), ("sparql_p50", "SPARQL agg. p50", "ms"),
    ("oxigraph_p50", "same on oxigraph serve", "ms"),
]


@dataclass
class Row:
    size: int
    mode: str
    triples: int = 0
    values: dict[str, float] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)


def graph_lines(size: int, settings: Settings) -> list[str]:
    """The shipped seed, then synthetic Measurements until ``size`` statements (the seed alone when larger)."""
    seed = list(seed_content(settings, seed_graph).text().added)
    return seed + list(synthetic(seed, size - len(seed))) if size > len(seed) else seed


def seed_store(location: str, lines: list[str], settings: Settings) -> float:
    """Write ``lines`` into the empty store at ``location`` as version 1; seconds taken. A remote store gets a
    client without the default 30 s limit per request: moving 300k staged statements in is one long update."""
    t = time.perf_counter()
    idle_tail = 0.0
    settings = settings.replace(store=location)
    if location.startswith("http"):
        kg = KnowledgeGraph(RemoteBackend(location, timeout_s=3600), settings)
    else:
        kg = KnowledgeGraph.open(location, settings=settings)
    kg.load_validated(ChangeText(lines, ntriples=True), author="bench_scale", message=f"{len(lines)} statements")
    flush = getattr(kg.backend, "flush", None)
    if flush is not None:
        flush()
        # RocksDB compacts what the write left only once a later update schedules it: without this, the first
        # process to open the store and write (``nfex serve``, as it opens) pays it — at 3M statements ~6 s of CPU
        # beside its first compile, in a probe. Made part of the seed here: an update that writes nothing, then
        # waiting until this process's compaction threads idle.
        kg.backend.update("INSERT { <urn:nfex:bench> <urn:nfex:bench> <urn:nfex:bench> } WHERE { FILTER (false) }")
        settled = settle(os.getpid(), window=0.5, thread="rocksdb:low")
        if settled is not None:
            print(f"  embedded: RocksDB compacted the seed in {settled[0]:.1f} s ({settled[2]:.1f} s of CPU)", flush=True)
            idle_tail = settled[1] - settled[0]  # the window that found it idle is not the seed's
    kg.close()
    return time.perf_counter() - t - idle_tail


def start_oxigraph(folder: Path) -> tuple[subprocess.Popen[bytes], str, float]:
    exe = shutil.which("oxigraph") or str(Path(sys.executable).parent / "oxigraph")
    port = free_port()
    proc = subprocess.Popen([exe, "serve", "--location", str(folder), "--bind", f"127.0.0.1:{port}"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    wait_ok(url + "/query?query=ASK%7B%7D", proc, 60)
    # it answers while it still works on a freshly loaded store (module docstring): waited out, so that it does
    # not run beside the starts measured next (2 cores)
    return proc, url, _settled(proc)


def _settled(proc: subprocess.Popen[bytes]) -> float:
    """Wait until `oxigraph serve` idles (module docstring); the seconds it worked."""
    settled = settle(proc.pid)
    if settled is None:
        return 0.0
    print(f"  oxigraph serve: idle {settled[0]:.1f} s after answering or seeding ({settled[2]:.1f} s of CPU meanwhile)", flush=True)
    return settled[0]


def p50_ms(n: int, call: Callable[[], httpx.Response]) -> float:
    out = []
    for _ in range(n):
        t = time.perf_counter()
        r = call()
        out.append((time.perf_counter() - t) * 1000)
        r.raise_for_status()
    return statistics.median(out)


def start_nfex(env: dict[str, str], log: Path, timeout: float) -> tuple[subprocess.Popen[bytes], str, float]:
    """`nfex serve` on a free port: the process, its URL, and seconds from starting it to ``/readyz`` 200."""
    port = free_port()
    t = time.perf_counter()
    svc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port), "--log-level", "warning"],
                           env=env, stdout=log.open("ab"), stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        wait_ok(base + "/readyz", svc, timeout)
    except BaseException:
        stop(svc)
        raise
    return svc, base, time.perf_counter() - t


def stop(svc: subprocess.Popen[bytes]) -> None:
    svc.terminate()  # the service keeps its compiled table as it stops
    try:
        svc.wait(600)
    except subprocess.TimeoutExpired:
        svc.kill()


def serve_and_measure(store: str, row: Row, args: argparse.Namespace, oxigraph_url: str, log: Path) -> None:
    tokens = [f"scale-token-{k}" for k in range(args.threads)]
    env = dict(os.environ, NFEX_STORE=store, NFEX_HOME=str(ROOT), NFEX_NEURAL="symbolic", NFEX_LOG_LEVEL="warning",
               PYTHONPATH=str(ROOT), NFEX_TOKENS=",".join(f"scale{k}:{tok}:reporter" for k, tok in enumerate(tokens)),
               NFEX_COMPILED_CACHE=str(log.parent / f"compiled-{log.stem}"))
    svc, base, row.values["cold_s"] = start_nfex(env, log, args.ready_timeout)
    try:
        row.values["compile_s"] = httpx.get(base + "/readyz").json()["rule_table"]["compile_ms"] / 1000
        run = measure(base, argparse.Namespace(reports=args.reports, threads=args.threads, idle=args.idle), tokens)
        row.errors += run.errors
        row.values.update(idle_p50=statistics.median(run.idle_ms), idle_p99=pct(run.idle_ms, 0.99),
                          stream_p50=statistics.median(run.stream_ms), stream_p99=pct(run.stream_ms, 0.99),
                          reports_s=run.reports_s)
        with httpx.Client(base_url=base, timeout=600, headers={"Authorization": f"Bearer {tokens[0]}"}) as c:
            c.post("/v1/select", params={"consistency": "latest"}, json={"context": {"agent": "car"}}).raise_for_status()  # the stream's compiles done
            r = c.post("/v1/feedback", json={"extractor": "ORB", "context": {"agent": "car"}, "ate_rmse": 0.5,
                                             "sequence": "bench/scale", "client": "bench_scale"})
            r.raise_for_status()
            c.post("/v1/select", params={"consistency": "latest"}, json={"context": {"agent": "car"}}).raise_for_status()
            row.values["report_compile_s"] = c.get("/readyz").json()["rule_table"]["compile_ms"] / 1000
            row.values["sparql_p50"] = p50_ms(args.queries, lambda: c.get("/sparql", params={"query": AGGREGATE}))
        with httpx.Client(timeout=600) as c:
            row.values["oxigraph_p50"] = p50_ms(args.queries, lambda: c.get(oxigraph_url + "/query", params={"query": AGGREGATE},
                                                                             headers={"accept": "application/sparql-results+json"}))
        before = httpx.get(base + "/readyz").json()  # what the first start has as it is stopped
    finally:
        stop(svc)
    svc, base, row.values["restart_s"] = start_nfex(env, log, args.ready_timeout)
    try:
        after = httpx.get(base + "/readyz").json()
        if not after["rule_table"].get("kept"):
            row.errors.append("the restart compiled its table instead of reading the kept one (before the stop: table "
                              f"{before['rule_table']['version']}, head {before['graph_version']}; after the restart: table "
                              f"{after['rule_table']['version']}, head {after['graph_version']})")
    finally:
        stop(svc)


def bulk_load(embedded: Path, folder: Path) -> float:
    """``oxigraph load`` into ``folder`` of the N-Quads dump of the embedded store at ``embedded`` (every graph: the
    knowledge and its version history); seconds of the load."""
    import pyoxigraph as ox

    dump = folder.parent / f"{folder.name}.nq"
    store = ox.Store(str(embedded))
    store.dump(str(dump), format=ox.RdfFormat.N_QUADS)
    del store
    exe = shutil.which("oxigraph") or str(Path(sys.executable).parent / "oxigraph")
    t = time.perf_counter()
    subprocess.run([exe, "load", "--location", str(folder), "--file", str(dump)], check=True, stdout=subprocess.DEVNULL)
    seconds = time.perf_counter() - t
    dump.unlink()
    return seconds


def run_size(size: int, args: argparse.Namespace, settings: Settings, work: Path) -> list[Row]:
    t = time.perf_counter()
    lines = graph_lines(size, settings)
    print(f"\n{size:,}: {len(lines):,} statements made in {time.perf_counter() - t:.1f} s", flush=True)
    rows = []
    bulk = args.remote_seed == "bulk" or (args.remote_seed == "auto" and len(lines) > 1_000_000)
    embedded = work / f"embedded-{size}"
    embedded_seed = seed_store(str(embedded), lines, settings) if bulk or "embedded" in args.modes else None
    remote_seed = bulk_load(embedded, work / f"oxigraph-{size}") if bulk else None
    os.sync()  # the seeds' writes on disk before a start is timed (the kernel's write-back would run beside it)
    ox_proc, ox_url, settling = start_oxigraph(work / f"oxigraph-{size}")
    try:
        if remote_seed is not None:
            remote_seed += settling  # what the server does to the loaded store once it opens it: part of the bulk seed
        if remote_seed is None:
            remote_seed = seed_store(ox_url, lines, settings) + _settled(ox_proc)
        for mode in args.modes:
            row = Row(size, mode if mode == "embedded" or not bulk else "remote (bulk-loaded)", len(lines))
            store = ox_url if mode == "remote" else str(embedded)
            row.values["seed_s"] = remote_seed if mode == "remote" else embedded_seed  # type: ignore[assignment]
            print(f"  {row.mode}: seeded in {row.values['seed_s']:.1f} s", flush=True)
            serve_and_measure(store, row, args, ox_url, work / f"serve-{mode}-{size}.log")
            print("  " + ", ".join(f"{k} {v:.3g}" for k, v in row.values.items()), flush=True)
            rows.append(row)
    finally:
        ox_proc.terminate()
        ox_proc.wait(60)
    return rows


def table(rows: list[Row]) -> str:
    head = "| statements | store | " + " | ".join(f"{h}{f' ({u})' if u else ''}" for _, h, u in COLUMNS) + " |"
    out = [head, "|" + "---|" * (len(COLUMNS) + 2)]
    for r in rows:
        cells = [f"{r.values[k]:.3g}" if k in r.values else "–" for k, _, _ in COLUMNS]
        out.append(f"| {r.triples:,} | {r.mode} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def plot(rows: list[Row], path: Path) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)")
        return
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, (key, header, unit) in enumerate(c for c in COLUMNS if c[2]):
        for mode, style in (("embedded", "-"), ("remote", "--")):
            pts = [(r.triples, r.values[key] * (1000 if unit == "s" else 1)) for r in rows if r.mode.startswith(mode) and key in r.values]
            if pts:
                ax.plot(*zip(*pts, strict=True), style, marker="o", color=plt.get_cmap("tab20")(i), label=f"{header} ({mode})")
    ax.set(xscale="log", yscale="log", xlabel="statements in the graph", ylabel="ms", title="nFEX at scale (bench/bench_scale.py)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    print(f"plot: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="30000,300000", help="graph sizes in statements, comma-separated")
    ap.add_argument("--modes", default="embedded,remote", help="embedded, remote or both")
    ap.add_argument("--reports", type=int, default=100)
    ap.add_argument("--threads", type=int, default=4)
    ap.add_argument("--idle", type=int, default=200)
    ap.add_argument("--queries", type=int, default=20)
    ap.add_argument("--ready-timeout", type=float, default=600, help="seconds a service may take to become ready")
    ap.add_argument("--remote-seed", choices=("auto", "http", "bulk"), default="auto",
                    help="how `oxigraph serve` gets the data: staged HTTP writes, or `oxigraph load` of the embedded store's dump (auto: above 1M statements)")
    ap.add_argument("--plot", type=Path, default=None, help="where to save the plot (PNG)")
    ap.add_argument("--rows", type=Path, default=None, help="also write the rows measured as JSON (for --replot)")
    ap.add_argument("--replot", type=Path, nargs="+", default=None, help="measure nothing: the table and plot of the rows these files hold")
    args = ap.parse_args()
    args.modes = [m for m in args.modes.split(",") if m]
    if not set(args.modes) <= {"embedded", "remote"}:
        ap.error(f"--modes: embedded and/or remote, got {args.modes}")
    if args.replot is not None:
        replotted = [Row(**r) for path in args.replot for r in json.loads(path.read_text())]
        print(table(sorted(replotted, key=lambda r: (r.triples, r.mode))))
        if args.plot is not None:
            plot(replotted, args.plot)
        return
    settings = Settings.from_env().replace(home=ROOT)
    work = Path(tempfile.mkdtemp(prefix="nfex-bench-scale-"))
    rows: list[Row] = []
    try:
        for size in (int(s) for s in args.sizes.split(",") if s):
            rows += run_size(size, args, settings, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"\n{args.reports} reports from {args.threads} threads; {args.idle} idle selects; {args.queries} SPARQL queries\n")
    print(table(rows))
    if args.rows is not None:
        args.rows.write_text(json.dumps([dataclasses.asdict(r) for r in rows], indent=1))
    for r in rows:
        for e in r.errors:
            print(f"  {r.triples:,} {r.mode}: failed: {e}")
    if args.plot is not None:
        plot(rows, args.plot)
    failed = {f"{r.triples:,} {r.mode}": len(r.errors) for r in rows if r.errors}
    if failed:
        print(f"\nFAILED: {failed}; these rows are not to be quoted", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
