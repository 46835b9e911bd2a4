"""The full read of the observations (a compile from scratch): branch queries on threads through ``Backend.values``
against the same branches as one query read term by term (the earlier form of the read), alternately on one store.

    python bench/bench_observations.py [--size 300000] [--pairs 7] [--store FOLDER]

The store is the shipped seed plus synthetic Measurements up to --size statements (bench_scale's graph), seeded
into a temporary folder, or an existing store folder (--store). Both reads fold their rows with the same code (the
threaded read makes each branch's column on its thread, the baseline after its query) and
must give the same Observations. Printed: each pair's times and ratio, the medians, and how many pairs the
threaded read won (a sign test: with 7 pairs all won, p = 1/128 under "no difference").
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_scale import graph_lines, seed_store  # noqa: E402

from nfex_core.config import Settings  # noqa: E402
from nfex_core.evidence.observations import (  # noqa: E402
    KEYS,
    Observation,
    _column,
    _fold,
    observation_query,
    read_observations,
)
from nfex_core.kg import KnowledgeGraph  # noqa: E402
from nfex_core.kg.backends import EmbeddedBackend  # noqa: E402
from nfex_core.kg.history import prefix_block  # noqa: E402


def one_query(kg: KnowledgeGraph) -> list[Observation]:
    """The baseline: every branch in one query, each value read from Oxigraph's term objects."""
    assert isinstance(kg.backend, EmbeddedBackend)
    parts: dict[str, list[list[str]]] = {k: [] for k in KEYS}
    for sol in kg.backend.solutions(prefix_block() + observation_query()):
        a, b = sol["a"], sol["b"]
        parts[sol["k"].value].append([sol["m"].value, a.value if a is not None else "", b.value if b is not None else ""])
    return _fold({k: _column(k, rows) for k, rows in parts.items()})


def measure(kg: KnowledgeGraph, pairs: int) -> int:
    wins, threaded_s, baseline_s = 0, [], []
    print(f"{'pair':>4} {'threaded (s)':>13} {'one query (s)':>14} {'ratio':>6}")
    for i in range(pairs):
        order = [("threaded", read_observations), ("one query", one_query)]
        if i % 2:
            order.reverse()
        got: dict[str, tuple[float, list[Observation]]] = {}
        for name, read in order:
            t = time.perf_counter()
            found = read(kg)
            got[name] = (time.perf_counter() - t, found)
        assert sorted(got["threaded"][1], key=lambda o: o.iri) == sorted(got["one query"][1], key=lambda o: o.iri)
        a, b = got["threaded"][0], got["one query"][0]
        threaded_s.append(a)
        baseline_s.append(b)
        wins += a < b
        print(f"{i + 1:>4} {a:>13.2f} {b:>14.2f} {b / a:>5.2f}×")
    print(f"median: threaded {statistics.median(threaded_s):.2f} s, one query {statistics.median(baseline_s):.2f} s "
          f"({statistics.median(baseline_s) / statistics.median(threaded_s):.2f}×); the threaded read faster in {wins} of {pairs} pairs "
          f"({len(got['threaded'][1])} observations)")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=300000, help="statements in the graph")
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--store", type=Path, default=None, help="an existing embedded store folder instead of a seeded one")
    args = ap.parse_args()
    settings = Settings.from_env()
    if args.store is not None:
        with KnowledgeGraph.open(str(args.store), settings=settings) as kg:
            return measure(kg, args.pairs)
    with tempfile.TemporaryDirectory() as folder:
        store = folder + "/store"
        lines = graph_lines(args.size, settings)
        seed_store(store, lines, settings)
        print(f"{len(lines)} statements seeded")
        with KnowledgeGraph.open(store, settings=settings.replace(store=store)) as kg:
            return measure(kg, args.pairs)


if __name__ == "__main__":
    sys.exit(main())
