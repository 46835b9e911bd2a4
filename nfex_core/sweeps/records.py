"""Sweep rows as graph triples: each row is a ``nfex:Measurement`` (a ``sosa:Observation`` whose
``sosa:usedProcedure`` is a ``nfex:Configuration``), with the conditions that held, its metric
results, and PROV provenance — the ``nfex:Run`` (code version, command, start time) on a
``nfex:Machine`` (CPU model and count; timings compare only on one machine). ontology/nfex.ttl,
"Configurations and measurements"; rules/shapes/integrity.ttl checks them on every commit.

IRIs are derived from content (a configuration from its α and Θ, a measurement from its cell key), so
re-running a cell addresses the same node and two sweeps share configurations.
"""
from __future__ import annotations

import json
import os
import platform
import socket
import subprocess
import uuid
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import rdflib
from rdflib.namespace import PROV, RDF, RDFS, SOSA, XSD
from rdflib.term import Literal, URIRef

from ..config import REPO_ROOT
from ..kg.identity import (
    configuration_iri,
    corruption_iri,
    dataset_iri,
    machine_iri,
    measurement_iri,
    metric_result_iri,
    run_iri,
    sequence_iri,
    setting_iri,
)
from ..kg.namespaces import NFEX
from ..kg.vocab import ExtractorSpec, Vocabulary
from .cells import DIMENSIONS


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def code_version() -> str:
    from .. import __version__

    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO_ROOT, capture_output=True,
                                text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return f"nfex {__version__}" + (f" ({commit})" if commit else "")


@dataclass
class RunInfo:
    """Provenance of one sweep or evaluation run."""

    command: str
    started: datetime = field(default_factory=lambda: datetime.now(UTC).replace(microsecond=0))  # HermiT rejects µs
    id: str = field(default_factory=lambda: uuid.uuid4().hex[:12])
    code: str = field(default_factory=code_version)
    cpu: str = field(default_factory=cpu_model)
    cpus: int = field(default_factory=lambda: len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)
    host: str = field(default_factory=socket.gethostname)

    @property
    def iri(self) -> URIRef:
        return run_iri(self.id)

    @property
    def machine_iri(self) -> URIRef:
        return machine_iri(self.host, self.cpu, self.cpus)

    def triples(self, g: rdflib.Graph) -> None:
        g.add((self.iri, RDF.type, NFEX.Run))
        g.add((self.iri, RDFS.label, Literal(f"run {self.id}")))
        g.add((self.iri, PROV.startedAtTime, Literal(self.started.isoformat(), datatype=XSD.dateTime)))
        g.add((self.iri, NFEX.codeVersion, Literal(self.code)))
        g.add((self.iri, NFEX.command, Literal(self.command)))
        g.add((self.iri, PROV.wasAssociatedWith, self.machine_iri))
        m = self.machine_iri
        g.add((m, RDF.type, NFEX.Machine))
        g.add((m, RDFS.label, Literal(f"{self.cpu}, {self.cpus} CPUs")))
        g.add((m, NFEX.cpuModel, Literal(self.cpu)))
        g.add((m, NFEX.cpuCount, Literal(self.cpus, datatype=XSD.integer)))


def _double(v: Any) -> Literal | None:
    if v in (None, ""):
        return None
    return Literal(float(v), datatype=XSD.double)


def _int(v: Any) -> Literal:
    return Literal(int(float(v)), datatype=XSD.integer)


def configuration_triples(g: rdflib.Graph, cfg: URIRef, spec: ExtractorSpec, params: Mapping[str, Any]) -> None:
    """A Configuration (α, Θ) with one ParameterSetting per parameter, each value typed by the graph.

    Sweeps and client feedback (nfex_core.feedback) both write configurations through this, under
    ``identity.configuration_iri``, so one (α, Θ) is one node whoever measured it."""
    g.add((cfg, RDF.type, NFEX.Configuration))
    g.add((cfg, RDFS.label, Literal(f"{spec.name} " + " ".join(f"{k}={v}" for k, v in sorted(params.items())))))
    g.add((cfg, NFEX.ofExtractor, spec.iri))
    for name, value in sorted(params.items()):
        p = spec.parameter(name)
        s = setting_iri(cfg, name)
        g.add((cfg, NFEX.hasSetting, s))
        g.add((s, RDF.type, NFEX.ParameterSetting))
        g.add((s, NFEX.parameter, p.iri))
        g.add((s, NFEX.value, p.literal(p.coerce(value))))


def sequence_triples(g: rdflib.Graph, dataset: str | None, sequence: str) -> URIRef:
    """The Sequence node (and its Dataset) under ``identity.sequence_iri`` — the IRI by which an evaluation
    holds the sequence out — labelled "<dataset> <sequence>" for people."""
    seq = sequence_iri(dataset, sequence)
    if dataset is None:
        g.add((seq, RDF.type, NFEX.Sequence))
        g.add((seq, RDFS.label, Literal(sequence)))
        return seq
    ds = dataset_iri(dataset)
    g.add((ds, RDF.type, NFEX.Dataset))
    g.add((ds, RDFS.label, Literal(dataset)))
    g.add((seq, RDF.type, NFEX.Sequence))
    g.add((seq, RDFS.label, Literal(f"{dataset} {sequence}")))
    g.add((seq, NFEX.inDataset, ds))
    return seq


def measurement_graph(rows: Iterable[Mapping[str, Any]], vocab: Vocabulary, run: RunInfo) -> rdflib.Graph:
    """The triples for ``rows`` (training-table rows, CSV strings or Python values) and their run."""
    g = rdflib.Graph()
    run.triples(g)
    for r in rows:
        spec = vocab.extractor(str(r["extractor"]))
        params = json.loads(str(r["params"]))
        cfg = configuration_iri(spec.name, str(r["params"]))
        configuration_triples(g, cfg, spec, params)
        seq = sequence_triples(g, str(r["dataset"]), str(r["sequence"]))
        m = measurement_iri(str(r["cell"]))
        g.add((m, RDF.type, NFEX.Measurement))
        g.add((m, SOSA.usedProcedure, cfg))
        g.add((m, NFEX.sequence, seq))
        g.add((m, PROV.wasGeneratedBy, run.iri))
        if str(r["corruption"]) not in ("none", "schedule"):
            c = corruption_iri(str(r["corruption"]))
            g.add((c, RDF.type, NFEX.Corruption))
            g.add((c, RDFS.label, Literal(str(r["corruption"]))))
            g.add((m, NFEX.corruption, c))
            g.add((m, NFEX.severity, Literal(float(r["severity"]), datatype=XSD.double)))
        for d in DIMENSIONS:
            value = r.get(f"ctx.{d}")
            if value and d in vocab.dimensions and value in vocab.dimensions[d].values:
                g.add((m, NFEX.underCondition, vocab.condition_value(d, str(value)).iri))
        g.add((m, NFEX.windowStart, _int(r["window_start"])))
        g.add((m, NFEX.windowEnd, _int(r["window_end"])))
        g.add((m, NFEX.frameCount, _int(r["frames"])))
        g.add((m, NFEX.trackingLost, _int(r["tracking_lost"])))
        g.add((m, NFEX.trackingFailed, Literal(str(r["failed"]) in ("1", "True"), datatype=XSD.boolean)))
        for col, prop in (("ate_rmse", NFEX.ateRmse), ("rpe_rmse", NFEX.rpeRmse), ("mean_matches", NFEX.meanMatches),
                          ("mean_inliers", NFEX.meanInliers), ("mean_keypoints", NFEX.meanKeypoints),
                          ("extraction_ms", NFEX.extractionMs), ("matching_ms", NFEX.matchingMs)):
            lit = _double(r.get(col)) if not (col in ("ate_rmse", "rpe_rmse") and str(r["failed"]) in ("1", "True")) else None
            if lit is not None:
                g.add((m, prop, lit))
        for col, prop in (("pair_rotation_error_deg", NFEX.pairRotationErrorDeg),
                          ("pair_direction_error_deg", NFEX.pairDirectionErrorDeg), ("bad_pair_fraction", NFEX.badPairFraction)):
            lit = _double(r.get(col))
            if lit is not None:
                g.add((m, prop, lit))
        if r.get("transition"):
            g.add((m, NFEX.transition, Literal(str(r["transition"]))))
        g.add((m, NFEX.frameWidth, _int(r["width"])))
        g.add((m, NFEX.frameHeight, _int(r["height"])))
        for k, v in r.items():
            if k.startswith("m.") and v not in (None, "") and k[2:] in vocab.metrics:
                mr = metric_result_iri(m, k[2:])
                g.add((m, NFEX.hasMetricResult, mr))
                g.add((mr, RDF.type, NFEX.MetricResult))
                g.add((mr, NFEX.metric, vocab.metric(k[2:]).iri))
                g.add((mr, NFEX.value, Literal(float(v), datatype=XSD.double)))
    return g
