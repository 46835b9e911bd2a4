"""Observations carried from one graph version to the next: incremental reading for the rule table's compile.

Reading every Measurement (observations.py) and every measured configuration's settings (cost.py) is most of
a compile's time on a graph with many measurements, yet a feedback report adds one Measurement. An
``ObservationIndex`` holds both at graph version v; ``advance(kg)`` brings it to the head by re-reading only
what the change since v can have touched:

- S: every subject of a triple the change added or removed (kg.diff(v, head)) that the rows' queries can
  read (their footprint, kg/storage/footprint.py: an extractor's comment or a statement is not);
- a Measurement's row reads its own triples and, along ``?m → ?cfg → ?extractor``, ``?m → ?condition →
  ?dimension``, ``?m → ?sequence``, nodes at most two steps away; a configuration's settings read
  ``?cfg → ?setting → ?parameter``, also two steps. So the affected nodes are S and every node with a path of
  one or two triples to a member of S (one query), and only those Measurements and configurations are read
  again (the others' rows cannot have changed);
- a change too large to pay off (more than ``MAX_SUBJECTS`` subjects), one that touches blank nodes (they
  cannot be named in a query), or a history that cannot be read is answered by a full read.

The result equals a full read (tests/nfex_core/evidence/test_index.py: random changes, compared with
``ObservationIndex.read``).
"""
from __future__ import annotations

import functools
import logging
import time
from collections import Counter
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from rdflib.term import URIRef

from ..kg.rdf.terms import Triple, py
from ..kg.storage.footprint import Footprint, footprint, pairs, reads
from ..kg.storage.history import prefix_block
from ..kg.vocabulary.specs import Value
from .observations import OBSERVATIONS, Observation, read_observations, restricted

if TYPE_CHECKING:
    from ..kg.storage.changes import ChangeSet
    from ..kg.store import KnowledgeGraph

log = logging.getLogger("nfex.evidence")

Diff = Callable[[int, int], "ChangeSet"]  # (since, until) → the net change, as KnowledgeGraph.diff
MAX_SUBJECTS = 2000  # above this a full read is as cheap as finding what changed

SETTINGS = """SELECT ?cfg ?name ?v WHERE {
    ?cfg a nfex:Configuration ; nfex:hasSetting ?s . ?s nfex:parameter/nfex:opencvName ?name ; nfex:value ?v .
}"""
# the bound pattern first: Oxigraph joins in the written order, and ``?x ?p ?o . ?o ?q ?s`` scans the graph
# (380 ms on 34k statements against 0.2 ms)
NEAR = """SELECT DISTINCT ?x WHERE {
    { ?x ?p ?s } UNION { ?o ?q ?s . ?x ?p ?o }
    FILTER (isIRI(?x))
}"""


def read_settings(kg: KnowledgeGraph, configurations: Collection[str]) -> dict[str, dict[str, Value]]:
    """Configuration IRI → {OpenCV name: value}, for ``configurations`` (each present, {} without settings)."""
    out: dict[str, dict[str, Value]] = {c: {} for c in configurations}
    if out:
        for r in kg.select(restricted(SETTINGS, "cfg", out)).rows:
            out[str(r["cfg"])][str(r["name"])] = py(r["v"])
    return out


@dataclass(frozen=True)
class ObservationIndex:
    """Every Measurement (by IRI) and the settings of every configuration they used, at graph ``version``."""

    version: int
    observations: Mapping[str, Observation]
    settings: Mapping[str, dict[str, Value]]  # every configuration an observation used; {} where it has no settings
    uses: Mapping[str, int] = field(default_factory=dict)  # configuration → observations that used it
    reread: int = -1  # Measurements and configurations read again by the last advance (−1: a full read)
    ms: float = 0.0
    changed: frozenset[str] | None = None  # Measurements whose row the last advance added, removed or changed (None: a full read)
    resettled: frozenset[str] = frozenset()  # configurations whose settings it added, removed or changed

    @classmethod
    def read(cls, kg: KnowledgeGraph) -> ObservationIndex:
        """A full read at the head."""
        t0 = time.perf_counter()
        version = kg.version
        observations = read_observations(kg)
        uses = Counter(o.configuration for o in observations)
        return cls(version, {o.iri: o for o in observations}, read_settings(kg, uses), dict(uses),
                   ms=(time.perf_counter() - t0) * 1000)

    def all(self) -> list[Observation]:
        """The observations, sorted by IRI (a full read's order does not matter to any reader; this one is stable)."""
        return [self.observations[i] for i in sorted(self.observations)]

    def measured_settings(self) -> dict[str, dict[str, Value]]:
        """As cost.measured_settings: the configurations a Measurement used that have settings."""
        return {c: dict(s) for c, s in self.settings.items() if s}

    def advance(self, kg: KnowledgeGraph, diff: Diff | None = None, head: int | None = None) -> ObservationIndex:
        """The index at ``head`` (default: the store's head), reading again only what the change since ``version``
        can have touched. ``diff``: how to read that change (default ``kg.diff``; a compile shares one between its
        readers). A commit landing after ``head`` while nodes are read may show in their rows; those nodes are
        in the next advance's change, so they are read again then."""
        t0 = time.perf_counter()
        head = kg.version if head is None else head
        if head == self.version:
            return replace(self, reread=0, changed=frozenset(), resettled=frozenset())
        try:
            change = (diff or kg.diff)(self.version, head)
        except Exception as e:  # a pruned or unreadable history: read everything
            log.info("observation index: no diff from version %d (%s); reading all", self.version, e)
            return ObservationIndex.read(kg)
        relevant = _relevant(change)
        subjects = {t[0] for t in relevant}
        if len(subjects) > MAX_SUBJECTS or any(not isinstance(s, URIRef) or not _nameable(str(s)) for s in subjects):
            return ObservationIndex.read(kg)
        touched = {str(s) for s in subjects}
        if touched:
            touched |= {str(r["x"]) for r in kg.select(restricted(NEAR, "s", touched)).rows if _nameable(str(r["x"]))}
        observations = dict(self.observations)
        uses = Counter(self.uses)
        for iri in touched:
            old = observations.pop(iri, None)
            if old is not None:
                uses[old.configuration] -= 1
        for o in read_observations(kg, touched):
            observations[o.iri] = o
            uses[o.configuration] += 1
        configurations = {c for c, n in uses.items() if n > 0}
        stale = (configurations - set(self.settings)) | (configurations & touched)
        settings = {c: s for c, s in self.settings.items() if c in configurations and c not in stale}
        settings.update(read_settings(kg, stale))
        changed = frozenset(i for i in touched if self.observations.get(i) != observations.get(i))
        resettled = frozenset(c for c in set(self.settings) | set(settings) if self.settings.get(c) != settings.get(c))
        return ObservationIndex(head, observations, settings, {c: uses[c] for c in configurations}, len(touched),
                                (time.perf_counter() - t0) * 1000, changed, resettled)


@functools.cache
def _footprint() -> Footprint | None:
    """What a Measurement's row and a configuration's settings read (kg/storage/footprint.py)."""
    rows, settings = footprint(prefix_block() + OBSERVATIONS), footprint(prefix_block() + SETTINGS)
    return None if rows is None or settings is None else rows | settings


def _relevant(change: ChangeSet) -> list[Triple]:
    """The triples of ``change`` that a row of the index can read: a change of anything else (an extractor's
    comment, a statement) re-reads nothing."""
    fp = _footprint()
    return [t for t in (*change.added, *change.removed) if reads(fp, pairs([t]))]


def _nameable(iri: str) -> bool:
    """Whether ``iri`` can be written as ``<iri>`` in a query."""
    return not any(c in iri for c in '<>"{}|^`\\ \n\t')
