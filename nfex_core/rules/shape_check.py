"""The advisor's check of a candidate (α, Θ′) against the context shapes in force — no pySHACL.

The decision for a context carries the compiled shapes whose gate atoms hold there
(``Decision.shapes``). For a candidate of extractor α with parameters Θ′ = g(Θ, E):

- a prohibition that concerns α prunes it (the engine already removed such α from the candidates);
- a violated bound ``θ_k ⋈ b`` is repaired by clamping θ_k to b (the nearest value of θ_k's datatype
  that satisfies it), cited with the shape's IRI and sh:message, kind "shape" — unless the shape says
  ``nfex:pruneOnViolation`` or the clamped value lies outside θ_k's range, which prunes α;
- after repair every bound must hold (two shapes may contradict each other), otherwise α is pruned
  citing the bound that still fails.

``materialise`` writes the candidate as the RDF that pySHACL validates
(tests/nfex_core/rules/test_shapes_compiled.py shows the two verdicts agree).
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import rdflib
from rdflib.namespace import RDF
from rdflib.term import URIRef

from ..kg.namespaces import NFEX
from ..kg.vocab import ExtractorSpec, ParameterSpec, Value, Vocabulary
from .types import Adjustment, Bound, Citation, CompiledShape


@dataclass(frozen=True)
class ShapeOutcome:
    params: dict[str, Value]
    adjustments: tuple[Adjustment, ...] = ()
    pruned: tuple[Citation, ...] = ()


def violations(spec: ExtractorSpec, params: Mapping[str, Value], shapes: Iterable[CompiledShape]) -> list[CompiledShape]:
    """The shapes in force that the unrepaired candidate violates (what pySHACL would report)."""
    return [s for s in shapes if s.violated(spec, params)]


def _step(p: ParameterSpec, value: float, up: bool) -> float:
    if p.datatype == "integer":
        return math.floor(value) + 1 if up else math.ceil(value) - 1
    return math.nextafter(value, math.inf if up else -math.inf)


def repair(bound: Bound, p: ParameterSpec) -> Value | None:
    """The value of θ_k nearest the bound that satisfies it and lies in θ_k's range; None if none does.

    The bound is moved to θ_k's datatype on its satisfied side (an integer ``< 10`` is 9, a double
    ``< b`` the float below b), then into θ_k's range.
    """
    if p.datatype == "boolean" or p.allowed is not None:
        candidates: list[Value] = [bound.literal.toPython()] if p.datatype == "boolean" else list(p.allowed or ())
        ok = [v for v in candidates if _fits(p, v) and bound.holds(p, v)]
        return ok[0] if ok else None
    b = float(bound.literal.toPython())
    v: float = b
    if p.datatype == "integer":
        v = {"<=": math.floor(b), ">=": math.ceil(b), "<": math.ceil(b) - 1, ">": math.floor(b) + 1}.get(bound.comparator, b)
    for _ in range(3):  # a double bound may sit between two floats: step once or twice to the right side
        if bound.holds(p, _typed(p, v)):
            break
        v = _step(p, v, up=bound.comparator in (">", ">="))
    out = p.clamp(v)  # a bound beyond the range: the range's end may still satisfy it
    return out if _fits(p, out) and bound.holds(p, out) else None


def _typed(p: ParameterSpec, v: float) -> Value:
    return int(v) if p.datatype == "integer" and float(v).is_integer() else float(v)


def _fits(p: ParameterSpec, v: Value) -> bool:
    try:
        p.validate(v)
    except Exception:
        return False
    return True


def enforce(spec: ExtractorSpec, params: Mapping[str, Value], shapes: Iterable[CompiledShape]) -> ShapeOutcome:
    """Repair Θ′ against the shapes that concern α, or prune α; see the module docstring."""
    theta = dict(params)
    mine = [s for s in shapes if s.concerns(spec.name)]
    adjustments: list[Adjustment] = []
    for s in mine:
        if not s.violated(spec, theta):
            continue
        bound = s.bound
        if bound is None or s.prune or bound.extractor != spec.name or bound.parameter not in theta:
            return ShapeOutcome(theta, tuple(adjustments), (s.citation,))
        fixed = repair(bound, spec.parameters[bound.parameter])
        if fixed is None:
            return ShapeOutcome(theta, tuple(adjustments), (s.citation,))
        adjustments.append(Adjustment(bound.parameter, theta[bound.parameter], fixed, 1.0, (s.citation,)))
        theta[bound.parameter] = fixed
    still = violations(spec, theta, mine)
    if still:
        return ShapeOutcome(theta, tuple(adjustments), (still[0].citation,))
    return ShapeOutcome(theta, tuple(adjustments))


def materialise(
    vocab: Vocabulary,
    extractor: str,
    params: Mapping[str, Value],
    context: Mapping[str, str | None],
    node: URIRef = NFEX.candidate,
) -> rdflib.Graph:
    """The candidate as RDF: a nfex:CandidateConfiguration with every setting and the known conditions."""
    spec = vocab.extractor(extractor)
    g = rdflib.Graph()
    g.add((node, RDF.type, NFEX.CandidateConfiguration))
    g.add((node, NFEX.ofExtractor, spec.iri))
    for name, value in params.items():
        setting = URIRef(f"{node}_{name}")
        g.add((node, NFEX.hasSetting, setting))
        g.add((setting, RDF.type, NFEX.ParameterSetting))
        g.add((setting, NFEX.parameter, spec.parameters[name].iri))
        g.add((setting, NFEX.value, spec.parameters[name].literal(value)))
    for dim, known in context.items():
        if known is not None:
            v = vocab.dimensions[dim].values[known]
            g.add((node, NFEX.underCondition, v.iri))
            g.add((v.iri, NFEX.inDimension, vocab.dimensions[dim].iri))
    return g


def _witness(shape: CompiledShape, vocab: Vocabulary) -> dict[str, str | None] | None:
    """A context in which the shape's gate atoms hold (None when this simple choice finds none)."""
    ctx: dict[str, str | None] = {}
    for a in shape.atoms:
        values = sorted(a.values) if not a.negated else sorted(set(vocab.dimensions[a.dimension].values) - a.values)
        if values:
            ctx.setdefault(a.dimension, values[0])
    return ctx if shape.applies(ctx) else None


def verify_prohibitions(shapes: list[CompiledShape], vocab: Vocabulary, graph: rdflib.Graph) -> tuple[list[CompiledShape], list[str]]:
    """Keep a prohibition only if pySHACL rejects a candidate its gate admits (once per graph version).

    A requirement that reads no setting is compiled as "prune wherever the gate holds"; this checks the
    claim on one candidate per extractor (defaults) in one context where the gate holds.
    """
    from ..kg.validation import run_pyshacl, shapes_closure

    kept: list[CompiledShape] = []
    errors: list[str] = []
    for s in shapes:
        ctx = _witness(s, vocab) if s.bound is None else None
        if ctx is None:
            kept.append(s)
            continue
        data = rdflib.Graph()
        nodes = set()
        for x, spec in vocab.extractors.items():
            if s.concerns(x):
                node = URIRef(f"{NFEX}witness_{x}")
                nodes.add(str(node))
                data += materialise(vocab, x, spec.defaults(), ctx, node)
        closure = shapes_closure({s.iri}, lambda ns: (t for n in ns for t in graph.triples((n, None, None))))
        results, _ = run_pyshacl(data, closure, None)
        missed = nodes - {r.focus_node for r in results if r.source_shape == str(s.iri)}
        if missed:
            errors.append(
                f"{s.iri}: its requirement is neither a parameter bound nor violated by a candidate its gate admits "
                f"({', '.join(sorted(m.rsplit('_', 1)[-1] for m in missed))} under {ctx}); not compiled (docs/shapes.md)"
            )
        else:
            kept.append(s)
    return kept, errors
