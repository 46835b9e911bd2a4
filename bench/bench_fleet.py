"""A fleet against one service: feedback reports streaming in while context-only selections are made (issue 17).

    python bench/bench_fleet.py [--reports 200] [--threads 4] [--idle 300]

Seeds a fresh embedded store from the shipped graph (ontology/ with its measurements, rules/) once, then, for
each configuration on its own copy of that store, starts the service (`nfex serve`, one uvicorn worker, on a
loopback port, with reporter tokens) and measures:

- idle: --idle sequential context-only `POST /v1/select` calls on one keep-alive connection;
- stream: --reports feedback reports from --threads reporter threads (each its own token and connection, each
  posting as soon as its last report was answered) while one more thread makes context-only selections until
  the last report is answered: reports/s, select p50/p99/max, and how stale the answers were (versions.stale_ms).

Reports/s counts acknowledged reports only (201 Created) over the stream's time. Every failed report or select is
printed, and any failure makes the script exit 1: a run with failures gives no rate to quote.

Configurations, in the same run: **fleet** (the defaults: background compile, group commit of ≤64 reports in a
20 ms window) and the **baseline** (NFEX_BACKGROUND_COMPILE=false, NFEX_FEEDBACK_BATCH=1: a select after a
commit waits for the recompile, one commit per report — the behaviour issue 17 measured).
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from _timing import free_port, wait_ok  # noqa: E402

from nfex_core.knowledge import open_graph  # noqa: E402

CONTEXTS = [{"agent": "car", "light": "bright"}, {"agent": "drone", "motion": "fast"}, {"scene": "indoor", "light": "dark"},
            {"agent": "human", "texture": "low"}]
CONFIGS = {
    "fleet": {},
    "baseline": {"NFEX_BACKGROUND_COMPILE": "false", "NFEX_FEEDBACK_BATCH": "1"},
}


@dataclass
class Run:
    idle_ms: list[float] = field(default_factory=list)
    stream_ms: list[float] = field(default_factory=list)
    stale_ms: list[float] = field(default_factory=list)
    reports_s: float = 0.0  # acknowledged reports (201) per second of the stream
    acknowledged: int = 0
    versions: int = 0
    errors: list[str] = field(default_factory=list)


def pct(xs: list[float], q: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, int(q * (len(s) - 1) + 0.5))]


def select_once(client: httpx.Client, i: int) -> tuple[float, float]:
    t = time.perf_counter()
    r = client.post("/v1/select", json={"context": CONTEXTS[i % len(CONTEXTS)]})
    ms = (time.perf_counter() - t) * 1000
    r.raise_for_status()
    return ms, float(r.json()["versions"]["stale_ms"])


def report_body(thread: int, i: int) -> dict[str, object]:
    return {"extractor": "ORB", "context": {"agent": "car", "light": "dark"}, "sequence": f"bench/fleet-{thread}",
            "client": "bench_fleet", "window_start": 100 * i, "window_end": 100 * i + 100, "ate_rmse": 0.5 + (i % 7) / 10,
            "tracking_lost": i % 5, "extraction_ms": 4.0}


def measure(base: str, args: argparse.Namespace, tokens: list[str]) -> Run:
    run = Run()
    with httpx.Client(base_url=base, timeout=120) as client:
        for i in range(50):  # warm-up
            select_once(client, i)
        for i in range(args.idle):
            run.idle_ms.append(select_once(client, i)[0])
        v0 = int(client.get("/v1/graph").json()["version"])

    done = threading.Event()
    left = iter(range(args.reports))
    lock = threading.Lock()

    def reporter(k: int) -> None:
        with httpx.Client(base_url=base, timeout=120, headers={"Authorization": f"Bearer {tokens[k]}"}) as c:
            while True:
                with lock:
                    i = next(left, None)
                if i is None:
                    return
                try:
                    r = c.post("/v1/feedback", json=report_body(k, i))
                except httpx.HTTPError as e:
                    run.errors.append(f"report {i}: {type(e).__name__}: {e}")
                    continue
                if r.status_code == 201:
                    with lock:
                        run.acknowledged += 1
                else:
                    run.errors.append(f"report {i}: {r.status_code} {r.text[:200]}")

    def selector() -> None:
        with httpx.Client(base_url=base, timeout=120) as c:
            i = 0
            while not done.is_set():
                try:
                    ms, stale = select_once(c, i)
                except httpx.HTTPError as e:
                    run.errors.append(f"select {i} during the stream: {type(e).__name__}: {e}")
                    return
                run.stream_ms.append(ms)
                run.stale_ms.append(stale)
                i += 1

    sel = threading.Thread(target=selector)
    sel.start()
    t = time.perf_counter()
    threads = [threading.Thread(target=reporter, args=(k,)) for k in range(args.threads)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    run.reports_s = run.acknowledged / (time.perf_counter() - t)
    done.set()
    sel.join()
    with httpx.Client(base_url=base, timeout=120) as client:
        run.versions = int(client.get("/v1/graph").json()["version"]) - v0
    return run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--reports", type=int, default=200)
    ap.add_argument("--threads", type=int, default=4)
    ap.add_argument("--idle", type=int, default=300)
    args = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="nfex-bench-fleet-"))
    t = time.perf_counter()
    kg = open_graph(str(work / "seed"))  # the shipped graph, seeded once
    triples = kg.triple_count()
    kg.backend.flush()  # type: ignore[attr-defined]
    kg.close()
    print(f"store seeded from the shipped graph: {triples} triples in {time.perf_counter() - t:.1f} s; "
          f"{args.reports} reports from {args.threads} threads, 1 select thread")
    tokens = [f"fleet-token-{k}" for k in range(args.threads)]
    runs: dict[str, Run] = {}
    try:
        for name, extra in CONFIGS.items():
            store = work / name
            shutil.copytree(work / "seed", store, ignore=shutil.ignore_patterns("LOCK"))
            port = free_port()
            env = dict(os.environ, NFEX_STORE=str(store), NFEX_LOG_LEVEL="warning", PYTHONPATH=str(ROOT),
                       NFEX_TOKENS=",".join(f"fleet{k}:{tok}:reporter" for k, tok in enumerate(tokens)), **extra)
            svc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port), "--log-level", "warning"],
                                   env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            base = f"http://127.0.0.1:{port}"
            try:
                wait_ok(base + "/readyz", svc)
                runs[name] = measure(base, args, tokens)
            finally:
                svc.terminate()
                svc.wait(30)
    finally:
        shutil.rmtree(work, ignore_errors=True)

    print(f"\n{'configuration':<10} {'reports/s':>9} {'acked':>6} {'versions':>8} | {'select during stream: n':>23} {'p50 ms':>8} {'p99 ms':>8} "
          f"{'max ms':>8} {'stale p99 ms':>12} | {'idle p50 ms':>11} {'idle p99 ms':>11}")
    for name, r in runs.items():
        stale = pct(r.stale_ms, 0.99) if r.stale_ms else 0.0
        stream = r.stream_ms or [float("nan")]
        print(f"{name:<10} {r.reports_s:>9.1f} {r.acknowledged:>6} {r.versions:>8} | {len(r.stream_ms):>23} "
              f"{statistics.median(stream):>8.1f} {pct(stream, 0.99):>8.1f} {max(stream):>8.1f} {stale:>12.0f} | "
              f"{statistics.median(r.idle_ms):>11.2f} {pct(r.idle_ms, 0.99):>11.2f}")
        for e in r.errors:
            print(f"  {name}: failed: {e}")
    if {"fleet", "baseline"} <= set(runs):
        f, b = runs["fleet"], runs["baseline"]
        if f.stream_ms and b.stream_ms and b.reports_s > 0:
            print(f"\nfleet / baseline: reports/s {f.reports_s / b.reports_s:.1f}x; select during the stream p99 "
                  f"{pct(b.stream_ms, 0.99) / pct(f.stream_ms, 0.99):.0f}x lower, max {max(b.stream_ms) / max(f.stream_ms):.0f}x lower")
    failed = {name: len(r.errors) for name, r in runs.items() if r.errors}
    if failed or set(runs) != set(CONFIGS):
        print(f"\nFAILED: {failed or 'a configuration did not run'}; these rates are not to be quoted", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
