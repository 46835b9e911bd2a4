"""The change set of a SPARQL 1.1 Update, computed without touching the store.

The change set is defined as what the update does to the default graph F: (F after) − F is added,
F − (F after) removed. ``change_by_copy`` computes exactly that — it runs the update on an in-memory
Oxigraph copy of F and diffs — and is kept as the reference; it costs O(graph), seconds on the shipped
graph. ``change_of_update`` gives the same change set at the cost of the change: it copies only the
triples the update can read or delete (``update_reach``: the triples matching its WHERE patterns, DELETE
templates and DELETE DATA), runs the update on that slice, and asks the store which of the inserted
triples it already holds. An update of INSERT DATA alone copies nothing. Where the slice cannot be bounded
(``?s ?p ?o``, a negated property set, a zero-length path between variables, text rdflib cannot parse)
the whole graph is copied, as before. ``tests/nfex_core/kg/storage/test_sparql_update.py`` compares the two on
random updates over random graphs.

Either way the change then goes through the same validated, versioned commit as any other write.
Operations that fetch URLs or touch named graphs (LOAD, CLEAR, DROP, CREATE, ADD, MOVE, COPY, SERVICE)
are refused before anything is copied (``sparql_gate``): evaluating them even on a copy would fetch.
The copy holds no named graphs, so an update writing to one is refused, and one reading one reads nothing.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import pyoxigraph as ox
import rdflib

from ...errors import BadInput, ParseError
from ..rdf.terms import from_oxigraph
from .changes import ChangeSet
from .sparql_gate import gate_update
from .update_reach import EVERYTHING, reach

if TYPE_CHECKING:
    from .backends import Backend

OxTriple = tuple[object, object, object]


def change_of_update(backend: Backend, update: str) -> ChangeSet:
    """What ``update`` would add to and remove from the default graph (nothing is written here)."""
    _check(update)
    scope = reach(update)
    if scope is None:  # rdflib cannot bound it: Oxigraph's own parse says whether it is SPARQL at all
        _run(ox.Store(), update)
        scope = EVERYTHING
    copied = scope.fetch(backend)
    if not scope.everything and any(isinstance(x, rdflib.BNode) for t in copied for x in (t[0], t[2])):
        # blank nodes (written by another tool: nFEX skolemises) cannot be looked up in the store afterwards
        return change_by_copy(backend, update)
    return _diff(_scratch(copied), update, None if scope.everything else backend)


def change_by_copy(backend: Backend, update: str) -> ChangeSet:
    """The reference: the update run on a copy of the whole default graph (O(graph))."""
    _check(update)
    return _diff(_scratch(EVERYTHING.fetch(backend)), update, None)


def _check(update: str) -> None:
    gate_update(update)


def _scratch(triples: rdflib.Graph) -> ox.Store:
    scratch = ox.Store()
    if len(triples):
        scratch.load(triples.serialize(format="nt").encode("utf-8"), format=ox.RdfFormat.N_TRIPLES)
    return scratch


def _run(scratch: ox.Store, update: str) -> None:
    try:
        scratch.update(update)
    except SyntaxError as e:
        raise ParseError(f"invalid SPARQL update: {e}") from e
    except (OSError, ValueError, TypeError, RuntimeError) as e:  # evaluation errors of a well-formed update
        raise BadInput(f"the update cannot be applied: {e}") from e


def _diff(scratch: ox.Store, update: str, store: Backend | None) -> ChangeSet:
    """Run ``update`` on ``scratch`` and diff; ``store``: the scratch holds a slice of it, so inserted
    triples it already holds are no change."""
    before: set[OxTriple] = {(q.subject, q.predicate, q.object) for q in scratch}
    _run(scratch, update)
    after_quads = list(scratch)
    if any(not isinstance(q.graph_name, ox.DefaultGraph) for q in after_quads):
        raise BadInput("updates may only change the default graph; named graphs hold nFEX's version history")
    after: set[OxTriple] = {(q.subject, q.predicate, q.object) for q in after_quads}
    if any(isinstance(x, ox.BlankNode) for t in after - before for x in (t[0], t[2])):
        raise BadInput("the update creates blank nodes; give new nodes IRIs so later writes can address them")

    def conv(ts: set[OxTriple]) -> frozenset:
        return frozenset((from_oxigraph(s), from_oxigraph(p), from_oxigraph(o)) for s, p, o in ts)

    added = conv(after - before)
    if store is not None and added:
        added -= store.present(added)
    return ChangeSet(added=added, removed=conv(before - after))
