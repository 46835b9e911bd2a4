"""The version history inside the store: where each version's change set and metadata live, how a
version is written (one guarded operation) and how the history is read back.

- ``<urn:nfex:meta>`` holds the head pointer ``<urn:nfex:head> nfex:versionNumber N`` and one
  ``nfex:GraphVersion`` node per commit (author, time, message, counts, commit id);
- ``<urn:nfex:version:N:added>`` / ``…:removed`` hold each version's change set;
- ``<urn:nfex:staging:ID:added|removed>`` hold a large commit's triples until it is applied;
- ``<urn:nfex:bulk-write>`` in the meta graph marks version 1 of an empty embedded store being written in bulk
  (``bulk_write_first``) until the head moves.

``KnowledgeGraph`` (store.py) decides *whether* to write (validation, claims, retries); this module is
*what* is written and read.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from rdflib.namespace import DCTERMS, PROV, RDF, XSD
from rdflib.term import Literal, URIRef

from .backends import Backend, EmbeddedBackend
from .changes import ChangeSet
from .claims import META, settle_update
from .namespaces import NFEX, PREFIXES
from .terms import Triple, n3, nt, py, triple_n3


def prefix_block() -> str:
    """PREFIX lines for every namespace nFEX declares."""
    return "".join(f"PREFIX {p}: <{ns}>\n" for p, ns in PREFIXES.items())


HEAD = URIRef("urn:nfex:head")


def version_iri(n: int) -> URIRef:
    return URIRef(f"urn:nfex:version:{n}")


def added_graph(n: int) -> URIRef:
    return URIRef(f"urn:nfex:version:{n}:added")


def removed_graph(n: int) -> URIRef:
    return URIRef(f"urn:nfex:version:{n}:removed")


STAGE_CHUNK = 1000  # triples per staging request (Virtuoso 7's parser gives up near 5,000)


def staging_graph(commit_id: str, kind: str) -> URIRef:
    """Where a commit's ``added`` or ``removed`` triples wait until it is applied (``write_version``)."""
    return URIRef(f"urn:nfex:staging:{commit_id}:{kind}")


@dataclass(frozen=True)
class Version:
    number: int
    author: str
    time: datetime | None
    message: str
    added: int
    removed: int

    def as_dict(self) -> dict[str, Any]:
        return {
            "version": self.number,
            "author": self.author,
            "time": self.time.isoformat() if self.time else None,
            "message": self.message,
            "added": self.added,
            "removed": self.removed,
        }


@dataclass(frozen=True)
class ChangeText:
    """A change set as the statements a version writes, one triple each (``triple_n3``, or N-Triples
    lines): what ``write_version`` sends. Content validated and serialised elsewhere (the shipped seed,
    ``nfex_core.knowledge.seed_content``) is written from its text without becoming rdflib terms first."""

    added: Sequence[str]
    removed: Sequence[str] = ()
    ntriples: bool = False  # every line is an N-Triples statement (``triple_nt``): it can be bulk-loaded

    @classmethod
    def of(cls, change: ChangeSet | ChangeText) -> ChangeText:
        if isinstance(change, ChangeText):
            return change
        return cls([triple_n3(t) for t in change.added], [triple_n3(t) for t in change.removed])

    def __len__(self) -> int:
        return len(self.added) + len(self.removed)


def write_version(backend: Backend, change: ChangeSet | ChangeText, head: int, new: int, author: str, message: str, commit_id: str) -> None:
    """Write ``change`` as version ``new`` if ``head`` is still the head: one operation, one transaction.

    A change the backend takes in one request (``max_inline_triples``; any size in the embedded store)
    is written inline. SPARQL servers take an update of any size only in principle: Virtuoso 7 refuses an
    INSERT DATA of ~5,000 triples (its parser runs out of memory) and a DELETE/INSERT template of ~1,000
    (its SQL compiler stops at 10,000 lines), and it keeps the earlier operations of a request whose later
    one fails. So a larger change is staged first, STAGE_CHUNK triples a request, in graphs of this commit
    that no query of the knowledge reads, and one operation of fixed size moves it in. A writer killed
    while staging leaves its staging graphs behind, unread.
    """
    text = ChangeText.of(change)
    limit = backend.max_inline_triples
    staged = limit is not None and len(text) > limit
    if staged:
        for kind, items in (("added", text.added), ("removed", text.removed)):
            for i in range(0, len(items), STAGE_CHUNK):
                body = "\n".join(items[i : i + STAGE_CHUNK])
                backend.update(f"INSERT DATA {{ GRAPH {n3(staging_graph(commit_id, kind))} {{\n{body}\n}} }}")
    backend.update(commit_update(backend, text, head, new, author, message, commit_id, staged=staged))

def commit_update(
    backend: Backend, change: ChangeSet | ChangeText, head: int, new: int, author: str, message: str, commit_id: str, *, staged: bool = False
) -> str:
    """The update writing version ``new``: one DELETE/INSERT … WHERE operation (one transaction on any
    server) writes the change, its change-set graphs, the version node and the new head, guarded by the
    head still being ``head``; further operations drop the claims on versions up to ``new`` (and the
    staging graphs). ``staged``: the triples are read from the staging graphs rather than written out.
    """
    text = ChangeText.of(change)
    meta = [*version_node(text, new, author, message, commit_id), (HEAD, NFEX.versionNumber, Literal(new))]
    guard = f"GRAPH {n3(META)} {{ {n3(HEAD)} nfex:versionNumber {head} }}"
    meta_block = "\n".join(triple_n3(t) for t in meta)
    tail = [settle_update(new)]  # claims for this and earlier versions are settled now
    if staged:
        staged_added, staged_removed = staging_graph(commit_id, "added"), staging_graph(commit_id, "removed")
        removed, added = "?rs ?rp ?ro .", "?as ?ap ?ao ."
        # each row binds an added triple, a removed one or neither (the last branch: the version is written
        # however the change is made up); a template triple with an unbound variable is skipped (§3.1.3)
        where = (f"{guard}\n{{ GRAPH {n3(staged_added)} {{ ?as ?ap ?ao }} }} UNION "
                 f"{{ GRAPH {n3(staged_removed)} {{ ?rs ?rp ?ro }} }} UNION {{ BIND (1 AS ?one) }}")
        tail = [f"DELETE WHERE {{ GRAPH {n3(g)} {{ ?s ?p ?o }} }}" for g in (staged_added, staged_removed)] + tail
    else:
        removed = "\n".join(text.removed)
        added = "\n".join(text.added)
        where = guard
    change_sets = [f"GRAPH {n3(graph)} {{\n{body}\n}}" for graph, body in ((added_graph(new), added), (removed_graph(new), removed))
                   if body.strip()]
    if backend.exclusive and not staged:
        # one process owns the store and read the head under its write_lock: the guard holds by construction,
        # and DATA operations skip instantiating a template per solution (a seed's 68k: 1.7 s → about 1 s)
        return "\n".join([
            f"{prefix_block()}DELETE DATA {{", backend.graph_block(removed), f"GRAPH {n3(META)} {{ {n3(HEAD)} nfex:versionNumber {head} }}",
            "} ;\nINSERT DATA {", backend.graph_block(added), *change_sets, f"GRAPH {n3(META)} {{\n{meta_block}\n}}", "}",
        ] + [f";\n{op}" for op in tail])
    return "\n".join([
        f"{prefix_block()}DELETE {{", backend.graph_block(removed), guard,
        "} INSERT {", backend.graph_block(added), *change_sets, f"GRAPH {n3(META)} {{\n{meta_block}\n}}",
        f"}} WHERE {{\n{where}\n}}",
    ] + [f";\n{op}" for op in tail])


def version_node(text: ChangeText, new: int, author: str, message: str, commit_id: str) -> list[Triple]:
    """The ``nfex:GraphVersion`` node of version ``new`` (in the meta graph)."""
    now = Literal(datetime.now(UTC).isoformat(timespec="milliseconds"), datatype=XSD.dateTime)
    v = version_iri(new)
    return [
        (v, RDF.type, NFEX.GraphVersion),
        (v, NFEX.versionNumber, Literal(new)),
        (v, NFEX.author, Literal(author)),
        (v, PROV.generatedAtTime, now),
        (v, DCTERMS.description, Literal(message)),
        (v, NFEX.addedCount, Literal(len(text.added))),
        (v, NFEX.removedCount, Literal(len(text.removed))),
        (v, NFEX.commitId, Literal(commit_id)),
    ]


BULK_WRITE = URIRef("urn:nfex:bulk-write")


def bulk_write_first(backend: EmbeddedBackend, text: ChangeText, author: str, message: str, commit_id: str) -> None:
    """Version 1 of an empty embedded store, written by Oxigraph's bulk loader: for the shipped seed's 67,680
    quads (the knowledge and its change-set graph) 0.32–0.35 s, against 0.71–0.90 s for the one-transaction
    update ``write_version`` sends (probes). The caller holds ``write_lock`` and has checked that the store is at
    version 0 with an empty knowledge graph; ``text`` is additions in N-Triples lines.

    The bulk loader is not atomic, so the write is bracketed: the marker ``BULK_WRITE`` goes in first (one
    transaction); then the knowledge, its change-set graph and the version node, in bulk; then one transaction
    moves the head to 1 and takes the marker out. Until it does, the store reads as version 0. An open that
    finds the marker (``clear_bulk_write``) takes out what the interrupted write left: that is all the knowledge
    graph can hold, since the marker is written only into an empty one, by the process that holds the store."""
    if text.removed or not text.ntriples:
        raise ValueError("bulk_write_first writes additions in N-Triples lines only")
    marker = f"{n3(BULK_WRITE)} nfex:commitId {n3(Literal(commit_id))}"
    backend.update(f"{prefix_block()}INSERT DATA {{ GRAPH {n3(META)} {{ {marker} }} }}")
    knowledge = f" <{backend.graph}> .\n" if backend.graph else " .\n"
    added = f" {n3(added_graph(1))} .\n"
    body = [line.rstrip().removesuffix(".").rstrip() for line in text.added]
    node = [f"{nt(s)} {nt(p)} {nt(o)}" for s, p, o in version_node(text, 1, author, message, commit_id)]  # one line each
    data = "".join([*(b + knowledge for b in body), *(b + added for b in body), *(n + f" {n3(META)} .\n" for n in node)])
    backend.bulk_load(data.encode("utf-8"))
    backend.update(f"{prefix_block()}DELETE DATA {{ GRAPH {n3(META)} {{ {n3(HEAD)} nfex:versionNumber 0 . {marker} }} }} ;\n"
                   f"INSERT DATA {{ GRAPH {n3(META)} {{ {n3(HEAD)} nfex:versionNumber 1 }} }} ;\n{settle_update(1)}")


def clear_bulk_write(backend: Backend) -> bool:
    """Where a bulk write of version 1 was interrupted (``bulk_write_first``: the marker is there and the head is
    still 0), take out what it wrote — the knowledge graph's triples, the change-set graph, the version node —
    and the marker; True if it did."""
    if not backend.ask(f"ASK {{ GRAPH {n3(META)} {{ {n3(BULK_WRITE)} ?p ?o }} }}") or backend.ask(
            f"ASK {{ GRAPH {n3(META)} {{ {n3(HEAD)} {n3(NFEX.versionNumber)} ?v FILTER (?v > 0) }} }}"):
        return False
    backend.update(";\n".join([
        f"DELETE WHERE {{ {backend.graph_block('?s ?p ?o')} }}",
        f"DROP SILENT GRAPH {n3(added_graph(1))}",
        f"DELETE WHERE {{ GRAPH {n3(META)} {{ {n3(version_iri(1))} ?p ?o }} }}",
        f"DELETE WHERE {{ GRAPH {n3(META)} {{ {n3(BULK_WRITE)} ?p ?o }} }}",
    ]))
    return True


def read_versions(backend: Backend, limit: int | None = None) -> list[Version]:
    """Every committed version, newest first (at most ``limit``)."""
    q = (
        f"SELECT ?n ?author ?time ?msg ?a ?r WHERE {{ GRAPH {n3(META)} {{ ?v a nfex:GraphVersion ; "
        "nfex:versionNumber ?n ; nfex:author ?author ; prov:generatedAtTime ?time ; "
        "dcterms:description ?msg ; nfex:addedCount ?a ; nfex:removedCount ?r } } ORDER BY DESC(?n)"
    )
    if limit:
        q += f" LIMIT {int(limit)}"
    rows = backend.select(prefix_block() + q).rows
    return [
        Version(
            number=int(py(r["n"])),
            author=str(r["author"]),
            time=t if isinstance(t := py(r["time"]), datetime) else None,
            message=str(r["msg"]),
            added=int(py(r["a"])),
            removed=int(py(r["r"])),
        )
        for r in rows
    ]


def read_changes(backend: Backend, number: int) -> ChangeSet:
    """The change set that version ``number`` committed (read as sets of triples: no rdflib Graph is built)."""
    added = backend.triples(f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ GRAPH {n3(added_graph(number))} {{ ?s ?p ?o }} }}")
    removed = backend.triples(f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ GRAPH {n3(removed_graph(number))} {{ ?s ?p ?o }} }}")
    return ChangeSet(added=frozenset(added), removed=frozenset(removed))
