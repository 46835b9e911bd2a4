"""DSL statements as the rule engine reads them from the graph.

``nfex_core/rules/dsl`` compiles programs to triples (docs/dsl.md); this module reads those triples
back as plain records and decides when a statement applies. A statement applies in a context when
every condition atom holds; an atom holds when the context's value for its dimension is one of the
atom's values — negated for ``is not`` — and never when the context does not know that dimension.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rdflib.term import Literal, Node, URIRef

from ..kg.rdf.terms import py
from ..kg.vocabulary.vocab import ExtractorSpec, MetricSpec, ParameterSpec, Vocabulary
from .types import ConditionAtom

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

KINDS = {
    "PruneStatement": "prune",
    "AdjustStatement": "adjust",
    "WeightStatement": "weight",
    "PreferStatement": "prefer",
    "RequireStatement": "require",
    "AcceptStatement": "accept",
    "EscalateStatement": "escalate",
}


@dataclass(frozen=True)
class CompiledStatement:
    """A DSL statement as compiled into the graph and read back by the engine (the parsed form is
    ``dsl.parser.Statement``)."""

    iri: URIRef
    kind: str  # prune | adjust | weight | prefer | require | accept | escalate
    label: str
    reason: str
    program: str
    order: int
    atoms: tuple[ConditionAtom, ...]
    source: str | None = None  # "rules/programs/default.nfex:12"
    extractor: str | None = None  # prune, prefer; adjust/require: the parameter's extractor
    parameter: str | None = None  # adjust, require: the OpenCV argument name
    metric: str | None = None  # weight
    value: float | int | bool | None = None  # factor, weight, bonus, bound
    comparator: str | None = None  # require
    shape: URIRef | None = None  # require: the SHACL shape compiled from it
    tests: tuple[tuple[str, str, float], ...] = ()  # accept: (signal, comparator, bound), in order

    def applies(self, context: Mapping[str, str | None]) -> bool:
        return all(a.holds(context) for a in self.atoms)



def load_statements(kg: KnowledgeGraph, vocab: Vocabulary) -> list[CompiledStatement]:
    """Every enabled statement of every program, in program order."""
    rows = kg.select(
        """SELECT ?s ?type ?label ?reason ?program ?order ?file ?line ?x ?p ?m ?factor ?weight ?bonus ?bound ?cmp ?shape WHERE {
            ?s a ?type ; nfex:inProgram ?prog .
            FILTER (?type IN (nfex:PruneStatement, nfex:AdjustStatement, nfex:WeightStatement, nfex:PreferStatement, nfex:RequireStatement,
                              nfex:AcceptStatement, nfex:EscalateStatement))
            FILTER NOT EXISTS { ?s nfex:enabled false }
            ?prog rdfs:label ?program .
            OPTIONAL { ?s rdfs:label ?label } OPTIONAL { ?s nfex:reason ?reason } OPTIONAL { ?s nfex:order ?order }
            OPTIONAL { ?prog nfex:sourceFile ?file } OPTIONAL { ?s nfex:line ?line }
            OPTIONAL { ?s nfex:prunes|nfex:prefers ?x } OPTIONAL { ?s nfex:parameter ?p } OPTIONAL { ?s nfex:metric ?m }
            OPTIONAL { ?s nfex:factor|nfex:maxEscalations ?factor } OPTIONAL { ?s nfex:weight ?weight } OPTIONAL { ?s nfex:bonus ?bonus }
            OPTIONAL { ?s nfex:bound ?bound } OPTIONAL { ?s nfex:comparator ?cmp } OPTIONAL { ?s nfex:shape ?shape }
        }"""
    ).rows
    atoms: dict[Node, dict[Node, tuple[str, set[str], bool]]] = {}
    for r in kg.select(
        """SELECT ?s ?a ?dim ?v ?neg WHERE {
            ?s nfex:hasCondition ?a . ?a nfex:dimension/nfex:token ?dim ; nfex:oneOf/nfex:token ?v .
            OPTIONAL { ?a nfex:negated ?neg }
        }"""
    ).rows:
        entry = atoms.setdefault(r["s"], {}).setdefault(r["a"], (str(r["dim"]), set(), bool(py(r.get("neg", Literal(False))))))
        entry[1].add(str(r["v"]))

    tests: dict[Node, list[tuple[int, str, str, float]]] = {}
    for r in kg.select(
        """SELECT ?s ?order ?signal ?cmp ?bound WHERE {
            ?s nfex:hasTest ?t . ?t nfex:signal ?signal ; nfex:testComparator ?cmp ; nfex:threshold ?bound .
            OPTIONAL { ?t nfex:order ?order }
        }"""
    ).rows:
        order = int(py(r["order"])) if "order" in r else 0
        tests.setdefault(r["s"], []).append((order, str(r["signal"]), str(r["cmp"]), float(py(r["bound"]))))

    out: list[CompiledStatement] = []
    for r in rows:
        kind = KINDS[str(r["type"]).rsplit("#", 1)[-1]]
        extractor = parameter = metric = None
        x, p, m = (vocab.by_iri.get(URIRef(str(r[k]))) if k in r else None for k in ("x", "p", "m"))
        if isinstance(x, ExtractorSpec):
            extractor = x.name
        if isinstance(p, ParameterSpec):
            extractor, parameter = p.extractor, p.name
        if isinstance(m, MetricSpec):
            metric = m.name
        value = next((py(r[k]) for k in ("factor", "weight", "bonus", "bound") if k in r), None)
        source = None
        if "file" in r:
            source = f"{r['file']}:{r['line']}" if "line" in r else str(r["file"])
        label = str(r.get("label", ""))
        out.append(
            CompiledStatement(
                iri=r["s"],  # type: ignore[arg-type]
                kind=kind,
                label=label,
                reason=str(r.get("reason", label)),
                program=str(r["program"]),
                order=int(py(r["order"])) if "order" in r else 0,
                atoms=tuple(ConditionAtom(d, frozenset(vs), neg) for d, vs, neg in atoms.get(r["s"], {}).values()),
                source=source,
                extractor=extractor,
                parameter=parameter,
                metric=metric,
                value=value,
                comparator=str(r["cmp"]) if "cmp" in r else None,
                shape=r.get("shape"),  # type: ignore[arg-type]
                tests=tuple((sig, cmp, b) for _, sig, cmp, b in sorted(tests.get(r["s"], []))),
            )
        )
    out.sort(key=lambda s: (s.program, s.order, str(s.iri)))
    return out
