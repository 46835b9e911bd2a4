"""The graph as the SPARQL pruning rules see it: admitted evidence only, with robust summaries.

Pruning rules are SPARQL text stored in the graph (rules/pruning/*.rq, or an editor's), so they cannot
call ``trust.admit`` or ``aggregate.robust``. The rule engine therefore evaluates them, once per graph
version, on a *view*: an in-memory copy of the default graph where

- the Measurements that ``admit`` did not admit are absent (every triple they are the subject of), so
  a rule that reads ``?m a nfex:Measurement`` sees admitted evidence only, whoever wrote the rule;
- each (extractor, condition value) with admitted windows has an ``nfex:EvidenceSummary`` carrying the
  robust aggregates (aggregate.py) of those windows, which the shipped measured rules read:

      nfex:ofExtractor, nfex:underCondition        the extractor and the condition value
      nfex:windows, nfex:failedWindows             windows, and those that failed outright
      nfex:ateWindows, nfex:medianAte, nfex:ateOutliers            windows with an ATE, their median, outliers
      nfex:lossWindows, nfex:medianLossRate        windows with a tracking-loss count, median lost/frames
      nfex:sources                                 distinct sources (sweep runs, reporters)

The summaries exist in the view only; ``GET /sparql`` shows the stored graph.

Of the stored graph the view holds only what the rules can read: R, their *reach* (kg/footprint.py ``Reach``;
all of it where a rule's patterns cannot be told), about one statement in ten at 3M. A first view costs one
N-Triples dump of R(G) and its load (``bench/bench_rules.py`` prints it). The next version's view is made from
the last one (``EvidenceView.advance``): with Q the quarantined Measurements and S the summary triples, the view
at v is V(v) = R(G(v) − triples of Q(v)) ∪ S(v). Given V(u) and the change G(u) → G(v) (``kg.diff``): take S(u)
out, apply the change's triples in R (removed, then added), take out the triples of every Measurement in Q(v),
put back from the store those in R of Q(u) − Q(v), and lay S(v) over it. A Measurement of Q(u) lost its
triples in V(u) and gets G(v)'s in R back; one of Q(v) loses all of them; any other node's triples are G(v)'s
in R. So the result is V(v), provided no stored triple has a
summary node (``nfex:evidence_…``, minted here) as subject — tests/nfex_core/evidence/test_view.py compares
with a fresh view after random changes. A change that cannot be read, is large (``MAX_CHANGE`` triples) or
holds blank nodes gets a fresh view.
"""
from __future__ import annotations

import hashlib
import io
import logging
import tempfile
from collections import Counter
from collections.abc import Iterable, Iterator, Mapping, Sequence, Set
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import pyoxigraph as ox
from rdflib.term import Literal, Node, URIRef

from ..kg.backends import EmbeddedBackend
from ..kg.changes import ChangeSet
from ..kg.claims import META
from ..kg.footprint import Delta, Reach
from ..kg.history import HEAD, ChangeText
from ..kg.namespaces import NFEX
from ..kg.terms import oxigraph_triples, py
from .aggregate import robust
from .index import Diff
from .observations import Observation
from .trust import Admission

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

_XSD = "http://www.w3.org/2001/XMLSchema#"
MAX_CHANGE = 20_000  # triples; above this a fresh view is as cheap
_BATCH = 500  # IRIs or triples per update

log = logging.getLogger("nfex.evidence")


def _lit(v: float | int) -> str:
    return f'"{int(v)}"^^<{_XSD}integer>' if isinstance(v, int) else f'"{float(v)!r}"^^<{_XSD}double>'


def summary_lines(key: tuple[str, tuple[str, str]], obs: Sequence[Observation], extractor_iris: Mapping[str, str],
                  value_iris: Mapping[tuple[str, str], str]) -> tuple[str, ...]:
    """One summary node: the admitted windows ``obs`` of extractor ``key[0]`` under condition value ``key[1]``."""
    x, cond = key
    if x not in extractor_iris or cond not in value_iris or not obs:
        return ()
    s = "<" + str(NFEX["evidence_" + hashlib.sha1(f"{x}|{cond[0]}|{cond[1]}".encode()).hexdigest()[:16]]) + ">"
    failed, sources, ates, rates = 0, set(), [], []  # one pass: a group of a large graph holds thousands of windows
    for o in obs:
        failed += o.failed
        sources.add(o.reporter or o.run or "unattributed")  # ``Observation.source``
        if o.ate is not None:
            ates.append(o.ate)
        if o.lost is not None and o.frames:
            rates.append(o.lost / o.frames)
    facts: dict[str, str] = {
        "ofExtractor": f"<{extractor_iris[x]}>", "underCondition": f"<{value_iris[cond]}>",
        "windows": _lit(len(obs)), "failedWindows": _lit(failed), "sources": _lit(len(sources)),
    }
    facts["ateWindows"] = _lit(len(ates))
    if ates:
        agg = robust(ates)
        facts["medianAte"], facts["ateOutliers"] = _lit(agg.value), _lit(agg.outliers)
    facts["lossWindows"] = _lit(len(rates))
    if rates:
        facts["medianLossRate"] = _lit(robust(rates).value)
    return (f"{s} <http://www.w3.org/1999/02/22-rdf-syntax-ns#type> <{NFEX.EvidenceSummary}> .",
            *(f"{s} <{NFEX[k]}> {v} ." for k, v in facts.items()))


@dataclass
class EvidenceView:
    """The view of graph ``version``, with what it took out of the stored graph (the triples of the
    ``quarantined`` Measurements) and laid over it (the ``summary`` lines), so the next version's view can
    be made from this one. ``advance`` changes ``backend`` in place: a view is handed to one compile."""

    version: int  # −1: not to be advanced (_settled)
    backend: EmbeddedBackend | None  # None: detached (``detached``), the store to be made when a rule must run
    quarantined: frozenset[str]
    summary: frozenset[str]
    incremental: bool = False  # made from an earlier view (else from a dump of the stored graph)
    delta: Delta | None = None  # the triples by which the advance changed the view (kg/footprint.py); None: unknown
    reach: Reach | None = None  # the stored triples it holds: those the rules can read (kg/footprint.py); None: all

    def detached(self) -> EvidenceView:
        """This view without its store: what the table kept on disk holds (rules/persisted.py). Advanced, it says what
        changed (``delta``) without a store to change, so compiles whose change no rule reads (a report waiting for
        corroboration) need no copy of the graph; the first compile that must run a rule makes a fresh view."""
        return EvidenceView(self.version, None, self.quarantined, self.summary, reach=self.reach)

    def advance(self, kg: KnowledgeGraph, admission: Admission, summary: frozenset[str],
                diff: Diff | None = None, head: int | None = None) -> EvidenceView:
        """The view of ``head`` (default: the store's head), made from this one (module docstring), or a fresh one
        where it cannot be. ``diff``: how to read the change (default ``kg.diff``; a compile shares one with the
        observation index)."""
        head = kg.version if head is None else head
        reach = self.reach
        if self.version < 0:
            return evidence_view(kg, admission, summary, reach)
        try:
            change = (diff or kg.diff)(self.version, head)
        except Exception as e:  # a pruned or unreadable history
            log.info("evidence view: no diff from version %d (%s); a fresh view", self.version, e)
            return evidence_view(kg, admission, summary, reach)
        if len(change.added) + len(change.removed) > MAX_CHANGE or any(
            not isinstance(x, URIRef | Literal) for t in (*change.added, *change.removed) for x in t
        ):
            return evidence_view(kg, admission, summary, reach)
        quarantined = frozenset(admission.quarantined)
        if self.backend is None:
            delta = _delta(kg, change, self.quarantined, quarantined, self.summary, summary)
            return EvidenceView(head, None, quarantined, summary, incremental=True, delta=delta, reach=reach)
        store: ox.Store = self.backend._store
        text = ChangeText.of(change if reach is None else ChangeSet(added=frozenset(t for t in change.added if reach.holds(t)),
                                                                  removed=frozenset(t for t in change.removed if reach.holds(t))))
        _delete_data(store, sorted(self.summary - summary))
        _delete_data(store, text.removed)
        _insert_data(store, text.added)
        _delete_subjects(store, quarantined)
        readmitted = sorted(self.quarantined - quarantined)
        version = head
        for i in range(0, len(readmitted), _BATCH):
            readmission = io.BytesIO()
            values = " ".join(f"<{m}>" for m in readmitted[i : i + _BATCH])
            within = "?s ?p ?o" if reach is None else reach.pattern()
            kg.backend.query_to(f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{ VALUES ?s {{ {values} }} {within} }}", "application/n-triples", readmission)
            store.load(readmission.getvalue(), format=ox.RdfFormat.N_TRIPLES)
            version = _settled(kg, head)  # read from the store: pinned to ``head`` only if no commit landed since
        _insert_data(store, sorted(summary - self.summary))
        delta = _delta(kg, change, self.quarantined, quarantined, self.summary, summary)
        return EvidenceView(version, self.backend, quarantined, summary, incremental=True, delta=delta, reach=reach)

    def holds(self, kg: KnowledgeGraph, triples: Set[tuple[URIRef, URIRef, URIRef]]) -> set[tuple[URIRef, URIRef, URIRef]] | None:
        """Which of ``triples`` (IRIs only) this view holds, for kg/footprint.py ``change_effect``: asked of its store,
        or, detached, of the stored graph less the quarantined plus the summaries — None where the store has moved
        past this view's version (it then cannot tell)."""
        if not triples:
            return set()
        values = " ".join(f"(<{s}> <{p}> <{o}>)" for s, p, o in triples)
        query = f"SELECT ?s ?p ?o WHERE {{ VALUES (?s ?p ?o) {{ {values} }} ?s ?p ?o }}"
        found = {(r["s"], r["p"], r["o"]) for r in (self.backend if self.backend is not None else kg.backend).select(query).rows}
        if self.backend is not None:
            return {t for t in triples if t in found}
        if kg.version != self.version:
            return None
        summary = set(_summary_triples(self.summary))
        return {t for t in triples if (t in found and str(t[0]) not in self.quarantined) or t in summary}


def _summary_triples(lines: Iterable[str]) -> Iterator[tuple[Node, Node, Node]]:
    """The triples of summary lines (``summary_lines``: N-Triples), read by Oxigraph's parser."""
    text = "\n".join(lines)
    return oxigraph_triples(ox.parse(text.encode(), format=ox.RdfFormat.N_TRIPLES)) if text else iter(())


def _delta(kg: KnowledgeGraph, change: ChangeSet, before: frozenset[str], after: frozenset[str],
           summary_before: frozenset[str], summary_after: frozenset[str]) -> Delta | None:
    """The triples by which the view changed, for kg/footprint.py; None where they are not known here: a
    Measurement left quarantine, or one that had triples before the change entered it (its stored triples come
    or go whole). A triple of a Measurement quarantined on both sides of the change never was in the view, nor
    was one added for a Measurement quarantined on arrival."""
    arrived = after - before
    if before - after:
        return None
    if arrived:
        counts = Counter(str(t[0]) for t in change.added if str(t[0]) in arrived)
        values = " ".join(f"<{m}>" for m in sorted(arrived))
        rows = kg.backend.select(f"SELECT ?m (COUNT(*) AS ?n) WHERE {{ VALUES ?m {{ {values} }} ?m ?p ?o }} GROUP BY ?m").rows
        if any(int(py(r["n"])) != counts[str(r["m"])] for r in rows):
            return None  # it had triples before the change: they left the view
    added: set[tuple[Node, Node, Node]] = {t for t in change.added if str(t[0]) not in after}
    removed: set[tuple[Node, Node, Node]] = {t for t in change.removed if str(t[0]) not in before}
    added.update(_summary_triples(summary_after - summary_before))
    removed.update(_summary_triples(summary_before - summary_after))
    return Delta(frozenset(added), frozenset(removed))


def _delete_data(store: ox.Store, lines: Sequence[str]) -> None:
    for i in range(0, len(lines), _BATCH):
        store.update("DELETE DATA {\n" + "\n".join(lines[i : i + _BATCH]) + "\n}")


def _insert_data(store: ox.Store, lines: Sequence[str]) -> None:
    """Statements as a version writes them (``ChangeText``: SPARQL terms, long literals included; not N-Triples)."""
    for i in range(0, len(lines), _BATCH):
        store.update("INSERT DATA {\n" + "\n".join(lines[i : i + _BATCH]) + "\n}")


def _delete_subjects(store: ox.Store, iris: Iterable[str]) -> None:
    out = sorted(iris)
    for i in range(0, len(out), _BATCH):
        values = " ".join(f"<{m}>" for m in out[i : i + _BATCH])
        store.update(f"DELETE {{ ?m ?p ?o }} WHERE {{ VALUES ?m {{ {values} }} ?m ?p ?o }}")


def dump(kg: KnowledgeGraph, reach: Reach | None = None) -> EmbeddedBackend:
    """The first step of a fresh view: the stored triples in ``reach`` (None: all) copied into an in-memory store,
    with the version they were read at. It reads the store only, so a compile can have it made while it reads the
    observations (rules/engine.py)."""
    view = EmbeddedBackend(None)
    store: ox.Store = view._store
    query = _versioned_dump(reach)
    if not (isinstance(kg.backend, EmbeddedBackend) and _load_through_file(kg.backend, store, query)):
        out = io.BytesIO()
        kg.backend.query_to(query, "application/n-triples", out)
        store.load(out.getvalue(), format=ox.RdfFormat.N_TRIPLES)
    return view


def evidence_view(kg: KnowledgeGraph, admission: Admission, summary: frozenset[str], reach: Reach | None = None,
                  dumped: EmbeddedBackend | None = None) -> EvidenceView:
    """A fresh view (module docstring): the stored graph dumped and loaded, less the quarantined, plus the summaries;
    ``reach``: only the stored triples the rules can read (kg/footprint.py ``Reach``: at 3M statements about one in
    ten), None: all of them; ``dumped``: ``dump(kg, reach)``, made beforehand. The dump carries the version it read (one query reads one state of the store, and a
    commit writes its data and the head in one operation), so the view knows its version even while commits land."""
    view = dumped if dumped is not None else dump(kg, reach)
    store: ox.Store = view._store
    mark = ox.NamedNode(_MARK)
    found = [int(q.object.value) for q in store.quads_for_pattern(mark, mark, None) if isinstance(q.object, ox.Literal)]
    store.update(f"DELETE WHERE {{ <{_MARK}> <{_MARK}> ?v }}")
    version = max(found) if found else -1
    quarantined = frozenset(admission.quarantined)
    _delete_subjects(store, quarantined)
    store.load("\n".join(sorted(summary)).encode() + b"\n", format=ox.RdfFormat.N_TRIPLES)
    return EvidenceView(version, view, quarantined, summary, reach=reach)


_MARK = "urn:nfex:view-version"


def _versioned_dump(reach: Reach | None) -> str:
    within = "{ ?s ?p ?o }" if reach is None else reach.pattern()
    return f"""CONSTRUCT {{ ?s ?p ?o . <{_MARK}> <{_MARK}> ?v }} WHERE {{
    {within} UNION {{ GRAPH <{META}> {{ <{HEAD}> <{NFEX.versionNumber}> ?v }} }}
}}"""


def _load_through_file(backend: EmbeddedBackend, store: ox.Store, query: str) -> bool:
    """The stored graph dumped into ``store`` through a temporary file, which Oxigraph writes and reads without the
    interpreter lock (into a Python buffer, the dump took the lock for every chunk, against the requests being
    served: ~20 s for the whole graph at 3M statements). False, with ``store`` left empty, where no such file can be written
    (the dump is ~150 bytes a statement): the caller goes through memory."""
    try:
        with tempfile.TemporaryDirectory(prefix="nfex-view-") as folder:
            path = str(Path(folder) / "dump.nt")
            backend.construct_to_file(query, path)
            store.load(path=path, format=ox.RdfFormat.N_TRIPLES)
        return True
    except OSError as e:
        log.info("evidence view: no temporary file (%s); the dump goes through memory", e)
        store.clear()
        return False


def _settled(kg: KnowledgeGraph, version: int) -> int:
    """``version``, or −1 (the next view is made fresh) when a commit landed after it before the store was read:
    the view may then hold a triple of a later version that a diff from ``version`` would not take out again."""
    return version if kg.version == version else -1
