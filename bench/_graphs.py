"""Synthetic but well-formed graph content for benchmarks: configurations and measurements."""
from __future__ import annotations

import random

from rdflib import Literal
from rdflib.namespace import RDF, XSD

from nfex_core.kg import ChangeSet
from nfex_core.kg.namespaces import NFEX, SOSA

CONDITIONS = ["light_dark", "light_bright", "agent_car", "agent_drone", "texture_low", "texture_high"]


def configuration(i: int, rng: random.Random) -> list[tuple]:  # type: ignore[type-arg]
    cfg = NFEX[f"bench_cfg_{i}"]
    s1, s2 = NFEX[f"bench_cfg_{i}_nf"], NFEX[f"bench_cfg_{i}_sf"]
    return [
        (cfg, RDF.type, NFEX.Configuration),
        (cfg, NFEX.ofExtractor, NFEX.ORB),
        (cfg, NFEX.hasSetting, s1),
        (cfg, NFEX.hasSetting, s2),
        (s1, RDF.type, NFEX.ParameterSetting),
        (s1, NFEX.parameter, NFEX.ORB_nfeatures),
        (s1, NFEX.value, Literal(rng.randrange(200, 4000))),
        (s2, RDF.type, NFEX.ParameterSetting),
        (s2, NFEX.parameter, NFEX.ORB_scaleFactor),
        (s2, NFEX.value, Literal(round(rng.uniform(1.05, 1.9), 3), datatype=XSD.double)),
    ]


def measurement(i: int, n_configs: int, rng: random.Random, prefix: str = "bench_m") -> list[tuple]:  # type: ignore[type-arg]
    m = NFEX[f"{prefix}_{i}"]
    triples = [
        (m, RDF.type, NFEX.Measurement),
        (m, SOSA.usedProcedure, NFEX[f"bench_cfg_{rng.randrange(n_configs)}"]),
        (m, NFEX.sequence, NFEX.bench_seq),
        (m, NFEX.ateRmse, Literal(round(rng.uniform(0, 3), 4), datatype=XSD.double)),
        (m, NFEX.rpeRmse, Literal(round(rng.uniform(0, 0.3), 4), datatype=XSD.double)),
        (m, NFEX.trackingLost, Literal(rng.randrange(0, 5))),
        (m, NFEX.frameCount, Literal(20)),
        (m, NFEX.windowStart, Literal(rng.randrange(0, 100))),
        (m, NFEX.windowEnd, Literal(rng.randrange(120, 200))),
        (m, NFEX.extractionMs, Literal(round(rng.uniform(2, 90), 2), datatype=XSD.double)),
    ]
    for c in rng.sample(CONDITIONS[:2], 1) + rng.sample(CONDITIONS[2:4], 1):
        triples.append((m, NFEX.underCondition, NFEX[c]))
    return triples


def bulk(n_configs: int, n_measurements: int, seed: int = 0) -> ChangeSet:
    rng = random.Random(seed)
    triples: list[tuple] = [(NFEX.bench_seq, RDF.type, NFEX.Sequence)]  # type: ignore[type-arg]
    for i in range(n_configs):
        triples += configuration(i, rng)
    for i in range(n_measurements):
        triples += measurement(i, n_configs, rng)
    return ChangeSet.adding(triples)


def change_of_about(n_triples: int, n_configs: int, seed: int = 1) -> ChangeSet:
    """Whole new measurements, topped up with labels to exactly ``n_triples``."""
    from rdflib.namespace import RDFS

    rng = random.Random(seed)
    triples: list[tuple] = []  # type: ignore[type-arg]
    i = 0
    while len(triples) + 12 <= n_triples:
        triples += measurement(i, n_configs, rng, prefix="bench_new")
        i += 1
    for k in range(n_triples - len(triples)):
        triples.append((NFEX[f"bench_new_{k % max(i, 1)}"], RDFS.label, Literal(f"benchmark measurement {k}")))
    return ChangeSet.adding(triples)
