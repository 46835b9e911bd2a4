"""The knowledge graph: versioned, SHACL-guarded writes over an embedded or remote SPARQL store.

Layout inside the store (the same for Oxigraph in a folder and for any SPARQL 1.1 server): the
**default graph** holds the knowledge itself (ontology, shapes, rules, programs, measurements); the
version history lives in named graphs beside it (history.py: the head, one node per version, each
version's change set).

A commit is one SPARQL Update whose WHERE clause requires the head to still be the version the change
was validated against (compare-and-swap). The update either applies entirely — data, change set,
version node and new head — or, when another writer committed first, not at all; the store's own
transaction makes it atomic, so a process killed mid-write leaves the last committed version.
"""
from __future__ import annotations

import logging
import random
import threading
import time
import uuid
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, TypeVar

import rdflib
from rdflib.term import Literal

from ..config import Settings
from ..errors import BadInput, Conflict, NotFound, PreconditionFailed, StoreUnavailable, ValidationFailed
from .backends import Backend, EmbeddedBackend, SelectResult, open_backend
from .changes import ChangeSet, graph_triples
from .claims import META as CLAIMS_META
from .claims import Rival, ttl_for
from .claims import release as release_claim
from .claims import rivals as rival_claims
from .claims import take as take_claim
from .derived import Derived
from .footprint import Footprint
from .history import (
    HEAD,
    ChangeText,
    Version,
    bulk_write_first,
    clear_bulk_write,
    prefix_block,
    read_changes,
    read_versions,
    version_iri,
    write_version,
)
from .namespaces import NFEX, PREFIXES
from .shacl_process import ShaclProcess
from .sparql_gate import gate_change, gate_update
from .sparql_update import change_of_update
from .terms import Triple, n3, py
from .validation import (
    Neighbourhood,
    Report,
    core_violations,
)

log = logging.getLogger("nfex.kg")
META = CLAIMS_META
CLAIM_WAIT_S = 30.0  # the longest a writer waits on other writers' live claims (claims.py)
T = TypeVar("T")


@dataclass(frozen=True)
class CommitResult:
    """The outcome of a write: the version now at head, and whether this write created it."""

    version: int
    changed: bool
    added: int = 0
    removed: int = 0
    report: Report | None = None


class KnowledgeGraph(Derived):
    """The one way nFEX reads and writes its knowledge graph."""

    def __init__(self, backend: Backend, settings: Settings | None = None) -> None:
        self.backend = backend
        self.settings = settings or Settings.from_env()
        self._cache: dict[str, tuple[int, Any]] = {}
        self._cache_lock = threading.Lock()
        self._vocabulary_footprint: Footprint | None = None  # what loading the vocabulary read (_carry_vocabulary)
        self._neighbourhood = Neighbourhood()  # what validations read around nodes, kept across commits (validation.py)
        self._listeners: list[Callable[[int], None]] = []
        self.shacl: ShaclProcess | None = None  # where writes run pySHACL: None, in this process (use_shacl_process)
        self._ensure_head()
        if self.backend.exclusive and clear_bulk_write(self.backend):
            log.warning("%s: a bulk write of version 1 was interrupted; what it wrote is taken out, the store is empty",
                        self.location)

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, location: str | None = None, *, settings: Settings | None = None) -> KnowledgeGraph:
        """Open ``location`` (default: the settings' store) as it is; ``nfex_core.knowledge.open_graph``
        also seeds an empty store."""
        settings = settings or Settings.from_env()
        return cls(open_backend(location or settings.store, settings), settings)

    def close(self) -> None:
        if self.shacl is not None:
            self.shacl.close()
        self.backend.close()

    def use_shacl_process(self) -> ShaclProcess:
        """Run the pySHACL part of each write's validation in a worker process (shacl_process.py): for a long-running
        process whose other threads (a service's selections, its background compile) want the interpreter lock too."""
        if self.shacl is None:
            self.shacl = ShaclProcess()
        return self.shacl

    def __enter__(self) -> KnowledgeGraph:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _ensure_head(self) -> None:
        self.backend.update(
            f"INSERT {{ GRAPH {n3(META)} {{ {n3(HEAD)} {n3(NFEX.versionNumber)} 0 }} }} "
            f"WHERE {{ FILTER NOT EXISTS {{ GRAPH {n3(META)} {{ {n3(HEAD)} {n3(NFEX.versionNumber)} ?v }} }} }}"
        )
        # the head lives in a named graph: seen in the default graph, the server shows the union of its graphs
        if self.backend.ask(f"ASK {{ {n3(HEAD)} {n3(NFEX.versionNumber)} ?v }}"):
            raise StoreUnavailable(
                f"the SPARQL server at {self.location} answers queries on its default graph from all its named "
                "graphs (GraphDB and Virtuoso do by default), where nFEX keeps its version history: the knowledge "
                "would be read with every past change set mixed in. Keep it in a named graph of its own: set "
                "NFEX_STORE_GRAPH, e.g. to https://w3id.org/nfex/graph/knowledge"
            )

    # ------------------------------------------------------------------ reading
    @property
    def location(self) -> str:
        return self.backend.location

    @property
    def version(self) -> int:
        res = self.backend.select(
            f"SELECT ?v WHERE {{ GRAPH {n3(META)} {{ {n3(HEAD)} {n3(NFEX.versionNumber)} ?v }} }}"
        )
        values = [int(py(r["v"])) for r in res.rows]
        return max(values) if values else 0

    def select(self, query: str, *, prefixes: bool = True) -> SelectResult:
        return self.backend.select((prefix_block() if prefixes else "") + query)

    def ask(self, query: str, *, prefixes: bool = True) -> bool:
        return self.backend.ask((prefix_block() if prefixes else "") + query)

    def construct(self, query: str, *, prefixes: bool = True) -> rdflib.Graph:
        return self.backend.construct((prefix_block() if prefixes else "") + query)

    def data_graph(self) -> rdflib.Graph:
        """The whole default graph (the knowledge, without version bookkeeping)."""
        g = self.backend.construct("CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }")
        for p, ns in PREFIXES.items():
            g.bind(p, ns)
        return g

    def export(self, format: str = "turtle") -> str:
        return self.data_graph().serialize(format=format)

    def triple_count(self) -> int:
        res = self.backend.select("SELECT (COUNT(*) AS ?n) WHERE { ?s ?p ?o }")
        return int(py(res.rows[0]["n"]))

    def on_commit(self, listener: Callable[[int], None]) -> None:
        """Call ``listener(new_version)`` after every commit made through this object."""
        self._listeners.append(listener)

    # ------------------------------------------------------------------ writing
    def _present(self, triples: Iterable[Triple]) -> set[Triple]:
        return self.backend.present(triples)

    def _effective(self, change: ChangeSet) -> ChangeSet:
        """Drop additions already present and removals of absent triples: versions record real changes."""
        present = self._present(change.added | change.removed)
        return ChangeSet(added=change.added - present, removed=change.removed & present)

    def commit(
        self,
        change: ChangeSet | Callable[[], ChangeSet],
        *,
        author: str,
        message: str = "",
        expected_version: int | None = None,
        retries: int = 5,
    ) -> CommitResult:
        """Apply ``change`` as one transaction: validate the touched nodes, then commit atomically.

        Raises ValidationFailed (nothing written) when SHACL rejects the candidate state,
        PreconditionFailed when ``expected_version`` is not the head, Conflict when other writers
        committed first ``retries + 1`` times, or when another writer's claim on the next version stood
        past ``CLAIM_WAIT_S``. When another writer commits first, the change is re-checked against the
        new head and retried (unless ``expected_version`` pins the head); while another writer holds a
        live claim (claims.py) this one waits for its commit or its expiry.

        ``change`` may be a function that computes the change from the store as it is (a SPARQL Update's
        ``DELETE … INSERT … WHERE``): it is called under the write lock, at the head it is committed on, and
        again whenever the head moves before the commit — so a change read from an older state is never
        replayed on a newer one, where it could be empty or wrong (a lost update).
        """
        compute = change if callable(change) else None
        if compute is None:
            assert isinstance(change, ChangeSet)
            self._refuse(change)
        with self.backend.write_lock:
            lost = 0
            waited = 0.0
            checked: tuple[int, ChangeSet, Report] | None = None
            while True:
                head = self.version
                if expected_version is not None and expected_version != head:
                    raise PreconditionFailed(
                        f"the graph is at version {head}, not {expected_version}; re-read and retry",
                        current_version=head,
                    )
                if checked is None or checked[0] != head:
                    if compute is not None:
                        change = compute()
                        self._refuse(change)
                        if self.version != head:  # a commit of another process landed while it was read
                            continue
                    assert isinstance(change, ChangeSet)
                    core = core_violations(self.backend, change)  # before the costlier steps: a change that
                    if core:  # would empty the graph (a rollback to 0) is refused in a few ASKs
                        raise ValidationFailed(core, "Conforms: False", current_version=head)
                    effective = self._effective(change)
                    if effective.empty:
                        return CommitResult(version=head, changed=False)
                    report = self._validate_shapes(effective, head)
                    if not report.conforms:
                        raise ValidationFailed(report.violations, report.text, current_version=head)
                    checked = (head, effective, report)
                _, effective, report = checked
                outcome = self._try_commit(effective, head, author, message)
                if outcome is None:
                    self._carry_shapes(effective, head)
                    self._neighbourhood.carry(effective, head)
                    self._carry_vocabulary(effective, head)
                    for listener in self._listeners:
                        listener(head + 1)
                    return CommitResult(
                        version=head + 1, changed=True, added=len(effective.added), removed=len(effective.removed), report=report
                    )
                if isinstance(outcome, Rival):
                    if waited + outcome.left_s > CLAIM_WAIT_S:
                        raise Conflict(
                            f"another writer claimed version {head + 1} and has not committed it ({outcome.iri}, "
                            f"{outcome.left_s:.1f} s left of its claim); the change was not applied, retry — "
                            "a claim whose writer died expires by itself",
                            current_version=self.version,
                        )
                    pause = min(outcome.left_s + 0.05, 0.25)
                    time.sleep(pause)
                    waited += pause
                    continue
                lost += 1
                if lost > retries:
                    raise Conflict(
                        f"other writers committed first {lost} times in a row (the head moved to version {self.version}); "
                        "the change was not applied, retry",
                        current_version=self.version,
                    )
                time.sleep(random.uniform(0.005, 0.05) * lost)

    @staticmethod
    def _refuse(change: ChangeSet) -> None:
        if any(isinstance(x, rdflib.BNode) for t in change.added | change.removed for x in t):
            raise BadInput("change sets must not contain blank nodes; build them with graph_triples()")
        gate_change(change.added)

    def load_validated(self, content: ChangeText, *, author: str, message: str = "") -> CommitResult:
        """Write ``content`` into an empty store as version 1, without validating it here.

        For content validated elsewhere: the shipped seed, which CI validates whole with pySHACL
        (``tests/nfex_core/kg/test_shipped_seed.py``). It skips what ``commit`` does to a change first — the
        core-shape ASKs, the lookup of which triples are new, SHACL — but writes the version as ``commit``
        does (the triples, the change-set graph, the version node, the head), so history, ``diff`` and
        ``rollback`` cannot tell the two apart: in one guarded operation, or, into an embedded store from N-Triples
        lines, with Oxigraph's bulk loader, bracketed so that an interrupted write is taken out when the store is
        next opened (history.py ``bulk_write_first``). Only an empty store qualifies (version
        0 and no triple in its knowledge graph); PreconditionFailed otherwise, Conflict when another
        writer wrote version 1 first.
        """
        if content.removed:
            raise BadInput("load_validated writes additions only, into an empty store")
        with self.backend.write_lock:
            head = self.version
            if head != 0 or self.backend.ask("ASK { ?s ?p ?o }"):
                raise PreconditionFailed(
                    f"load_validated writes into an empty store only; this one is at version {head}", current_version=head
                )
            if isinstance(self.backend, EmbeddedBackend) and content.ntriples:
                commit_id = uuid.uuid4().hex
                try:
                    bulk_write_first(self.backend, content, author, message, commit_id)
                except BaseException:
                    clear_bulk_write(self.backend)  # what the loader wrote before it stopped
                    raise
            elif self._try_commit(content, head, author, message) is not None:
                raise Conflict(f"another writer committed version {head + 1} first", current_version=self.version)
            for listener in self._listeners:
                listener(head + 1)
            return CommitResult(version=head + 1, changed=True, added=len(content.added))

    def _try_commit(self, change: ChangeSet | ChangeText, head: int, author: str, message: str) -> Rival | bool | None:
        """Write version head+1 if no other writer gets there first: None when committed, a Rival when
        another writer's live claim stands in the way, False when the head moved (claims.py)."""
        new = head + 1
        commit_id = uuid.uuid4().hex
        if self.backend.exclusive:  # one process owns the store; its writers take turns on write_lock
            self._write_version(change, head, new, author, message, commit_id)
            return None if self._committed(new, commit_id) else False
        ttl = ttl_for(len(change.added) + len(change.removed))
        started = time.monotonic()
        claim = take_claim(self.backend, new, ttl)
        rivals = rival_claims(self.backend, claim)
        moved = self.version != head
        if rivals or moved or time.monotonic() - started > ttl / 2:
            release_claim(self.backend, claim)
            if moved:
                return False
            return max(rivals, key=lambda r: r.left_s) if rivals else Rival(str(claim.iri), 0.0)
        self._write_version(change, head, new, author, message, commit_id)
        return None if self._committed(new, commit_id) else False

    def _committed(self, new: int, commit_id: str) -> bool:
        return self.ask(f"ASK {{ GRAPH {n3(META)} {{ {n3(version_iri(new))} nfex:commitId {n3(Literal(commit_id))} }} }}")

    def _write_version(self, change: ChangeSet | ChangeText, head: int, new: int, author: str, message: str, commit_id: str) -> None:
        write_version(self.backend, change, head, new, author, message, commit_id)

    def add(self, graph: rdflib.Graph, *, author: str, message: str = "", expected_version: int | None = None) -> CommitResult:
        return self.commit(ChangeSet.adding(graph_triples(graph)), author=author, message=message, expected_version=expected_version)

    def remove(self, graph: rdflib.Graph, *, author: str, message: str = "", expected_version: int | None = None) -> CommitResult:
        return self.commit(ChangeSet.removing(graph_triples(graph)), author=author, message=message, expected_version=expected_version)

    def update(self, sparql_update: str, *, author: str, message: str = "", expected_version: int | None = None) -> CommitResult:
        """Run a SPARQL 1.1 Update as a checked transaction.

        The update is evaluated on a copy of the affected data to find what it would add and remove, under
        the write lock and at the head it commits on (``commit`` with a function): two concurrent
        ``DELETE … INSERT … WHERE`` updates each see the other's result, and neither is lost. The gate
        (sparql_gate.py) judges the text before the lock is taken.
        """
        gate_update(sparql_update)
        return self.commit(lambda: change_of_update(self.backend, sparql_update), author=author,
                           message=message or "SPARQL update", expected_version=expected_version)

    # ------------------------------------------------------------------ versions
    def versions(self, limit: int | None = None) -> list[Version]:
        return read_versions(self.backend, limit)

    def version_info(self, number: int) -> Version:
        for v in self.versions():
            if v.number == number:
                return v
        raise NotFound(f"no graph version {number}; the head is {self.version}")

    def changes(self, number: int) -> ChangeSet:
        """The change set that version ``number`` committed."""
        self.version_info(number)
        return read_changes(self.backend, number)

    def diff(self, since: int, until: int | None = None, *, read: Callable[[int], ChangeSet] | None = None) -> ChangeSet:
        """The net change from version ``since`` to version ``until`` (default: the head); ``read``: how a version's
        change set is read (default ``read_changes``; a compile passes one that reads each version once)."""
        head = self.version
        until = head if until is None else until
        if not 0 <= since <= head or not 0 <= until <= head:
            raise NotFound(f"versions must lie in 0..{head}")
        read = read or (lambda n: read_changes(self.backend, n))
        net = ChangeSet()  # the range is checked above: each version's change set is read directly
        if since <= until:
            for n in range(since + 1, until + 1):
                net = net.then(read(n))
        else:
            for n in range(since, until, -1):
                net = net.then(read(n).inverse())
        return net

    def rollback(self, to: int, *, author: str, expected_version: int | None = None) -> CommitResult:
        """Restore the knowledge of version ``to`` as a new version (history is kept, like git revert)."""
        head = self.version
        if not 0 <= to <= head:
            raise NotFound(f"no graph version {to}; the head is {head}")
        if to == head:
            return CommitResult(version=head, changed=False)
        change = self.diff(head, to)
        return self.commit(change, author=author, message=f"rollback to version {to}", expected_version=expected_version)
