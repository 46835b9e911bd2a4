"""The knowledge as OWL alone: the graph without its SHACL shapes, for OWL tools (Protégé, reasoners).

The store keeps the ontology, the shapes that guard writes and the context shapes side by side in one
graph. An OWL tool reads a SHACL shape as an individual with odd annotations — and its property shapes,
``sh:in`` lists and SPARQL constraints as a tangle of anonymous ones. ``owl_only`` leaves out every node
that is a shape or a SHACL constraint, everything reachable from one only through skolemised nodes (its
property shapes and lists; an OWL class that is also a node shape stays), and every triple that uses a
term of the SHACL namespace. The modules' own ontology headers collapse into the core one
(``https://w3id.org/nfex``): the export holds all modules, so their ``owl:imports`` of each other are inside it.
"""
from __future__ import annotations

import rdflib
from rdflib.namespace import OWL, RDF, SH
from rdflib.term import Node, URIRef

from .namespaces import PREFIXES
from .terms import is_skolem

CORE = URIRef("https://w3id.org/nfex")
_MODULES = "https://w3id.org/nfex/"


def _shacl(term: Node) -> bool:
    return isinstance(term, URIRef) and str(term).startswith(str(SH))


def owl_only(graph: rdflib.Graph) -> rdflib.Graph:
    """``graph`` less its SHACL shapes and constraints (see the module docstring)."""
    # an OWL entity that also carries SHACL (a class that is its own node shape) stays, less its sh: triples;
    # an ontology node carrying only sh:declare prefixes for SPARQL constraints goes
    entities = {s for s, o in graph.subject_objects(RDF.type) if str(o).startswith(str(OWL)) and o != OWL.Ontology}
    dropped = {s for s, p, o in graph if _shacl(p) or (p == RDF.type and _shacl(o))} - entities
    frontier = list(dropped)
    while frontier:  # property shapes, sh:in / sh:or lists: skolemised nodes only a shape reaches
        node = frontier.pop()
        for o in graph.objects(node, None):
            if is_skolem(o) and o not in dropped:
                dropped.add(o)
                frontier.append(o)
    out = rdflib.Graph()
    for prefix, ns in PREFIXES.items():
        if prefix != "sh":
            out.bind(prefix, ns)
    for s, p, o in graph:
        if s in dropped or o in dropped or _shacl(s) or _shacl(p) or _shacl(o):
            continue
        if p == OWL.imports and str(o).startswith(str(CORE)):
            continue
        if isinstance(s, URIRef) and str(s).startswith(_MODULES) and (s, RDF.type, OWL.Ontology) in graph:
            continue  # a module's header: the core ontology's stands for the export
        out.add((s, p, o))
    return out
