"""SHACL validation of a 50-triple change on a graph of at least --triples triples (the seed alone is ~24.7k):
incremental against whole-graph.

    python bench/bench_shacl_incremental.py [--triples 20000] [--change 50] [--repeat 5]

Builds an embedded store (seed + synthetic configurations and measurements), then times, in one run,
KnowledgeGraph.check(change) — SHACL on the nodes the change touches — and pySHACL on the whole
candidate graph, and prints both and the ratio.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _graphs import bulk, change_of_about  # noqa: E402
from _timing import call_ms  # noqa: E402

from nfex_core.kg.shacl.validation import validate_graph  # noqa: E402
from nfex_core.knowledge import open_graph


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--triples", type=int, default=20000)
    ap.add_argument("--change", type=int, default=50)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    kg = open_graph(tempfile.mkdtemp(prefix="nfex-bench-"))
    seed_triples = kg.triple_count()
    n_configs = max(10, (args.triples - seed_triples) // 60)
    n_meas = max(10, (args.triples - seed_triples - 10 * n_configs) // 12)
    # loaded without per-write validation: the benchmark is about validating the next change
    setup = bulk(n_configs, n_meas)
    kg._write_version(setup, kg.version, kg.version + 1, "bench", "bulk", "bench")  # unvalidated: synthetic, for timing
    total = kg.triple_count()
    change = change_of_about(args.change, n_configs)
    print(f"graph: {total} triples; change: {len(change)} triples (new measurements)")

    report, inc = call_ms(lambda: kg.check(change), args.repeat)
    assert report.conforms, report.text
    data, shapes = kg.data_graph(), kg.shapes()
    candidate = data + change.as_graph("added")
    full, whole = call_ms(lambda: validate_graph(candidate, shapes), max(1, args.repeat // 2))
    assert full.conforms, full.text
    i_ms, w_ms = statistics.median(inc), statistics.median(whole)
    print(f"incremental (nodes the change touches): {i_ms:9.1f} ms  (median of {len(inc)}; {report.data_triples} triples checked)")
    print(f"whole graph:                            {w_ms:9.1f} ms  (median of {len(whole)})")
    print(f"ratio whole / incremental:              {w_ms / i_ms:9.1f}x")


if __name__ == "__main__":
    main()
