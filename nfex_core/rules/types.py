"""The rule engine's value types: what a compiled decision is made of, and what it cites.

A leaf module (it imports no behaviour of nFEX above ``kg``): the engine produces these, the
advisor, the budget, the context shapes, the neural step and the fitness function read them.

- ``Citation``: a rule, statement or shape that shaped a decision, as a Selection reports it;
- ``Factor``: a value with the citations that produced it — f_kj, h_x(E) or a preference bonus
  (paper §IV-A: factors multiply, weights multiply, bonuses add);
- ``Adjustment``: one parameter of Θ changed to Θ′, by which factor and why;
- ``ConditionAtom``: "dimension is one of V" (or its negation), the condition of a DSL statement or
  of a context shape's gate; it never holds where the context does not know the dimension;
- ``Bound`` / ``CompiledShape``: a context shape compiled to "gate ⇒ θ_k ⋈ b" or a prohibition;
- ``Evidence`` / ``MeasuredConfiguration``: what the graph measured for an extractor, or one of its
  configurations, under a context's known conditions;
- ``PairTest`` / ``AcceptRule`` / ``Policy``: the verification of frame pairs in force in a context,
  compiled from ``accept pair if …`` and ``escalate at most N`` statements (verification/judge.py judges);
- ``Decision``: everything the table holds for one context.
"""
from __future__ import annotations

import math
import operator
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pyshacl.rdfutil.compare import compare_literal
from rdflib.term import Literal, URIRef

from ..evidence.aggregate import ROBUST
from ..kg.vocabulary.vocab import ExtractorSpec, ParameterSpec, Value

ContextKey = tuple[str | None, ...]

# what an ``accept pair if …`` statement may test (verification/judge.py computes them)
PAIR_SIGNALS: dict[str, str] = {
    "inliers": "RANSAC inliers of the essential matrix",
    "matches": "ratio-test matches",
    "keypoints": "keypoints in the newer frame",
    "parallax": "median inlier parallax, px",
    "extraction_ms": "extraction time of this try, ms",
    "rotation": "rotation angle of the estimate, degrees",
    "rotation_change": "angle between the estimate's rotation and the motion prior's, degrees",
    "heading_change": "angle between the estimate's direction of motion and the motion prior's, degrees",
    "agreement": "least disagreement (rotation + direction, degrees) with another candidate's estimate of the pair",
}
MAX_ESCALATIONS = 5
PAIR_COMPARATORS: dict[str, Callable[[float, float], bool]] = {
    "<=": operator.le, "<": operator.lt, ">=": operator.ge, ">": operator.gt,
}
DEFAULT_ESCALATIONS = 1


@dataclass(frozen=True)
class PairTest:
    signal: str
    comparator: str
    bound: float

    def holds(self, signals: Mapping[str, float | None]) -> bool:
        v = signals.get(self.signal)
        return v is not None and math.isfinite(v) and PAIR_COMPARATORS[self.comparator](v, self.bound)

    def text(self) -> str:
        return f"{self.signal} {self.comparator} {self.bound:g}"


@dataclass(frozen=True)
class AcceptRule:
    tests: tuple[PairTest, ...]
    atoms: tuple[ConditionAtom, ...]
    citation: Citation


@dataclass(frozen=True)
class Policy:
    """The verification in force in one context."""

    accept: tuple[AcceptRule, ...] = ()
    escalations: int = DEFAULT_ESCALATIONS
    escalation_citation: Citation | None = None

    @property
    def active(self) -> bool:
        return bool(self.accept)

    @property
    def max_tries(self) -> int:
        return 1 + self.escalations if self.active else 1



NO_POLICY = Policy()


@dataclass(frozen=True)
class Citation:
    """A rule that shaped a decision, as a selection reports it."""

    rule: str
    label: str
    reason: str
    kind: str  # sparql | prune | adjust | weight | prefer | require | budget | shape | measured | verify | backend
    source: str | None = None

    def as_dict(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if v is not None}


@dataclass(frozen=True)
class Factor:
    value: float
    citations: tuple[Citation, ...] = ()


@dataclass(frozen=True)
class Adjustment:
    """θ_k changed from ``before`` to ``after`` (``factor`` = w_k before clamping), and why."""

    parameter: str
    before: Value
    after: Value
    factor: float
    citations: tuple[Citation, ...]

    @property
    def clamped(self) -> bool:
        return isinstance(self.after, int | float) and not isinstance(self.after, bool) and abs(
            float(self.before) * self.factor - float(self.after)
        ) > 1e-9 * max(1.0, abs(float(self.after)))

    def as_dict(self) -> dict[str, Any]:
        return {"parameter": self.parameter, "from": self.before, "to": self.after, "factor": round(self.factor, 6),
                "clamped": self.clamped, "because": [c.as_dict() for c in self.citations]}


@dataclass(frozen=True)
class ConditionAtom:
    """``dimension is one of values`` (``negated``: a known value not among them)."""

    dimension: str
    values: frozenset[str]
    negated: bool = False

    def holds(self, context: Mapping[str, str | None]) -> bool:
        value = context.get(self.dimension)
        if value is None:
            return False
        return (value in self.values) != self.negated


@dataclass(frozen=True)
class Bound:
    """``extractor.parameter ⋈ literal``: the requirement that a candidate's setting satisfies."""

    extractor: str
    parameter: str
    comparator: str  # <= < >= > =
    literal: Literal

    def holds(self, spec: ParameterSpec, value: Value) -> bool:
        """The SHACL verdict on the setting ``value`` (pySHACL's own literal comparison)."""
        node = spec.literal(value)
        if self.comparator == "=":
            return bool(node == self.literal)
        try:
            c = compare_literal(node, self.literal)
        except Exception:  # incomparable literals fail the constraint in pySHACL too
            return False
        return {"<=": c <= 0, "<": c < 0, ">=": c >= 0, ">": c > 0}[self.comparator]

    def text(self) -> str:
        return f"{self.extractor}.{self.parameter} {self.comparator} {self.literal}"


@dataclass(frozen=True)
class CompiledShape:
    """One context shape (or a DSL ``require`` without a shape) as the advisor checks it."""

    iri: URIRef
    label: str
    message: str
    extractor: str | None  # None: the gate admits every extractor
    atoms: tuple[ConditionAtom, ...]
    bound: Bound | None  # None: a prohibition
    prune: bool = False  # nfex:pruneOnViolation: do not clamp
    kind: str = "shape"  # shape | require
    source: str | None = None

    def applies(self, context: Mapping[str, str | None]) -> bool:
        return all(a.holds(context) for a in self.atoms)

    def concerns(self, extractor: str) -> bool:
        return self.extractor is None or self.extractor == extractor

    def violated(self, spec: ExtractorSpec, params: Mapping[str, Value]) -> bool:
        """The unrepaired verdict for candidate (spec, params) in a context where the gate's atoms hold."""
        if not self.concerns(spec.name):
            return False
        if self.bound is None:
            return True
        if self.bound.extractor != spec.name or self.bound.parameter not in params:
            return True  # no setting of that parameter: sh:qualifiedMinCount 1 fails
        return not self.bound.holds(spec.parameters[self.bound.parameter], params[self.bound.parameter])

    @property
    def citation(self) -> Citation:
        return Citation(str(self.iri), self.label, self.message, self.kind, self.source)


@dataclass(frozen=True)
class Evidence:
    """What the graph has measured (and admitted) for an extractor under the context's known conditions: the
    windows that count there (``Observation.counts_under``), the median ATE and extraction time over them."""

    ate: float | None
    windows: int
    extraction_ms: float | None = None
    outliers: int = 0  # windows whose ATE lies over 3 scaled MADs from the median (aggregate.py)
    sources: tuple[str, ...] = ()  # sweep runs and reporters behind the windows

    def as_dict(self) -> dict[str, Any]:
        return {"ate_m": self.ate, "aggregate": ROBUST, "windows": self.windows, "outliers": self.outliers,
                "sources": len(self.sources), "source_iris": list(self.sources[:10]), "extraction_ms": self.extraction_ms}


@dataclass(frozen=True)
class MeasuredConfiguration:
    """A configuration of an extractor and its measured accuracy under a context's known conditions."""

    iri: str
    params: Mapping[str, Value]  # the full Θ: OpenCV argument names → values, valid in the graph's ranges
    ate: float  # the median ATE over the windows that count
    windows: int  # measurements that count under the context
    outliers: int = 0
    sources: tuple[str, ...] = ()


@dataclass(frozen=True)
class Decision:
    """The compiled table's entry for one context E."""

    context: Mapping[str, str | None]
    candidates: tuple[str, ...]  # C(E)
    pruned: Mapping[str, tuple[Citation, ...]]
    factors: Mapping[str, Mapping[str, Factor]]  # extractor → parameter → f (the product over statements)
    weights: Mapping[str, Factor]  # metric → h_x(E)
    bonuses: Mapping[str, Factor]  # extractor → preference bonus
    evidence: Mapping[str, Evidence] = field(default_factory=dict)
    shapes: tuple[CompiledShape, ...] = ()  # context shapes whose gate holds here (rules/shape_check.py)
    verification: Policy = NO_POLICY  # how a frame pair's estimate is judged here (verification/judge.py)

    def bonus(self, extractor: str) -> float:
        """The preference bonus of ``extractor`` here (0 without one)."""
        return self.bonuses[extractor].value if extractor in self.bonuses else 0.0
