"""Per-request cost of the compiled context-shape check against running pySHACL per request.

    python bench/bench_shapes.py [--requests 2000] [--shacl-requests 20]

On a seeded embedded store (the shipped rules/shapes/context.ttl) and the same random contexts:

- compiled: ``enforce(spec, Θ′, decision.shapes)`` for every candidate of the context (what a request
  pays for shapes), and the whole context-only ``Advisor.select``;
- baseline: materialise every candidate with its context and validate it with pySHACL against the
  context shapes (what checking shapes per request would cost);
- once per graph version: ``compile_table`` with the shapes (reading them, the pySHACL check of
  prohibitions) and ``load_context_shapes`` alone.

Prints µs/ms per request and the ratio baseline / compiled.
"""
from __future__ import annotations

import argparse
import random
import statistics
import tempfile
import time

import rdflib

from nfex_core.advisor import Advisor
from nfex_core.kg.shacl.validation import run_pyshacl, shapes_closure
from nfex_core.knowledge import open_graph
from nfex_core.rules.engine import compile_table
from nfex_core.rules.shape_check import enforce, materialise
from nfex_core.rules.shapes import GraphShapes, context_shape_nodes, load_context_shapes
from nfex_core.rules.statements import load_statements


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--requests", type=int, default=2000)
    ap.add_argument("--shacl-requests", type=int, default=20)
    args = ap.parse_args()
    kg = open_graph(tempfile.mkdtemp() + "/store")
    vocab = kg.vocabulary()
    rng = random.Random(0)
    dims = list(vocab.dimensions)
    contexts = [{d: rng.choice([*vocab.dimensions[d].values, None]) for d in dims} for _ in range(args.requests)]

    t = time.perf_counter()
    for _ in range(5):
        table = compile_table(kg)
    compile_ms = (time.perf_counter() - t) / 5 * 1000
    statements = load_statements(kg, vocab)
    shapes_graph = kg.shapes().graph
    t = time.perf_counter()
    for _ in range(5):
        load_context_shapes(GraphShapes.compile(shapes_graph, vocab), statements)
    load_ms = (time.perf_counter() - t) / 5 * 1000

    decisions = [table.decide(c) for c in contexts]
    params = {x: spec.defaults() for x, spec in vocab.extractors.items()}
    t = time.perf_counter()
    for d in decisions:
        for x in d.candidates:
            enforce(vocab.extractors[x], params[x], d.shapes)
    compiled_us = (time.perf_counter() - t) / len(decisions) * 1e6

    advisor = Advisor(kg)
    advisor.select({})
    t = time.perf_counter()
    for c in contexts:
        advisor.select(c)
    select_us = (time.perf_counter() - t) / len(contexts) * 1e6

    g = kg.shapes().graph
    shapes = shapes_closure(set(context_shape_nodes(g)), lambda ns: (tr for n in ns for tr in g.triples((n, None, None))))
    times = []
    for c in contexts[: args.shacl_requests]:
        t = time.perf_counter()
        data = rdflib.Graph()
        for i, x in enumerate(vocab.extractors):
            data += materialise(vocab, x, params[x], c, rdflib.URIRef(f"urn:cand:{i}"))
        run_pyshacl(data, shapes, None)
        times.append((time.perf_counter() - t) * 1000)
    shacl_ms = statistics.mean(times)

    print(f"graph version {kg.version}, {len(table.decisions)} contexts, {sum(1 for _ in context_shape_nodes(g))} context shapes")
    print(f"once per version: compile_table {compile_ms:.0f} ms, of which reading the shapes {load_ms:.0f} ms")
    print(f"per request, compiled enforce (all candidates): {compiled_us:.1f} µs")
    print(f"per request, Advisor.select context-only (everything): {select_us:.1f} µs")
    print(f"per request, pySHACL on the materialised candidates: {shacl_ms:.1f} ms")
    print(f"ratio pySHACL / compiled enforce: {shacl_ms * 1000 / compiled_us:.0f}x")


if __name__ == "__main__":
    main()
