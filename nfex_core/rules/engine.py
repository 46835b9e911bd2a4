"""The compiled rule engine: per graph version, one lookup table from context to decision.

The condition space is finite — each dimension takes one of its values or is unknown — so the engine
evaluates every SPARQL pruning rule once for all contexts (one query per rule, see pruning.py) and
every DSL statement and context shape (shapes.py) for all contexts, and stores a ``Decision`` per context: the candidates, the pruned
extractors with the rules that pruned them, the parameter factors f_kj, the metric weights h_x, the
preference bonuses, the context shapes in force (``require`` statements are compiled to them), and the measured evidence per extractor. A
request then pays one dictionary lookup. Measurements are read once (evidence/observations.py)
and only those the trust rule admits count (evidence/trust.py): the SPARQL rules run on the evidence view
(evidence/view.py), the evidence per extractor, the measured configurations and the cost model use the
admitted observations, each aggregated with the median (evidence/aggregate.py). The measured configurations of each extractor under a context
(``RuleTable.measured``: the graph's answer to "which Θ of α had the lowest median ATE here?") are ranked
on a context's first request and kept. ``compile_table`` runs again when the graph version changes, and
carries from the last table whatever the change cannot have touched (docs/architecture.md): the
configuration stage (setup.py), the observations (evidence/index.py) and their grouping (evidence/groups.py),
the rules' view (evidence/view.py), each rule's hits outside its footprint (kg/storage/footprint.py), and each
context's decision whose rule prunes are the same. The same step fits the cost model (nfex_core/evidence/cost.py) and reads the budget terms, so a request's
budget check (advisor/budget.py) costs arithmetic only.

Composition (paper §IV-A): several ``adjust`` statements on one parameter multiply
(w_k = Π_j f_kj(e_j)); several ``weight`` statements on one metric multiply (h_x(E), default 1);
``prefer`` bonuses add.
"""
from __future__ import annotations

import concurrent.futures
import functools
import logging
import os
import threading
import time
from collections.abc import Callable, Collection, Hashable, Mapping, Sequence
from typing import TYPE_CHECKING, TypeVar, cast

from rdflib.term import URIRef

from ..evidence import Observation, robust
from ..evidence.cost import fit_groups
from ..evidence.groups import Grouped
from ..evidence.index import Diff, ObservationIndex
from ..evidence.view import EvidenceView, dump, evidence_view, summary_lines
from ..kg.storage.backends import EmbeddedBackend
from ..kg.storage.changes import evidence_only
from ..kg.storage.footprint import Anchor, Effect, Reach, anchors, change_effect, reads
from ..kg.storage.history import read_changes
from ..kg.vocabulary.vocab import ExtractorSpec, Value
from . import pruning
from .persisted import CompiledCache
from .setup import Setup
from .table import CompileState, RuleTable, _measured_configuration
from .types import (
    Citation,
    ContextKey,
    Decision,
)

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

__all__ = ["CompileState", "RuleEngine", "RuleTable", "backend_citations", "compile_table"]

log = logging.getLogger("nfex.rules")
K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


def _per_group(groups: Mapping[K, tuple[Observation, ...]], dirty: Collection[K] | None, earlier: Mapping[K, V] | None,
               make: Callable[[K, tuple[Observation, ...]], V], stale: Callable[[K], bool] | None = None) -> dict[K, V]:
    """``make(key, observations)`` for every group: again only for the ``dirty`` ones (and the ``stale``) where the
    ``earlier`` results of the same groups are at hand (evidence/groups.py)."""
    if earlier is None or dirty is None:
        return {k: make(k, obs) for k, obs in groups.items()}
    again = set(dirty) | ({k for k in groups if stale(k)} if stale is not None else set())
    out = {k: v for k, v in earlier.items() if k in groups and k not in again}
    out.update((k, make(k, groups[k])) for k in again if k in groups)
    return out


def compile_table(kg: KnowledgeGraph, previous: RuleTable | None = None) -> RuleTable:
    """Evaluate every rule and statement for every context of the graph's condition space. ``previous``: the
    table of an earlier version, from which what the change since then cannot have touched is carried: its
    observations (evidence/index.py), its rules' view (evidence/view.py), its configuration stage
    (setup.py) when the change is evidence only, and each context's decision whose rule prunes are unchanged."""
    t0 = time.perf_counter()
    version = kg.version
    carry = previous.carry if previous is not None else None  # what the last compile left for this one
    # the stages below read the same change once, and each version's change set once: while reports stream in, the
    # head moves during a compile and its ranges overlap (version → head, read again as the head moves)
    changes = functools.cache(lambda n: read_changes(kg.backend, n))
    diff = functools.cache(lambda since, until: kg.diff(since, until, read=changes))
    # a full read of the observations runs in the store without the interpreter lock (observations.py) while the
    # configuration stage below parses the rules' queries with it
    reading = _pool().submit(ObservationIndex.read, kg) if carry is None else None
    absent = backend_citations(kg, kg.vocabulary().extractors)
    setup = _carried_setup(kg, previous, version, diff, absent) or Setup.read(kg, absent, carry.setup if carry is not None else None)
    vocab, dims = setup.vocab, setup.dimensions
    reach = _reach(setup)  # what the rules can read: all the view must hold of the stored graph
    # a fresh view's copy of the store is made while the observations are read (Oxigraph dumps without the lock)
    copying = _pool().submit(dump, kg, reach) if setup.rules and (
        carry is None or carry.view is None or carry.view.reach != reach) else None
    if reading is not None:
        index = reading.result()
    else:
        assert carry is not None
        index = carry.index.advance(kg, diff, version)
    grouped = carry.grouped.advance(carry.index.observations, index.observations, index.changed, setup.policy) \
        if carry is not None and index.changed is not None and carry.setup.policy == setup.policy \
        else Grouped.of(index.observations.values(), setup.policy)
    admission = grouped.admission
    extractor_iris = {x: str(e.iri) for x, e in vocab.extractors.items()}
    alike = carry is not None and _extractor_names(carry.setup) == _extractor_names(setup) \
        and carry.setup.value_iris == setup.value_iris
    dirty = grouped.dirty or {}
    lines = _per_group(grouped.groups["summary"], dirty.get("summary"), carry.summary_lines if alike and carry is not None else None,
                       lambda k, obs: summary_lines(k, obs, extractor_iris, setup.value_iris))
    summary = frozenset(line for group in lines.values() for line in group)
    carried = carry.take_view() if carry is not None and setup.rules and copying is None else None
    if carried is not None and carried.reach != reach:
        carried = None
    made: EvidenceView | None = None
    if setup.rules:
        made = carried.advance(kg, admission, summary, diff, version) if carried is not None \
            else evidence_view(kg, admission, summary, reach, copying.result() if copying is not None else None)
    errors: list[str] = []
    ruled: dict[int, list[tuple[str, Citation]]] = {}
    same = carry is not None and carry.setup is setup
    delta = made.delta if made is not None else None
    # a rule's last hits stand where its query is the same, the extractors are named alike and the view's
    # change since misses the rule's footprint, or the stars of its patterns (kg/storage/footprint.py), whatever else of
    # the configuration changed; and where the rule pruned nothing and the change can only take rows out of its
    # answer (a prior that yielded to evidence, and more evidence)
    earlier = carry.hits if carry is not None and delta is not None \
        and _extractor_names(carry.setup) == _extractor_names(setup) else {}
    hits: dict[tuple[pruning.SparqlRule, str], dict[int, list[tuple[str, Citation]]]] = {}
    touched = delta.pairs() if delta is not None else None

    def changed(k: int, last: dict[int, list[tuple[str, Citation]]]) -> bool:
        if not reads(setup.footprints[k], touched):
            return False
        stars = anchors(setup.rules[k].query)
        view = made
        if delta is None or view is None or stars is None:
            return True
        effect = change_effect(stars, delta, lambda ts: view.holds(kg, ts))
        return effect is Effect.ANY or (effect is Effect.SHRINKS and bool(last))

    due = [k for k, (rule, query) in enumerate(zip(setup.rules, setup.queries, strict=True)) if not isinstance(query, Exception)
           and ((rule, query) not in earlier or changed(k, earlier[(rule, query)]))]
    if made is not None and made.backend is None and due:  # a kept table's detached view (view.py): a rule must run now
        made = evidence_view(kg, admission, summary, reach)
        earlier = {}
        due = [k for k, query in enumerate(setup.queries) if not isinstance(query, Exception)]
    # ``due`` is empty without rules, and with rules there is a view (``made``) with its store
    found_by = dict(zip(due, _evaluate_rules(made.backend, [(setup.rules[k], cast(str, setup.queries[k])) for k in due]), strict=True)) \
        if made is not None and made.backend is not None else {}
    for k, (rule, query) in enumerate(zip(setup.rules, setup.queries, strict=True)):
        if isinstance(query, Exception):  # a broken rule must not take selection down; it is reported
            errors.append(f"{rule.iri}: {query}")
            continue
        kept = earlier.get((rule, query))
        if k in found_by:
            found = found_by[k]
            if isinstance(found, Exception):  # a broken rule must not take selection down; it is reported
                errors.append(f"{rule.iri}: {found}")
                log.warning("pruning rule %s failed: %s", rule.iri, found)
                continue
            kept = {}
            for i, found_here in found.items():
                # in a fixed order: a store returns rows in an order of its own, and a carried compile's view is
                # another store than a full compile's (their citations of one rule must come out the same)
                for x, reason in sorted(found_here, key=lambda hit: (str(hit[0]), str(hit[1]))):
                    spec = vocab.by_iri.get(x)
                    if isinstance(spec, ExtractorSpec):
                        kept.setdefault(i, []).append((spec.name, Citation(str(rule.iri), rule.label, reason, "sparql", rule.source)))
        assert kept is not None
        hits[(rule, query)] = kept
        for i, pairs in kept.items():
            ruled.setdefault(i, []).extend(pairs)
    errors += setup.errors
    plain: dict[ContextKey, Decision] = {}
    rebuilt = 0
    for i, key in enumerate(setup.keys):
        mine = tuple(ruled.get(i, ()))
        if same and carry is not None and carry.ruled.get(i, ()) == mine:
            plain[key] = carry.plain[key]
        else:
            plain[key] = setup.decision(i, mine)
            rebuilt += 1
    settings = index.measured_settings()
    aggregates = _per_group(grouped.groups["cost"], dirty.get("cost"), carry.cost_groups if carry is not None else None,
                            lambda k, obs: robust([o.extraction_ms for o in obs if o.extraction_ms is not None]))
    cost = fit_groups(vocab.extractors, settings, aggregates)
    measured = _per_group(grouped.groups["measured"], dirty.get("measured"),
                          carry.measured_groups if same and carry is not None else None,
                          lambda k, obs: _measured_configuration(k, obs, settings, vocab.extractors),
                          lambda k: k[1] in index.resettled)
    configurations: dict[str, dict[str, tuple[dict[str, Value], Sequence[Observation]]]] = {}
    if setup.measured_rule:
        for (x, cfg), found in measured.items():
            if found is not None:
                configurations.setdefault(x, {})[cfg] = found
    # per extractor, its groups by condition set: an extractor no group of which the change touched keeps its
    # dict, so what ``decide`` made of it is taken over too (``RuleTable._made``)
    touched_observed = dirty.get("observed")
    observed: dict[str, dict[frozenset[tuple[str, str]], Sequence[Observation]]] = {}
    if previous is not None and touched_observed is not None:
        extractors = {cast(str, k[0]) for k in touched_observed}  # type: ignore[index]
        observed = {x: g for x, g in previous.observed.items() if x not in extractors}
    else:
        extractors = None
    for group, obs in grouped.groups["observed"].items():
        extractor, conditions = cast(tuple[str, frozenset[tuple[str, str]]], group)
        if extractors is None or extractor in extractors:
            observed.setdefault(extractor, {})[conditions] = obs
    ms = (time.perf_counter() - t0) * 1000
    log.info("compiled %d contexts (%d rebuilt, configuration %s), %d rules, %d statements at graph version %d in %.0f ms "
             "(observations: %s in %.0f ms)", len(setup.keys), rebuilt, "carried" if same else "read", len(setup.rules),
             len(setup.statements), version, ms, "read in full" if index.reread < 0 else f"{index.reread} re-read", index.ms)
    return RuleTable(version, dims, dict(plain), list(setup.rules), list(setup.statements), errors, ms, cost, setup.budget_terms,
                     configurations, setup.min_measurements, observed, admission, step_checks=dict(setup.step_checks),
                     carry=CompileState(setup, index, made, hits, {i: tuple(r) for i, r in ruled.items()}, plain, grouped,
                                        lines, aggregates, measured),
                     made_before=previous.memo if previous is not None and previous.min_measurements == setup.min_measurements
                     and previous.dimensions == dims and alike else None)


Found = dict[int, list[tuple[URIRef, str]]]  # pruning.evaluate's: per context index, the extractors pruned and why
_RULE_THREADS: concurrent.futures.ThreadPoolExecutor | None = None
_RULE_THREADS_LOCK = threading.Lock()


def _evaluate_rules(view: EmbeddedBackend, rules: Sequence[tuple[pruning.SparqlRule, str]]) -> list[Found | Exception]:
    """Each rule's contextualised query on the view, side by side: Oxigraph evaluates a query without holding
    the GIL, and the rules are independent reads of one in-memory store."""
    def one(rule: pruning.SparqlRule, query: str) -> Found | Exception:
        try:
            return pruning.evaluate(view, rule, query)
        except Exception as e:  # reported by the caller, with the rule
            return e

    if len(rules) < 2:
        return [one(r, q) for r, q in rules]
    return list(_pool().map(lambda rq: one(*rq), rules))


def _pool() -> concurrent.futures.ThreadPoolExecutor:
    """The compile's helper threads: for work Oxigraph does without the interpreter lock."""
    global _RULE_THREADS
    with _RULE_THREADS_LOCK:
        if _RULE_THREADS is None:
            _RULE_THREADS = concurrent.futures.ThreadPoolExecutor(max_workers=max(2, min(4, os.cpu_count() or 1)),
                                                                  thread_name_prefix="nfex-rule")
        return _RULE_THREADS


def _reach(setup: Setup) -> Reach | None:
    """The stored triples the SPARQL rules can read (kg/storage/footprint.py ``Reach``); None: any (a rule whose patterns
    cannot be told, or that cannot be parsed)."""
    found: list[Anchor] = []
    for rule in setup.rules:
        stars = anchors(rule.query)
        if stars is None:
            return None
        found.extend(stars)
    return Reach.of(found)


def _extractor_names(setup: Setup) -> dict[str, str]:
    return {str(spec.iri): name for name, spec in setup.vocab.extractors.items()}


def _carried_setup(kg: KnowledgeGraph, previous: RuleTable | None, version: int, diff: Diff,
                   absent: Mapping[str, Citation]) -> Setup | None:
    """``previous``'s configuration stage, where the change from its version to ``version`` is evidence only
    (kg.storage.changes.evidence_only) and the same backends are missing; else None (read it again).

    The types are read at the head ``now``; a commit landing while they are read makes the read inexact, so it is
    read again, three times. A store this process alone writes is then read once more holding its write lock, where
    no commit can land: reports committed every few milliseconds (one reporter, batches of one) outran three reads
    and made each compile re-read its configuration (tests/nfex_core/rules/test_setup.py)."""
    carry = previous.carry if previous is not None else None
    if previous is None or carry is None or dict(carry.setup.absent) != dict(absent):
        return None
    try:
        change = diff(previous.version, version)

        def read() -> bool | None:
            now = kg.version
            found = evidence_only(kg.backend, change, diff(version, now) if now != version else None)
            return found if kg.version == now else None

        for _ in range(3):
            found = read()
            if found is not None:
                return carry.setup if found else None
        if kg.backend.exclusive:
            with kg.backend.write_lock:  # the commits wait a few reads; nothing here waits on a commit
                found = read()
            return carry.setup if found else None
    except Exception:  # a pruned or unreadable history
        return None
    return None


BACKEND_RULE = "https://w3id.org/nfex#rule_backend_available"


def backend_citations(kg: KnowledgeGraph, extractors: Mapping[str, ExtractorSpec]) -> dict[str, Citation]:
    """Extractors whose backend cannot run in this process (a learned model without its extra or weights),
    each with the citation that prunes it in every context: the reason says what to install or set."""
    from ..vision.backends import unavailable  # no heavy import: it checks installed packages and files

    return {x: Citation(BACKEND_RULE, "Extractor backend installed", a.detail, "backend")
            for x, a in unavailable(extractors, kg.settings).items()}


class RuleEngine:
    """The compiled table for the graph's current version, rebuilt when a commit moves the version; each
    rebuild carries the last table's observations forward (compile_table's ``previous``). With a ``cache``
    (persisted.py), the first table comes from the one kept on disk where it is this store's, and a table
    compiled from scratch is kept there for the next start."""

    def __init__(self, kg: KnowledgeGraph, cache: CompiledCache | None = None) -> None:
        self.kg = kg
        self.cache = cache
        self._last: RuleTable | None = None
        self._read_cache = cache is not None

    def table(self) -> RuleTable:
        if self._read_cache and self.cache is not None:
            self._read_cache = False
            loaded = self.cache.load(self.kg, backend_citations(self.kg, self.kg.vocabulary().extractors))
            if loaded is not None:
                self._last = loaded
                self.kg.remember("rule-table", loaded.version, loaded)  # it answers while it is the head's
        scratch = self._last is None
        table = self.kg.cached("rule-table", lambda: compile_table(self.kg, self._last))
        if scratch and self.cache is not None:  # the first compile of a process: in the service, before it is ready
            self.cache.save(self.kg, table)
        self._last = table
        return table

    def save(self) -> None:
        """Keep the last table for the next start (at shutdown)."""
        if self.cache is not None and self._last is not None:
            self.cache.save(self.kg, self._last)
