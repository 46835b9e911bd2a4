"""Evidence before influence: which Measurements may steer selections (DESIGN.md, "Evidence and trust").

A Measurement is a *report* when it is attributed to an agent (``prov:wasAttributedTo``): that is how
``POST /v1/feedback`` records what a reporter token's holder measured. Everything else was written by
nFEX's own runs (the shipped sweeps, ``nfex sweep``) or by an editor, and is admitted as it is. A
report is admitted

- when an editor accepted it (``nfex:acceptedBy``, ``POST /v1/feedback/{id}/accept``), or
- when it is corroborated: at least ``nfex:minSources`` distinct reporters (a graph setting, default 3)
  reported the same configuration under the same conditions (the same set of condition values).

Until then it stays in the graph with its run and reporter, visible to SPARQL, but no reader of
evidence — the rule engine's measurement rules and measured Θ′, the measured accuracy, the cost model,
the dynamic baselines — counts it. ``admit`` is that selection, in one place; an evidence scope (which
sequences, runs and sources a reader may use) narrows its result further.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..kg.rdf.terms import py
from .observations import Observation

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

DEFAULT_MIN_SOURCES = 3


@dataclass(frozen=True)
class TrustPolicy:
    min_sources: int = DEFAULT_MIN_SOURCES

    @classmethod
    def load(cls, kg: KnowledgeGraph) -> TrustPolicy:
        rows = kg.select("SELECT ?n WHERE { nfex:minSources nfex:value ?n }").rows
        return cls(max(1, int(py(rows[0]["n"])))) if rows else cls()


def corroboration_key(o: Observation) -> tuple[str, frozenset[tuple[str, str]]]:
    """Reports corroborate each other when they measured the same configuration under the same conditions."""
    return (o.configuration, o.conditions)


@dataclass(frozen=True)
class Admission:
    """Per Measurement IRI, why it counts (``admitted``) or why not yet (``quarantined``)."""

    admitted: dict[str, str] = field(default_factory=dict)
    quarantined: dict[str, str] = field(default_factory=dict)

    def select(self, observations: Iterable[Observation]) -> list[Observation]:
        return [o for o in observations if o.iri in self.admitted]


def report_status(o: Observation, reporters: int, policy: TrustPolicy) -> tuple[bool, str]:
    """Whether ``o`` counts, and why: ``reporters`` is the number of distinct reporters of its corroboration key
    (unused for a Measurement that is no report)."""
    if o.reporter is None:
        return True, "measured by nFEX" if o.run else "written by an editor"
    if o.accepted_by is not None:
        return True, f"report accepted by {o.accepted_by}"
    if reporters >= policy.min_sources:
        return True, f"report corroborated by {reporters} reporters"
    return False, (f"report by {o.reporter}: {reporters} of the {policy.min_sources} reporters (nfex:minSources) that must "
                   "report this configuration under these conditions, and not accepted by an editor")


def admit(observations: Iterable[Observation], policy: TrustPolicy) -> Admission:
    """Which observations may steer selections, and why (module docstring)."""
    items = list(observations)
    reporters: dict[tuple[str, frozenset[tuple[str, str]]], set[str]] = {}
    for o in items:
        if o.reporter is not None:
            reporters.setdefault(corroboration_key(o), set()).add(o.reporter)
    out = Admission()
    for o in items:
        counts, reason = report_status(o, len(reporters[corroboration_key(o)]) if o.reporter is not None else 0, policy)
        (out.admitted if counts else out.quarantined)[o.iri] = reason
    return out


def admitted(kg: KnowledgeGraph, observations: Iterable[Observation]) -> list[Observation]:
    """The observations that may steer selections under the graph's trust policy."""
    items = list(observations)
    return admit(items, TrustPolicy.load(kg)).select(items)
