"""SPARQL pruning rules (``rules/pruning/*.rq``): which extractors a context excludes, and why.

A rule is a SPARQL SELECT returning ``?extractor`` and a human-readable ``?reason``. It may read the
context through one variable per condition dimension, named by the dimension's token (``?agent``,
``?light``, …) and bound to condition-value IRIs — unbound where the context does not know the value,
so a rule that needs a dimension should test it (``FILTER (?light = nfex:light_dark)`` fails when
``?light`` is unbound, which is the conservative outcome).

Rules are graph data: seeding stores each file as a ``nfex:SparqlRule`` with its label, comment,
source file and query text, so a selection cites the rule's IRI and new rules arrive by transaction.
The engine evaluates a rule once per graph version for *every* context at once: it binds the context
variables from one ``VALUES`` block per dimension, whose join is every context, and projects which context
each result belongs to (``contextualise``).
"""
from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import pyoxigraph as ox
import rdflib
from rdflib.namespace import RDF, RDFS
from rdflib.term import Literal, URIRef

from ..config import Settings
from ..errors import BadInput, ParseError
from ..kg.backends import EmbeddedBackend
from ..kg.changes import read_rdf_file
from ..kg.identity import rule_iri
from ..kg.namespaces import NFEX
from ..kg.sparql_gate import gate_query
from ..kg.terms import n3

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

_HEADER = re.compile(r"^#\s*(label|comment):\s*(.*)$", re.IGNORECASE)
_SELECT = re.compile(r"\bSELECT\s+(DISTINCT\s+|REDUCED\s+)?", re.IGNORECASE)
_WHERE = re.compile(r"\bWHERE\s*\{", re.IGNORECASE)


@dataclass(frozen=True)
class SparqlRule:
    iri: URIRef
    label: str
    query: str
    comment: str = ""
    source: str | None = None


def parse_rule_file(path: Path, root: Path) -> SparqlRule:
    """A rule file: ``# label:`` and ``# comment:`` header lines (a comment may continue on ``#   `` lines)."""
    text = path.read_text()
    label, comment, in_comment = "", [], False
    for line in text.splitlines():
        m = _HEADER.match(line)
        if m:
            in_comment = m.group(1).lower() == "comment"
            if in_comment:
                comment.append(m.group(2).strip())
            else:
                label = m.group(2).strip()
        elif in_comment and line.startswith("#   "):
            comment.append(line[1:].strip())
        else:
            in_comment = False
    if not label:
        raise ParseError(f"{path}: a pruning rule needs a '# label: …' header line")
    return SparqlRule(rule_iri(path.stem), label, text, " ".join(comment), str(path.relative_to(root)))


def rule_triples(rule: SparqlRule) -> rdflib.Graph:
    g = rdflib.Graph()
    g.add((rule.iri, RDF.type, NFEX.SparqlRule))
    g.add((rule.iri, RDFS.label, Literal(rule.label)))
    if rule.comment:
        g.add((rule.iri, RDFS.comment, Literal(rule.comment)))
    if rule.source:
        g.add((rule.iri, NFEX.sourceFile, Literal(rule.source)))
    g.add((rule.iri, NFEX.query, Literal(rule.query)))
    g.add((rule.iri, NFEX.enabled, Literal(True)))
    return g


def rules_graph(settings: Settings) -> rdflib.Graph:
    """rules/pruning/*.rq as nfex:SparqlRule individuals, and the thresholds they read."""
    folder = settings.rules_dir / "pruning"
    g = rdflib.Graph()
    for path in sorted(folder.glob("*.rq")):
        g += rule_triples(parse_rule_file(path, settings.home))
    for path in sorted(folder.glob("*.ttl")):
        g += read_rdf_file(path)
    return g


def load_rules(kg: KnowledgeGraph) -> list[SparqlRule]:
    rows = kg.select(
        """SELECT ?r ?label ?query ?comment ?source WHERE {
            ?r a nfex:SparqlRule ; rdfs:label ?label ; nfex:query ?query .
            OPTIONAL { ?r rdfs:comment ?comment } OPTIONAL { ?r nfex:sourceFile ?source }
            FILTER NOT EXISTS { ?r nfex:enabled false }
        } ORDER BY ?r"""
    ).rows
    return [
        SparqlRule(r["r"], str(r["label"]), str(r["query"]), str(r.get("comment", "")), str(r["source"]) if "source" in r else None)  # type: ignore[arg-type]
        for r in rows
    ]


CONTEXT_INDEX = "ctx_"
"""Prefix of the variables ``contextualise`` projects (``?ctx_agent`` …); a rule must not use them (``check_rule``)."""
_CONTEXT_VARIABLE = re.compile(r"[?$]" + CONTEXT_INDEX)


def contextualise(query: str, dimensions: Sequence[str], values: Sequence[Sequence[URIRef | None]]) -> str:
    """The rule evaluated for many contexts at once: every combination of the dimensions' ``values`` (None:
    unknown), the last dimension varying fastest, as ``itertools.product`` lists them (rules/setup.py's keys).

    One ``VALUES`` block per dimension opens the outermost WHERE group, so their join — the contexts — joins
    with the whole pattern; each row also binds ``?ctx_<dimension>`` to the value's place times the number of
    contexts one step of it spans, and the projection gains those variables, so a result's context index is
    their sum (``evaluate``). Six short blocks rather than one row per context: the query text (and its parse,
    most of a cheap rule's time) no longer grows with the product, 1,296 contexts on the shipped graph.
    """
    select = _SELECT.search(query)
    where = _WHERE.search(query, select.end() if select else 0)
    if select is None or where is None:
        raise BadInput("a pruning rule must be a SELECT … WHERE { … } query")
    if len(values) != len(dimensions):
        raise ValueError(f"{len(dimensions)} dimensions but {len(values)} lists of values")
    stride, blocks = 1, []
    for d, vs in reversed(list(zip(dimensions, values, strict=True))):
        rows = " ".join(f"({n3(v) if v is not None else 'UNDEF'} {i * stride})" for i, v in enumerate(vs))
        blocks.append(f"  VALUES (?{d} ?{CONTEXT_INDEX}{d}) {{ {rows} }}\n")
        stride *= len(vs)
    out = query[: where.end()] + "\n" + "".join(reversed(blocks)) + query[where.end() :]
    index = " ".join(f"?{CONTEXT_INDEX}{d}" for d in dimensions)
    return out[: select.end()] + index + " " + out[select.end() :]


def check_rule(query: str, dimensions: Sequence[str]) -> None:
    """Refuse a rule that does not parse, calls SERVICE, uses the engine's ``?ctx_…`` variables (``contextualise``), or
    does not return ?extractor and ?reason (before it is stored)."""
    gate_query(query)
    if _CONTEXT_VARIABLE.search(query):
        raise BadInput(f"a pruning rule must not use variables named ?{CONTEXT_INDEX}…: the engine binds them to say which context a row is for")
    try:
        probe = ox.Store().query(contextualise(query, dimensions, [[None]] * len(dimensions)))
    except SyntaxError as e:
        raise ParseError(f"the rule is not valid SPARQL: {e}") from e
    if not isinstance(probe, ox.QuerySolutions):
        raise BadInput("a pruning rule must be a SELECT query")
    names = {v.value for v in probe.variables}
    missing = {"extractor", "reason"} - names
    if missing:
        raise BadInput(f"a pruning rule must select ?extractor and ?reason; missing: {', '.join(sorted('?' + m for m in missing))}")


def evaluate(backend: EmbeddedBackend, rule: SparqlRule, query: str) -> dict[int, list[tuple[URIRef, str]]]:
    """For each context index, the extractors ``rule`` prunes with their reasons: ``query`` is the rule
    contextualised for the contexts (``contextualise``), evaluated on ``backend`` (the rule engine's evidence
    view, evidence/view.py, an in-memory store). A rule prunes in many contexts at once (hundreds of rows, each
    its context's index, extractor and reason), so the rows are read as Oxigraph gives them, not as rdflib
    terms; an ``?extractor`` that is not an IRI is passed over."""
    gate_query(rule.query)  # a rule written before the gate judged stored text (kept per text: no parse per compile)
    res = backend.solutions(query)
    index = [v.value for v in res.variables if v.value.startswith(CONTEXT_INDEX)]
    extractors: dict[str, URIRef] = {}
    out: dict[int, list[tuple[URIRef, str]]] = {}
    for sol in res:
        x = sol["extractor"]
        if not isinstance(x, ox.NamedNode):
            continue
        iri = extractors.get(x.value)
        if iri is None:
            iri = extractors[x.value] = URIRef(x.value)
        reason = sol["reason"]
        i = sum(int(sol[v].value) for v in index)  # VALUES binds every index variable
        out.setdefault(i, []).append((iri, reason.value if reason is not None else rule.label))
    return out
