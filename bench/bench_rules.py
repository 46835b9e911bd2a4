"""Per-request cost of the compiled rule engine against evaluating the pruning SPARQL per request.

    python bench/bench_rules.py [--measurements 1000] [--requests 20000] [--sparql-requests 20]

Builds an embedded store (seed — ontology, SPARQL pruning rules, rules/programs/default.nfex — plus
synthetic configurations and measurements so the measurement rules have data), then times, in one
run and on the same graph and the same random contexts:

- compiled: ``RuleTable.decide(context)`` (the lookup a request pays) and the advisor's context-only
  ``Advisor.select(context)`` (lookup + Θ′ = g(Θ,E) per candidate + scores + the Selection object);
- baseline: every rules/pruning/*.rq query evaluated per request by rdflib on the same data, for the
  one context of the request (parsed per request, and prepared once with per-request bindings);
- for reference, the same per-request queries on the Oxigraph store.

Prints µs per request and the ratios baseline / compiled.
"""
from __future__ import annotations

import argparse
import io
import random
import sys
import tempfile
import time
from pathlib import Path

import rdflib

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _graphs import bulk  # noqa: E402
from _timing import per_call_us  # noqa: E402

from nfex_core.advisor import Advisor  # noqa: E402
from nfex_core.knowledge import open_graph
from nfex_core.rules import pruning  # noqa: E402
from nfex_core.rules.engine import RuleEngine  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--measurements", type=int, default=1000)
    ap.add_argument("--requests", type=int, default=20000)
    ap.add_argument("--sparql-requests", type=int, default=20)
    args = ap.parse_args()

    kg = open_graph(tempfile.mkdtemp(prefix="nfex-bench-rules-"))
    setup = bulk(max(10, args.measurements // 10), args.measurements)
    kg._write_version(setup, kg.version, kg.version + 1, "bench", "bulk", "bench")  # unvalidated: synthetic, for timing
    vocab = kg.vocabulary()
    dims = tuple(vocab.dimensions)
    rng = random.Random(0)
    contexts = [{d: rng.choice([*vocab.dimensions[d].values, None]) for d in dims} for _ in range(1000)]
    requests = [contexts[i % len(contexts)] for i in range(args.requests)]

    t = time.perf_counter()
    table = RuleEngine(kg).table()
    compile_ms = (time.perf_counter() - t) * 1000
    rules = table.rules
    print(f"graph: {kg.triple_count()} triples, {len(rules)} SPARQL pruning rules, {len(table.statements)} DSL statements, "
          f"{len(table.decisions)} contexts; compile {compile_ms:.0f} ms (once per graph version)")

    decide_us = per_call_us(table.decide, requests)
    advisor = Advisor(kg, poll_interval_s=3600)
    advisor.select({})
    select_us = per_call_us(lambda c: advisor.select({k: v for k, v in c.items() if v is not None}), requests[: max(1, args.requests // 10)])

    # the rules run on the evidence view (admitted measurements, robust summaries), as the engine runs them
    assert table.carry.view is not None and table.carry.view.backend is not None
    view = table.carry.view.backend  # the compile's own view
    dump = io.BytesIO()
    view.query_to("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }", "application/n-triples", dump)
    data = rdflib.Graph().parse(data=dump.getvalue().decode(), format="nt")
    sample = requests[: args.sparql_requests]

    def iris(ctx):  # type: ignore[no-untyped-def]
        return [[vocab.dimensions[d].values[ctx[d]].iri if ctx[d] else None] for d in dims]  # one context

    def rdflib_parsed(ctx):  # type: ignore[no-untyped-def]
        out = []
        for rule in rules:
            out += list(data.query(pruning.contextualise(rule.query, dims, iris(ctx))))
        return out

    from rdflib.plugins.sparql import prepareQuery
    from rdflib.term import Variable

    prepared = [prepareQuery(rule.query) for rule in rules]

    def rdflib_prepared(ctx):  # type: ignore[no-untyped-def]
        bindings = {Variable(d): vocab.dimensions[d].values[ctx[d]].iri for d in dims if ctx[d]}
        out = []
        for q in prepared:
            out += list(data.query(q, initBindings=bindings))
        return out

    def oxigraph(ctx):  # type: ignore[no-untyped-def]
        out = []
        for rule in rules:
            out += view.select(pruning.contextualise(rule.query, dims, iris(ctx))).rows
        return out

    # the baselines answer what the compiled table answers (pruned extractors per context)
    for ctx in sample[:5]:
        want = {x for x, cs in table.decide(ctx).pruned.items() for c in cs if c.kind == "sparql"}
        got = {vocab.by_iri[r["extractor"]].name for r in oxigraph(ctx)}  # type: ignore[attr-defined]
        assert got == want, (ctx, got, want)

    parsed_us = per_call_us(rdflib_parsed, sample, repeat=1)
    prepared_us = per_call_us(rdflib_prepared, sample, repeat=1)
    oxi_us = per_call_us(oxigraph, sample, repeat=1)
    print(f"compiled RuleTable.decide:                {decide_us:12.2f} µs/request  (mean of {len(requests)})")
    print(f"compiled Advisor.select (context only):   {select_us:12.2f} µs/request  (mean of {max(1, args.requests // 10)})")
    print(f"rdflib, pruning SPARQL parsed per request:{parsed_us:12.0f} µs/request  (mean of {len(sample)})")
    print(f"rdflib, pruning SPARQL prepared:          {prepared_us:12.0f} µs/request  (mean of {len(sample)})")
    print(f"oxigraph, pruning SPARQL per request:     {oxi_us:12.0f} µs/request  (mean of {len(sample)})")
    print(f"ratio rdflib parsed / decide:             {parsed_us / decide_us:12.0f}x")
    print(f"ratio rdflib prepared / decide:           {prepared_us / decide_us:12.0f}x")
    print(f"ratio rdflib parsed / Advisor.select:     {parsed_us / select_us:12.0f}x")
    print(f"ratio oxigraph / decide:                  {oxi_us / decide_us:12.0f}x")


if __name__ == "__main__":
    main()
