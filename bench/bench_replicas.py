"""How long a report acknowledged by one replica takes to reach every replica's selections on a shared store.

    python bench/bench_replicas.py [--replicas 3] [--reports 5]

A real `oxigraph serve` seeded with the shipped graph, --replicas `nfex serve` processes on it (symbolic advisor,
default consistency), one reporter token. Each of --reports feedback reports goes to replica A; from its 201, each
replica's context-only selections are polled until one answers from the report's version (``versions.graph``).
Prints, per replica, the median and the maximum of those times, beside the two things the bound is made of
(docs/service.md, "The bound"): the poll interval (``NFEX_POLL_INTERVAL_S``) and the replica's compile of the last
report (``/readyz`` ``rule_table.compile_ms``), both from the same run. ``tests/service/test_replicas.py`` checks
that the report arrives; this script measures how long it takes. A failed report or select exits 1.
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent))
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench_scale import start_nfex, start_oxigraph, stop  # noqa: E402

from nfex_core.config import Settings  # noqa: E402
from nfex_core.knowledge import open_graph  # noqa: E402

CONTEXT = {"agent": "drone", "light": "dark", "texture": "low"}
TOKEN = "replicas-token"


def reached(urls: list[str], version: int, patience_s: float) -> dict[str, float]:
    """Seconds until each replica's selection answered from ``version`` or later (inf: not within patience_s)."""
    t0 = time.perf_counter()
    took = dict.fromkeys(urls, float("inf"))
    with httpx.Client(timeout=30) as c:
        while any(v == float("inf") for v in took.values()) and time.perf_counter() - t0 < patience_s:
            for url in urls:
                if took[url] == float("inf"):
                    r = c.post(url + "/v1/select", json={"context": CONTEXT})
                    r.raise_for_status()
                    if r.json()["versions"]["graph"] >= version:
                        took[url] = time.perf_counter() - t0
            time.sleep(0.01)
    return took


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--replicas", type=int, default=3)
    ap.add_argument("--reports", type=int, default=5)
    ap.add_argument("--patience", type=float, default=60.0, help="seconds after which a replica counts as never reached")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="nfex-bench-replicas-"))
    ox, ox_url, _ = start_oxigraph(work / "oxigraph")
    services: list = []
    failed: list[str] = []
    try:
        open_graph(settings=Settings.from_env().replace(store=ox_url, home=ROOT), seed_empty=True).close()
        env = dict(os.environ, NFEX_STORE=ox_url, NFEX_HOME=str(ROOT), NFEX_NEURAL="symbolic", NFEX_LOG_LEVEL="warning",
                   PYTHONPATH=str(ROOT), NFEX_TOKENS=f"bench:{TOKEN}:reporter", NFEX_COMPILED_CACHE="none")
        urls = []
        for i in range(args.replicas):
            svc, url, _ = start_nfex(env, work / f"replica-{i}.log", 600)
            services.append(svc)
            urls.append(url)
        poll_s = float(os.environ.get("NFEX_POLL_INTERVAL_S") or 0.25)
        times: dict[str, list[float]] = {u: [] for u in urls}
        with httpx.Client(base_url=urls[0], timeout=60, headers={"Authorization": f"Bearer {TOKEN}"}) as a:
            for i in range(args.reports):
                r = a.post("/v1/feedback", json={"extractor": "ORB", "context": CONTEXT, "sequence": "bench/replicas",
                                                 "client": "bench_replicas", "window_start": 100 * i,
                                                 "window_end": 100 * i + 100, "ate_rmse": 0.3, "tracking_lost": 0})
                if r.status_code != 201:
                    failed.append(f"report {i}: {r.status_code} {r.text[:200]}")
                    continue
                for url, t in reached(urls, int(r.json()["version"]), args.patience).items():
                    if t == float("inf"):
                        failed.append(f"report {i}: {url} never answered from version {r.json()['version']}")
                    else:
                        times[url].append(t)
        print(f"{args.replicas} replicas on one oxigraph serve (shipped graph), {args.reports} reports through replica 0; "
              f"poll interval {poll_s} s")
        print(f"{'replica':>7} {'median s':>9} {'max s':>7} {'its compile of the last report s':>33}")
        for i, url in enumerate(urls):
            compile_s = httpx.get(url + "/readyz", timeout=30).json()["rule_table"]["compile_ms"] / 1000
            if times[url]:
                print(f"{i:>7} {statistics.median(times[url]):>9.2f} {max(times[url]):>7.2f} {compile_s:>33.2f}")
    finally:
        for svc in services:
            stop(svc)
        ox.terminate()
        ox.wait(60)
        shutil.rmtree(work, ignore_errors=True)
    for f in failed:
        print(f"failed: {f}")
    if failed:
        sys.exit(1)


if __name__ == "__main__":
    main()
