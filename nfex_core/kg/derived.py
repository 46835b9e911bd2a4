"""What a KnowledgeGraph derives from its graph, per version: its shapes and vocabulary, and the verdict of its
shapes on a change.

Each is kept for the version it was read at (``cached``) and carried to the next version when a commit cannot
have changed it (``_carry_shapes``, ``_carry_vocabulary``: kg/storage/footprint.py's footprints, changes.evidence_only).
A change is validated on the nodes it touches (validation.py), the whole candidate graph where it edits the
shapes. ``Derived`` is a base of ``store.KnowledgeGraph``, which holds the store these read.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, TypeVar

import rdflib

from .shacl.process import ShaclProcess
from .shacl.validation import (
    Neighbourhood,
    Report,
    Shapes,
    core_violations,
    extract_shapes,
    shapes_in,
    touches_shapes,
    validate_change,
    validate_graph,
)
from .storage.backends import Backend, SelectResult
from .storage.changes import ChangeSet, evidence_only
from .storage.footprint import Footprint, Recorder, pairs, reads
from .vocabulary.vocab import Vocabulary

T = TypeVar("T")


class Derived:
    """The derived reads of ``store.KnowledgeGraph`` (module docstring); the attributes are its."""

    backend: Backend
    shacl: ShaclProcess | None
    _cache: dict[str, tuple[int, Any]]
    _cache_lock: threading.Lock
    _vocabulary_footprint: Footprint | None
    _neighbourhood: Neighbourhood

    @property
    def version(self) -> int:
        raise NotImplementedError

    def data_graph(self) -> rdflib.Graph:
        raise NotImplementedError

    def select(self, query: str, *, prefixes: bool = True) -> SelectResult:
        raise NotImplementedError

    def _effective(self, change: ChangeSet) -> ChangeSet:
        raise NotImplementedError

    def cached(self, key: str, build: Callable[[], T]) -> T:
        """A value derived from the graph, rebuilt when the version changes (vocabulary, rule tables…)."""
        v = self.version
        with self._cache_lock:
            hit = self._cache.get(key)
            if hit is not None and hit[0] == v:
                return hit[1]
        value = build()
        # a commit between reading v and building is caught by the next call's version check
        with self._cache_lock:
            self._cache[key] = (v, value)
        return value

    def remember(self, key: str, version: int, value: T) -> None:
        """Hand ``cached`` the value of ``key`` at ``version`` (a compiled table read from disk, rules/persisted.py)."""
        with self._cache_lock:
            self._cache[key] = (version, value)

    def shapes(self) -> Shapes:
        return self.cached("shapes", lambda: extract_shapes(self.backend))

    def _carry_shapes(self, change: ChangeSet, head: int) -> None:
        """The shapes of ``head`` are those of ``head + 1`` when ``change`` leaves them alone: a change that
        touches no shape node, no ``sh:`` predicate and no ``sh:`` type cannot add, remove or alter one
        (``touches_shapes`` against ``shapes_closure``). Spares each commit a re-extraction, and pySHACL a
        re-parse of the SPARQL constraints the fresh blank nodes of a new extraction would change."""
        with self._cache_lock:
            hit = self._cache.get("shapes")
            if hit is not None and hit[0] == head and not touches_shapes(change, hit[1]):
                self._cache["shapes"] = (head + 1, hit[1])

    def _carry_vocabulary(self, change: ChangeSet, head: int) -> None:
        """The vocabulary of ``head`` is that of ``head + 1`` when ``change`` (just committed) misses what loading
        it reads (the footprint of its queries, kg/storage/footprint.py: an editor's statement toggle) or touches
        evidence only (changes.evidence_only: a report's Measurement, run, configuration, …): spares each
        report batch and editor's write, and the compile after it, a reload (~15 ms)."""
        with self._cache_lock:
            hit = self._cache.get("vocabulary")
            fp = self._vocabulary_footprint
        if hit is None or hit[0] != head:
            return
        if reads(fp, pairs(change.added | change.removed)) and not evidence_only(self.backend, change):
            return
        with self._cache_lock:
            if self._cache.get("vocabulary") is hit:
                self._cache["vocabulary"] = (head + 1, hit[1])

    def vocabulary(self) -> Vocabulary:
        return self.cached("vocabulary", self._load_vocabulary)

    def _load_vocabulary(self) -> Vocabulary:
        reader = Recorder(self)
        vocab = Vocabulary.load(reader)
        with self._cache_lock:
            self._vocabulary_footprint = reader.footprint()
        return vocab

    # ------------------------------------------------------------------ validating
    def validate(self) -> Report:
        """Validate the whole graph against its shapes (about a second at 17k triples)."""
        return validate_graph(self.data_graph(), self.shapes())

    def check(self, change: ChangeSet) -> Report:
        """Validate ``change`` against the current head without committing it."""
        effective = self._effective(change)
        return self._validate(effective)

    def _validate(self, change: ChangeSet) -> Report:
        """The core shape first (a few ASKs: a change that would empty the graph is refused at once, not
        after validating the whole candidate), then the shapes on the touched nodes (validation.py)."""
        core = core_violations(self.backend, change)
        if core:
            return Report(False, core, "Conforms: False" + "".join(f"\nViolation: {r.line()}" for r in core))
        return self._validate_shapes(change)

    def _validate_shapes(self, change: ChangeSet, head: int | None = None) -> Report:
        """``head``: the version the store is at, known under the write lock (the neighbourhoods kept at it are used)."""
        shapes = self.shapes()
        if touches_shapes(change, shapes) or self.version == 0:
            candidate = self.data_graph()
            for t in change.removed:
                candidate.remove(t)
            for t in change.added:
                candidate.add(t)
            new_shapes = shapes_in(candidate)
            return validate_graph(candidate, new_shapes)
        return validate_change(self.backend, change, shapes, self.shacl.run if self.shacl is not None else None,
                               self._neighbourhood.at(head) if head is not None else None)
