"""Cost of the lock that publishes a context's first-request results into the rule table's memo (rules/memo.py).

    python bench/bench_table_memo.py [--measurements 1000] [--contexts 1000] [--rounds 7]

Builds the embedded store of bench_rules.py (seed plus synthetic configurations and measurements), compiles the
table once, then, paired in one run on the same table and the same contexts, in rounds of alternating order:

- first requests: ``decide`` and ``measured`` for every context on a fresh memo (each publishes once), with
  the memo's ``threading.Lock`` and with no lock (``contextlib.nullcontext``: the baseline);
- repeated requests: the same contexts again, the fastest of five passes (memo hits: no publication, no lock).

Prints µs per context (median over rounds) and the ratio lock / no lock.
"""
from __future__ import annotations

import argparse
import contextlib
import copy
import random
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _graphs import bulk  # noqa: E402

from nfex_core.knowledge import open_graph  # noqa: E402
from nfex_core.rules.engine import RuleEngine  # noqa: E402
from nfex_core.rules.memo import ContextMemo  # noqa: E402
from nfex_core.rules.table import RuleTable  # noqa: E402


def _pass_us(table: RuleTable, contexts: list[dict[str, str | None]]) -> float:
    t = time.perf_counter()
    for c in contexts:
        table.decide(c)
        table.measured(c)
    return (time.perf_counter() - t) * 1e6 / len(contexts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--measurements", type=int, default=1000)
    ap.add_argument("--contexts", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()

    kg = open_graph(tempfile.mkdtemp(prefix="nfex-bench-memo-"))
    setup = bulk(max(10, args.measurements // 10), args.measurements)
    kg._write_version(setup, kg.version, kg.version + 1, "bench", "bulk", "bench")  # unvalidated: synthetic, for timing
    vocab = kg.vocabulary()
    dims = tuple(vocab.dimensions)
    rng = random.Random(0)
    contexts = [{d: rng.choice([*vocab.dimensions[d].values, None]) for d in dims} for _ in range(args.contexts)]
    table = RuleEngine(kg).table()
    print(f"{len(table.decisions)} contexts in the table, {sum(len(c) for c in table.configurations.values())} measured "
          f"configurations; {len(contexts)} random contexts asked, {args.rounds} rounds")

    variants = {"lock": threading.Lock, "no lock": contextlib.nullcontext}
    first: dict[str, list[float]] = {k: [] for k in variants}
    again: dict[str, list[float]] = {k: [] for k in variants}
    for r in range(args.rounds):
        for name in (list(variants) if r % 2 == 0 else list(variants)[::-1]):
            t = copy.copy(table)
            t.memo, t.made_before = ContextMemo(variants[name]()), None
            first[name].append(_pass_us(t, contexts))
            again[name].append(min(_pass_us(t, contexts) for _ in range(5)))
    for label, runs in (("first requests", first), ("repeated requests", again)):
        lock, none = statistics.median(runs["lock"]), statistics.median(runs["no lock"])
        print(f"{label:18s}: lock {lock:8.2f} µs/context, no lock {none:8.2f} µs/context, ratio {lock / none:.3f}")
    kg.close()


if __name__ == "__main__":
    main()
