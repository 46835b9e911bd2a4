"""Every IRI nFEX mints for its knowledge, in one place.

Two writers that mean the same thing must name it the same way: a sweep, a client's feedback, the SLAM
replay client and ``nfex evaluate`` all say ``sequence_iri("kitti", "01")`` for KITTI sequence 01, and an
evaluation holds a sequence out by this IRI — never by matching label text. IRIs derived from content
(a configuration from its α and Θ, a sweep measurement from its cell key) let a re-run address the same
node. The store's own bookkeeping (versions, claims: ``urn:nfex:…``) is minted by ``kg.store``.

>>> str(sequence_iri("kitti", "01"))
'https://w3id.org/nfex#sequence_kitti_01'
>>> str(configuration_iri("ORB", {"nfeatures": 500, "scaleFactor": 1.2})) == str(configuration_iri("ORB", {"scaleFactor": 1.2, "nfeatures": 500}))
True
"""
from __future__ import annotations

import hashlib
import json
import re
import uuid
from collections.abc import Mapping
from typing import Any

from rdflib.term import URIRef

from .namespaces import NFEX

_UNSAFE = re.compile(r"[^A-Za-z0-9]")


def slug(text: str) -> str:
    """``text`` with every character that is not a letter or digit replaced by ``_`` (IRI-safe, stable)."""
    return _UNSAFE.sub("_", text)


def canonical(params: Mapping[str, Any]) -> str:
    """A stable JSON text of a parameter set (sweep tables' ``params`` column, configuration identity)."""
    return json.dumps({k: params[k] for k in sorted(params)}, sort_keys=True, separators=(",", ":"))


# ------------------------------------------------------------------------------ data and evidence
def dataset_iri(dataset: str) -> URIRef:
    return NFEX[f"dataset_{slug(dataset)}"]


def sequence_iri(dataset: str | None, sequence: str) -> URIRef:
    """The one IRI of a sequence: ``sequence_<dataset>_<sequence>`` (the sequence's own id within its
    dataset, e.g. "01" — not a "kitti/01" key); without a dataset, ``sequence_<sequence>``."""
    if "/" in sequence and dataset is not None and sequence.startswith(f"{dataset}/"):
        sequence = sequence[len(dataset) + 1:]  # a Sequence.key given where its name was meant
    return NFEX[f"sequence_{slug(dataset)}_{slug(sequence)}"] if dataset else NFEX[f"sequence_{slug(sequence)}"]


def configuration_iri(extractor: str, params: Mapping[str, Any] | str) -> URIRef:
    """(α, Θ) → one node whoever measured it; ``params`` as a mapping or its ``canonical`` text."""
    text = params if isinstance(params, str) else canonical(params)
    return NFEX[f"cfg_{extractor}_{hashlib.sha1(text.encode()).hexdigest()[:12]}"]


def setting_iri(configuration: URIRef, parameter: str) -> URIRef:
    return URIRef(f"{configuration}_{slug(parameter)}")


def measurement_iri(cell_key: str | None = None) -> URIRef:
    """A sweep cell's measurement (content-derived), or a fresh one for a client report."""
    return NFEX[f"meas_{cell_key}"] if cell_key is not None else NFEX[f"measurement_{uuid.uuid4().hex}"]


def report_iri(reporter: str, key: str) -> URIRef:
    """A client report's measurement, named by its reporter and idempotency key: a retry names the same one."""
    return NFEX[f"measurement_{uuid.uuid5(uuid.NAMESPACE_URL, f'nfex-report:{reporter}:{key}').hex}"]


def metric_result_iri(measurement: URIRef, metric: str) -> URIRef:
    return URIRef(f"{measurement}_{slug(metric)}")


def corruption_iri(name: str) -> URIRef:
    return NFEX[f"corruption_{slug(name)}"]


def run_iri(run_id: str) -> URIRef:
    return NFEX[f"run_{slug(run_id)}"]


def machine_iri(host: str, cpu: str, cpus: int) -> URIRef:
    return NFEX["machine_" + hashlib.sha1(f"{host}|{cpu}|{cpus}".encode()).hexdigest()[:12]]


def reporter_iri(name: str) -> URIRef:
    """The agent a client report is attributed to (``prov:wasAttributedTo``)."""
    return NFEX[f"client_{slug(name) or 'anonymous'}"]


# ------------------------------------------------------------------------------ rules and programs
def program_iri(name: str) -> URIRef:
    return NFEX[f"program_{slug(name)}"]


def statement_iri(program: str, label: str, occurrence: int = 0) -> URIRef:
    digest = hashlib.sha1(f"{program}\n{label}".encode()).hexdigest()[:10]
    suffix = f"_{occurrence + 1}" if occurrence else ""
    return NFEX[f"statement_{slug(program)}_{digest}{suffix}"]


def rule_iri(rule_id: str) -> URIRef:
    """A SPARQL pruning rule, from its file stem or API id (``measured-failures`` → ``rule_measured_failures``)."""
    return NFEX[f"rule_{rule_id.replace('-', '_')}"]


def condition_value_iri(dimension: str, value: str) -> URIRef:
    return NFEX[f"{dimension}_{value}"]


def model_iri(version: str, part: str) -> URIRef:
    """A trained model's network (``paramnet`` | ``selectornet``), as a selection cites it."""
    return URIRef(f"urn:nfex:model:{version}#{part}")
