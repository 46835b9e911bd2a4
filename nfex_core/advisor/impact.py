"""What a change to the graph would change in the decisions, computed without committing it.

An editor about to apply a program (or any change set) asks: in which contexts would the advisor
answer a different extractor α or different parameters Θ′? The condition space is finite (each
dimension takes one of its values or is unknown), so the answer is exact: the change is applied to an
in-memory copy of the default graph, the rule engine compiles that copy's table as it would after the
commit, and the advisor's context-only answer (mode "prior": the rules, the context shapes and the
measurements, no frame) is compared with the current graph's for every context. A context whose
compiled decision is equal in both tables gets the same answer when the measurement-derived inputs
(measured configurations, cost model, budget terms) are equal too, so only the others are asked (a
program changes a few hundred of the 1,296 contexts). The store is not written; a SHACL check of the change against the head (``KnowledgeGraph.check``) says whether the
commit would be accepted.

Frame-dependent parts of a selection (F_metrics on the pixels, estimated conditions) are not part of
the comparison: they need a frame. Budgets (``budget_ms``) are left out too: they are per request.
"""
from __future__ import annotations

import io
import itertools
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import NfexError
from ..kg.backends import EmbeddedBackend
from ..kg.changes import ChangeSet
from ..kg.terms import triple_n3
from ..rules.table import RuleTable

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph
    from . import Advisor

Context = dict[str, str | None]


@dataclass(frozen=True)
class Outcome:
    """The advisor's context-only answer: α and Θ′, or why there is none (every extractor pruned)."""

    extractor: str | None
    params: Mapping[str, Any] = field(default_factory=dict)
    pruned: tuple[str, ...] = ()
    error: str | None = None

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"extractor": self.extractor, "params": dict(self.params), "pruned": list(self.pruned)}
        if self.error:
            out["error"] = self.error
        return out


@dataclass(frozen=True)
class ContextChange:
    context: Context
    before: Outcome
    after: Outcome

    @property
    def alpha_changed(self) -> bool:
        return self.before.extractor != self.after.extractor

    def params_changed(self) -> dict[str, tuple[Any, Any]]:
        """Θ′ entries that differ (only meaningful when α is the same)."""
        keys = set(self.before.params) | set(self.after.params)
        return {k: (self.before.params.get(k), self.after.params.get(k))
                for k in sorted(keys) if self.before.params.get(k) != self.after.params.get(k)}

    def as_dict(self) -> dict[str, Any]:
        return {
            "context": {d: v for d, v in self.context.items() if v is not None},
            "alpha_changed": self.alpha_changed,
            "params_changed": {} if self.alpha_changed else {k: {"from": a, "to": b} for k, (a, b) in self.params_changed().items()},
            "before": self.before.as_dict(),
            "after": self.after.as_dict(),
        }


@dataclass(frozen=True)
class Impact:
    """Every context whose α or Θ′ the change would alter, from graph version ``version``."""

    version: int
    contexts: int  # compared
    changes: list[ContextChange]
    added: int
    removed: int
    conforms: bool
    violations: list[dict[str, Any]]
    elapsed_ms: float

    def as_dict(self, limit: int | None = None) -> dict[str, Any]:
        shown = self.changes if limit is None else self.changes[:limit]
        return {
            "graph_version": self.version,
            "contexts": self.contexts,
            "changed": len(self.changes),
            "alpha_changed": sum(c.alpha_changed for c in self.changes),
            "params_changed": sum(not c.alpha_changed for c in self.changes),
            "added": self.added,
            "removed": self.removed,
            "conforms": self.conforms,
            "violations": self.violations,
            "changes": [c.as_dict() for c in shown],
            "truncated": len(shown) < len(self.changes),
            "elapsed_ms": round(self.elapsed_ms, 1),
        }


def scratch_copy(kg: KnowledgeGraph, change: ChangeSet | None = None) -> KnowledgeGraph:
    """An in-memory KnowledgeGraph holding ``kg``'s default graph with ``change`` applied (not versioned:
    its head is 0). Works for an embedded and a remote store alike (the copy is read with one query)."""
    from ..kg.store import KnowledgeGraph

    buf = io.BytesIO()
    kg.backend.query_to("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }", "application/n-triples", buf)
    backend = EmbeddedBackend(None)
    backend.load(buf.getvalue())
    if change is not None and not change.empty:
        parts = []
        if change.removed:
            parts.append("DELETE DATA {\n" + "\n".join(triple_n3(t) for t in change.removed) + "\n}")
        if change.added:
            parts.append("INSERT DATA {\n" + "\n".join(triple_n3(t) for t in change.added) + "\n}")
        backend.update(" ;\n".join(parts))
    return KnowledgeGraph(backend, kg.settings)


def contexts(kg: KnowledgeGraph) -> list[Context]:
    """Every context of the graph's condition space: each dimension one of its values or unknown."""
    vocab = kg.vocabulary()
    dims = list(vocab.dimensions)
    values = [[*vocab.dimensions[d].values, None] for d in dims]
    return [dict(zip(dims, combo, strict=True)) for combo in itertools.product(*values)]


def outcome(advisor: Advisor, context: Context) -> Outcome:
    """The advisor's answer for ``context`` without a frame, or the reason it has none."""
    try:
        sel = advisor.select({d: v for d, v in context.items() if v is not None})
    except NfexError as e:
        pruned = tuple(sorted(p["extractor"] for p in e.extra.get("pruned", [])))
        return Outcome(None, {}, pruned, e.detail)
    return Outcome(sel.extractor, dict(sel.params), tuple(sorted(p.extractor for p in sel.pruned)))


def _unchanged(old: RuleTable, new: RuleTable) -> Callable[[Context], bool]:
    """A test for "the advisor answers ``context`` alike from both tables" that never says yes wrongly:
    equal decisions, and equal inputs the decisions do not hold (measured configurations, cost, budget)."""
    try:
        comparable = (old.dimensions == new.dimensions and old.configurations == new.configurations
                      and old.min_measurements == new.min_measurements and old.cost == new.cost
                      and old.budget_terms == new.budget_terms)
    except Exception:  # an input without a usable equality: compare every context
        comparable = False
    if not comparable:
        return lambda context: False

    def same(context: Context) -> bool:
        key = old.key(context)
        return key in old.decisions and old.decisions[key] == new.decisions.get(key)

    return same


def impact(kg: KnowledgeGraph, change: ChangeSet, *, make_advisor: Callable[[KnowledgeGraph], Advisor] | None = None) -> Impact:
    """Compare the advisor's context-only answers on the graph as it is and as it would be after
    ``change``, for every context; nothing is written. ``make_advisor`` builds the advisor for a scratch
    graph (default ``Advisor(graph)``, with ``kg``'s settings, as the service's).

    Both sides are answered from scratch copies loaded the same way: the order in which a store returns
    extractors and measurements decides ties, and a disk store and an in-memory copy may order them
    differently, which would show as changes no edit made."""
    from . import Advisor

    t0 = time.perf_counter()
    build = make_advisor or (lambda g: Advisor(g))
    version = kg.version
    report = kg.check(change) if not change.empty else None
    before, after = build(scratch_copy(kg)), build(scratch_copy(kg, change))
    same = _unchanged(before.engine.table(), after.engine.table())
    found: list[ContextChange] = []
    every = contexts(kg)
    for context in every:
        if same(context):
            continue
        a, b = outcome(before, context), outcome(after, context)
        if a.extractor != b.extractor or a.params != b.params:
            found.append(ContextChange(context, a, b))
    violations = [v.__dict__ for v in report.violations] if report is not None else []
    return Impact(
        version=version,
        contexts=len(every),
        changes=found,
        added=len(change.added),
        removed=len(change.removed),
        conforms=report.conforms if report is not None else True,
        violations=violations,
        elapsed_ms=(time.perf_counter() - t0) * 1000,
    )
