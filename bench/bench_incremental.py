"""Compile per report: the rule table carried forward from the last version (incremental) against a full compile.

    python bench/bench_incremental.py [--sizes 30000,300000] [--reports 5]

For each graph size (the shipped seed plus synthetic Measurements drawn like the shipped sweeps,
bench/_synthetic.py; seeded once into an embedded store in a temporary folder), a report is committed
through ``ReportWriter`` and then, alternately, ``compile_table(kg, previous)`` (the observations carried
from the previous version, evidence/index.py) and ``compile_table(kg)`` (everything read again) are timed on
the same version; the script prints both medians over ``--reports`` reports and their ratio, and checks that
both tables decide the same.
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_scale import graph_lines, seed_store  # noqa: E402

from nfex_core.config import Settings  # noqa: E402
from nfex_core.feedback import Feedback, ReportWriter  # noqa: E402
from nfex_core.kg import KnowledgeGraph  # noqa: E402
from nfex_core.rules.engine import compile_table  # noqa: E402


def run(size: int, reports: int, settings: Settings) -> tuple[int, float, float, int]:
    with tempfile.TemporaryDirectory() as folder:
        lines = graph_lines(size, settings)
        seed_store(folder + "/store", lines, settings)
        kg = KnowledgeGraph.open(folder + "/store", settings=dataclasses.replace(settings, store=folder + "/store"))
        writer = ReportWriter(kg, max_items=1)
        try:
            table = compile_table(kg)
            incremental, full = [], []
            for i in range(reports):
                writer.write(Feedback("SIFT", {}, {"agent": "car", "light": "dark"}, sequence=f"bench-{i}", dataset="bench",
                                      reporter="bench", frames=10, ate_rmse=0.05 + 0.01 * i, extraction_ms=40.0,
                                      width=1241, height=376, tracking_lost=0))
                t = time.perf_counter()
                carried = compile_table(kg, table)
                incremental.append(time.perf_counter() - t)
                t = time.perf_counter()
                whole = compile_table(kg)
                full.append(time.perf_counter() - t)
                assert carried.decisions == whole.decisions and carried.configurations == whole.configurations
                table = carried
            return len(lines), statistics.median(incremental), statistics.median(full), reports
        finally:
            writer.close()
            kg.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="30000", help="graph sizes in statements, comma-separated")
    ap.add_argument("--reports", type=int, default=5)
    args = ap.parse_args()
    settings = Settings.from_env()
    print(f"{'statements':>10} {'incremental (ms)':>17} {'full (ms)':>10} {'ratio':>7}")
    for size in (int(s) for s in args.sizes.split(",")):
        n, inc, full, _ = run(size, args.reports, settings)
        print(f"{n:>10} {inc * 1000:>17.0f} {full * 1000:>10.0f} {full / inc:>6.1f}×", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
