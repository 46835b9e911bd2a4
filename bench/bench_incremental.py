"""Compile per change: the rule table carried forward from the last version (incremental) against a full compile.

    python bench/bench_incremental.py [--sizes 30000,300000] [--reports 5] [--kinds quarantined,admitted,editor]

For each graph size (the shipped seed plus synthetic Measurements drawn like the shipped sweeps,
bench/_synthetic.py; seeded once into an embedded store in a temporary folder), changes are committed one
at a time and, after each, ``compile_table(kg, previous)`` (carried: rules/setup.py, evidence/index.py,
evidence/view.py) and ``compile_table(kg)`` (everything read again) are timed on the same version; the
script prints both medians over ``--reports`` changes, their ratio, and checks that both tables decide the
same. The kinds of change:

- ``quarantined``: a client's report through ``ReportWriter``, from one reporter: it waits for
  corroboration (evidence/trust.py), the common case of a fleet's stream;
- ``admitted``: the same with ``nfex:minSources 1``, so every report is admitted and changes the evidence
  summaries the measured rules read;
- ``admitted-fast``: an admitted report under agent = car and motion = fast, inside the star of the shipped
  expert rule (kg/footprint.py), which then counts every car + fast Measurement again;
- ``editor``: an editor's small ``kg update`` that disables and re-enables a DSL statement (configuration:
  the whole table is compiled again, what ``/sparql/update``'s read-your-writes waits for).
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
from nfex_core.feedback import Feedback, ReportWriter  # noqa: E402
from nfex_core.kg import KnowledgeGraph  # noqa: E402
from nfex_core.rules.engine import compile_table  # noqa: E402

PREFIX = "PREFIX nfex: <https://w3id.org/nfex#> "
KINDS = ("quarantined", "admitted", "admitted-fast", "editor")


def _change(kg: KnowledgeGraph, writer: ReportWriter, kind: str, i: int, statement: str) -> None:
    if kind == "editor":
        toggle = "INSERT DATA" if i % 2 == 0 else "DELETE DATA"
        kg.update(PREFIX + f"{toggle} {{ <{statement}> nfex:enabled false }}", author="bench")
        return
    conditions = {"agent": "car", "motion": "fast"} if kind == "admitted-fast" else {"agent": "car", "light": "dark"}
    writer.write(Feedback("SIFT", {}, conditions, sequence=f"bench-{kind}-{i}", dataset="bench",
                          reporter="bench", frames=10, ate_rmse=0.05 + 0.01 * i, extraction_ms=40.0,
                          width=1241, height=376, tracking_lost=0))


def run(size: int, reports: int, kinds: list[str], settings: Settings, full: bool = True) -> tuple[int, dict[str, tuple[float, float]]]:
    with tempfile.TemporaryDirectory() as folder:
        lines = graph_lines(size, settings)
        seed_store(folder + "/store", lines, settings)
        kg = KnowledgeGraph.open(folder + "/store", settings=settings.replace(store=folder + "/store"))
        writer = ReportWriter(kg, max_items=1)
        out: dict[str, tuple[float, float]] = {}
        try:
            statement = str(kg.select("SELECT ?s WHERE { ?s nfex:inProgram ?p } ORDER BY ?s").rows[0]["s"])
            for kind in kinds:
                if kind.startswith("admitted"):
                    kg.update(PREFIX + "DELETE { nfex:minSources nfex:value ?n } INSERT { nfex:minSources nfex:value 1 } "
                              "WHERE { OPTIONAL { nfex:minSources nfex:value ?n } }", author="bench")
                t = time.perf_counter()
                table = compile_table(kg)
                carried_ms, full_ms = [], [time.perf_counter() - t] if not full else []
                for i in range(reports):
                    _change(kg, writer, kind, i, statement)
                    t = time.perf_counter()
                    carried = compile_table(kg, table)
                    carried_ms.append(time.perf_counter() - t)
                    table = carried
                    if not full:
                        continue
                    t = time.perf_counter()
                    whole = compile_table(kg)
                    full_ms.append(time.perf_counter() - t)
                    assert carried.plain == whole.plain and carried.configurations == whole.configurations
                    assert carried.cost == whole.cost and carried.admission == whole.admission
                out[kind] = (statistics.median(carried_ms), statistics.median(full_ms))
            return len(lines), out
        finally:
            writer.close()
            kg.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="30000", help="graph sizes in statements, comma-separated")
    ap.add_argument("--reports", type=int, default=5, help="changes of each kind (the median is printed)")
    ap.add_argument("--kinds", default=",".join(KINDS), help=f"comma-separated, of: {', '.join(KINDS)}")
    ap.add_argument("--no-full", action="store_true",
                    help="time the carried compiles only; 'full' is then the first compile of each kind (for 3M, where one takes minutes)")
    args = ap.parse_args()
    kinds = [k for k in args.kinds.split(",") if k]
    unknown = set(kinds) - set(KINDS)
    if unknown:
        ap.error(f"unknown kind(s): {', '.join(sorted(unknown))}")
    settings = Settings.from_env()
    print(f"{'statements':>10} {'change':>12} {'carried (ms)':>13} {'full (ms)':>10} {'ratio':>7}")
    for size in (int(s) for s in args.sizes.split(",")):
        n, found = run(size, args.reports, kinds, settings, full=not args.no_full)
        for kind, (inc, full) in found.items():
            print(f"{n:>10} {kind:>12} {inc * 1000:>13.0f} {full * 1000:>10.0f} {full / inc:>6.1f}×", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
