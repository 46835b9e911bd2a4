"""What each rule does across the condition space, read from the compiled table (rules/engine.py).

For every rule, DSL statement and context shape the table cites: in how many contexts it prunes each
extractor, adjusts a parameter, weighs a metric, adds a preference or is in force as a bound, with one
example context each. The workbench shows it beside a rule ("prunes SIFT in 216 of 1,296 contexts,
e.g. agent = car, motion = fast"); it costs one pass over the table's decisions.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .table import RuleTable
from .types import Citation


@dataclass
class Effect:
    """One effect of one rule: ``what`` (e.g. "prunes SIFT", "adjusts ORB.nfeatures"), in ``contexts``
    contexts, first seen in ``example``."""

    what: str
    contexts: int = 0
    example: dict[str, str] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"what": self.what, "contexts": self.contexts, "example": self.example}


@dataclass
class RuleEffects:
    iri: str
    label: str
    kind: str
    source: str | None
    reasons: set[str] = field(default_factory=set)
    effects: dict[str, Effect] = field(default_factory=dict)

    def add(self, what: str, context: Mapping[str, str | None], reason: str | None = None) -> None:
        e = self.effects.get(what)
        if e is None:
            e = self.effects[what] = Effect(what, 0, {d: v for d, v in context.items() if v is not None})
        e.contexts += 1
        if reason:
            self.reasons.add(reason)

    def as_dict(self) -> dict[str, Any]:
        return {"iri": self.iri, "label": self.label, "kind": self.kind, "source": self.source,
                "reasons": sorted(self.reasons)[:20],
                "effects": [e.as_dict() for e in sorted(self.effects.values(), key=lambda e: (-e.contexts, e.what))]}


def effects(table: RuleTable) -> dict[str, RuleEffects]:
    """Rule IRI → its effects over every context of ``table``."""
    out: dict[str, RuleEffects] = {}

    def of(c: Citation) -> RuleEffects:
        r = out.get(c.rule)
        if r is None:
            r = out[c.rule] = RuleEffects(c.rule, c.label, c.kind, c.source)
        return r

    for decision in table.decisions.values():
        ctx = decision.context
        for x, cites in decision.pruned.items():
            for c in cites:
                of(c).add(f"prunes {x}", ctx, c.reason)
        for x, params in decision.factors.items():
            for p, f in params.items():
                for c in f.citations:
                    of(c).add(f"adjusts {x}.{p}", ctx, c.reason)
        for m, f in decision.weights.items():
            for c in f.citations:
                of(c).add(f"weighs {m}", ctx, c.reason)
        for x, f in decision.bonuses.items():
            for c in f.citations:
                of(c).add(f"prefers {x}", ctx, c.reason)
        for sh in decision.shapes:
            if sh.bound is not None:
                b = sh.bound
                of(sh.citation).add(f"bounds {b.extractor}.{b.parameter}", ctx, sh.message)
    return out
