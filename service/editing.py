"""Helpers for the REST editing routes: a resource's description, request bodies as RDF, replacement."""
from __future__ import annotations

import re

import rdflib
from fastapi import Request
from rdflib.term import Node, URIRef

from nfex_core.errors import BadInput
from nfex_core.kg import ChangeSet, KnowledgeGraph, parse_rdf
from nfex_core.kg.terms import Triple, is_skolem, n3

from .bodies import media_type
from .images import UnsupportedMediaType

RDF_BODY = {"text/turtle": "turtle", "application/n-triples": "nt", "application/ld+json": "json-ld", "application/rdf+xml": "xml"}
NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_.-]{0,99}$")


def check_name(kind: str, name: str) -> str:
    if not NAME.match(name):
        raise BadInput(f"{kind} name {name!r} must start with a letter and use letters, digits, '_', '-', '.' (≤100)")
    return name


def describe(kg: KnowledgeGraph, roots: set[URIRef]) -> set[Triple]:
    """Outgoing triples of ``roots`` and of the anonymous (skolem) nodes they reach."""
    out: set[Triple] = set()
    seen: set[Node] = set()
    frontier: set[Node] = set(roots)
    while frontier:
        seen |= frontier
        values = " ".join(n3(n) for n in frontier if isinstance(n, URIRef))
        g = kg.backend.construct(f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?s {{ {values} }} ?s ?p ?o }}")
        triples = set(g)
        out |= triples
        frontier = {t[2] for t in triples if is_skolem(t[2]) and t[2] not in seen}
    return out


def subjects_of(kg: KnowledgeGraph, predicate: URIRef, obj: URIRef) -> set[URIRef]:
    rows = kg.backend.select(f"SELECT ?s WHERE {{ ?s {n3(predicate)} {n3(obj)} }}").rows
    return {r["s"] for r in rows if isinstance(r["s"], URIRef)}


def replace(kg: KnowledgeGraph, old: set[Triple], new: frozenset[Triple] | set[Triple]) -> ChangeSet:
    return ChangeSet.of(added=frozenset(new) - frozenset(old), removed=frozenset(old) - frozenset(new))


async def rdf_body(request: Request) -> rdflib.Graph:
    media = media_type(request.headers.get("content-type"))
    fmt = RDF_BODY.get(media)
    if fmt is None:
        raise UnsupportedMediaType(f"send RDF as one of {', '.join(RDF_BODY)}, not {media or 'nothing'!r}")
    return parse_rdf(await request.body(), format=fmt, source="the request body")


def turtle(triples: set[Triple]) -> str:
    g = rdflib.Graph()
    from nfex_core.kg.namespaces import PREFIXES

    for p, ns in PREFIXES.items():
        g.bind(p, ns)
    for t in triples:
        g.add(t)
    return g.serialize(format="turtle")
