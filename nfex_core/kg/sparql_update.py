"""The change set of a SPARQL 1.1 Update, computed without touching the store.

An update (INSERT DATA, DELETE/INSERT … WHERE, …) is run on an in-memory Oxigraph copy of the default
graph; the difference between the copy before and after is the change set, which then goes through
the same validated, versioned commit as any other write. Copying costs O(graph) — fine for editors'
updates, which are rare; the hot paths (selection, feedback) build change sets directly.

Operations that fetch URLs or touch named graphs (LOAD, CLEAR, DROP, CREATE, ADD, MOVE, COPY, SERVICE)
are refused before the copy is made (``sparql_guard``): evaluating them even on the copy would fetch.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import pyoxigraph as ox

from ..errors import BadInput, ParseError
from .changes import ChangeSet
from .sparql_guard import refuse_unsafe_update
from .terms import from_oxigraph

if TYPE_CHECKING:
    from .backends import Backend


def change_of_update(backend: Backend, update: str) -> ChangeSet:
    """What ``update`` would add to and remove from the default graph (nothing is written here)."""
    if not update.strip():
        raise BadInput("the update is empty")
    refuse_unsafe_update(update)
    scratch = ox.Store()
    data = backend.construct("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }")
    scratch.load(data.serialize(format="nt").encode("utf-8"), format=ox.RdfFormat.N_TRIPLES)
    before = {(q.subject, q.predicate, q.object) for q in scratch}
    try:
        scratch.update(update)
    except SyntaxError as e:
        raise ParseError(f"invalid SPARQL update: {e}") from e
    except (OSError, ValueError, TypeError, RuntimeError) as e:  # evaluation errors of a well-formed update
        raise BadInput(f"the update cannot be applied: {e}") from e
    after_quads = list(scratch)
    if any(not isinstance(q.graph_name, ox.DefaultGraph) for q in after_quads):
        raise BadInput("updates may only change the default graph; named graphs hold nFEX's version history")
    after = {(q.subject, q.predicate, q.object) for q in after_quads}
    if any(isinstance(x, ox.BlankNode) for t in after - before for x in (t[0], t[2])):
        raise BadInput("the update creates blank nodes; give new nodes IRIs so later writes can address them")

    def conv(ts: set[tuple[object, object, object]]) -> frozenset:
        return frozenset((from_oxigraph(s), from_oxigraph(p), from_oxigraph(o)) for s, p, o in ts)

    return ChangeSet(added=conv(after - before), removed=conv(before - after))
