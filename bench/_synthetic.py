"""Graphs of a chosen size for the scale benchmark: the shipped seed plus synthetic Measurements drawn like
the shipped sweeps (ontology/measurements/).

A shipped Measurement is a node with its window, outcome, cost, conditions, configuration, run and sequence,
plus one node per metric result (``<m>_density`` …): its *closure* is every statement whose subject is the
Measurement or one of those (about 60 statements). A synthetic Measurement is a closure copied with new IRIs
(``<m>_s<k>`` for copy k) and each measured ``xsd:double`` value multiplied by exp(N(0, ``spread``)): it names the same
configurations, runs, sequences and conditions as its original, so every reader of evidence (the rule
engine's measured rules, measured Θ′, the cost model) has work proportional to the graph's size, as a graph
grown by real sweeps would. Integers (windows, frame counts, tracking loss) are copied as they are.
Statements are N-Triples lines, written with ``KnowledgeGraph.load_validated`` (no rdflib terms on the way).
"""
from __future__ import annotations

import math
import random
import re
from collections.abc import Iterator, Sequence

MEASUREMENT_TYPE = " <http://www.w3.org/1999/02/22-rdf-syntax-ns#type> <https://w3id.org/nfex#Measurement> ."
SETTING = "<https://w3id.org/nfex#severity>"  # what the sweep set (a corruption's severity), not what it measured
DOUBLE = re.compile(r'"([^"]+)"\^\^<http://www\.w3\.org/2001/XMLSchema#double>')


def closures(lines: Sequence[str]) -> list[list[str]]:
    """The shipped Measurements' closures (see the module docstring), in the order of ``lines``."""
    roots = [line.split(" ", 1)[0][:-1] for line in lines if line.endswith(MEASUREMENT_TYPE)]  # "<iri" without ">"
    by_root: dict[str, list[str]] = {r: [] for r in roots}
    for line in lines:
        subject = line.split(" ", 1)[0]
        root = subject[:-1].split("_", 2)
        # a Measurement's IRI is nfex#meas_<hex>; its metric results nfex#meas_<hex>_<metric>
        key = "_".join(root[:2]) if len(root) >= 2 else subject[:-1]
        if key in by_root:
            by_root[key].append(line)
    return [by_root[r] for r in roots]


def synthetic(lines: Sequence[str], extra: int, *, spread: float = 0.15, seed: int = 0) -> Iterator[str]:
    """At least ``extra`` statements of synthetic Measurements copied from the closures in ``lines``."""
    rng = random.Random(seed)
    shapes = closures(lines)
    if not shapes:
        raise ValueError("the seed holds no Measurement to copy (is ontology/measurements/ there?)")
    roots = [c[0].split(" ", 1)[0][:-1] for c in shapes]
    written, k = 0, 0
    while written < extra:
        for root, closure in zip(roots, shapes, strict=True):
            new = f"{root}_s{k}"

            def perturb(m: re.Match[str]) -> str:
                value = float(m.group(1)) * math.exp(rng.gauss(0.0, spread))
                return f'"{value:.6g}"^^<http://www.w3.org/2001/XMLSchema#double>'

            for line in closure:
                line = line.replace(root + "_", new + "_").replace(root + ">", new + ">")
                yield line if SETTING in line else DOUBLE.sub(perturb, line)
            written += len(closure)
            if written >= extra:
                return
        k += 1
