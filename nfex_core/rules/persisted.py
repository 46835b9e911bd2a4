"""The compiled rule table kept on disk, so that a service restarts without compiling its graph again.

A compile from scratch reads every measurement: under a second on the shipped graph, 1–2 s at 300k
statements and 6–12 s at 3M, at every start (``bench/bench_scale.py``). So the table is kept in a file:

- **written** when the service stops (``Advisor.close``) and after a compile made from scratch (the first of
  a process: in the service, before it is ready, so that pickling, which holds the interpreter lock, does not
  stall selections): the table with what the next compile carries from it (docs/architecture.md), its evidence
  view detached from its store (an in-memory copy of the graph: made again when a compile first has a rule to
  run, evidence/view.py ``detached``);
- **read** at the first compile of a process, and used when it was compiled from this very store: the commit
  of its version (``nfex:commitId``, a fresh uuid per commit) is the store's commit of that version — a store
  rebuilt, restored or rolled back to an equal version number differs — by the same code (a digest of
  ``nfex_core``'s and ``nfex_slam``'s sources and the versions of the libraries whose objects it holds) with
  the same extractor backends missing. When it is the head's, it answers at once; when the head has moved on,
  the next compile carries from it like from any earlier table. Anything else — no file, another store's,
  other code, a file that does not read — and the first compile is made from scratch, as without it.

The file is ``NFEX_COMPILED_CACHE/<sha1 of the store's location>.pickle`` (``~/.cache/nfex/compiled``), the
``KEEP`` most recently used kept. It is a pickle: written by this code for this user, like the store itself,
and as trusted — a file from elsewhere is not to be put there (unpickling runs code).
"""
from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
import pickle
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy
import pyoxigraph as ox
import rdflib

from ..caches import prune, write_atomically
from ..kg.rdf.namespaces import NFEX
from ..kg.rdf.terms import n3
from ..kg.storage.claims import META
from ..kg.storage.history import version_iri

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph
    from .table import RuleTable

log = logging.getLogger("nfex.rules")
FORMAT = 2
KEEP = 16  # tables of this many stores (a test suite starts many); the least recently used go


def _code_digest() -> str:
    """What the pickled objects depend on: the sources of the packages whose classes they are, and the versions of
    the libraries whose objects they hold (rdflib terms, numpy arrays)."""
    import nfex_slam

    import nfex_core

    h = hashlib.sha256(f"{FORMAT}\0{sys.version}\0{rdflib.__version__}\0{numpy.__version__}\0{ox.__version__}".encode())
    for package in (nfex_core, nfex_slam):
        root = Path(str(package.__file__)).resolve().parent
        for path in sorted(root.rglob("*.py")):
            h.update(f"\0{path.relative_to(root).as_posix()}\0".encode())
            h.update(path.read_bytes())
    return h.hexdigest()


_CODE: str | None = None


def code_digest() -> str:
    global _CODE
    if _CODE is None:
        _CODE = _code_digest()
    return _CODE


def commit_of(kg: KnowledgeGraph, version: int) -> str | None:
    """The commit id that wrote ``version`` in this store (None for version 0, or where the history lacks it)."""
    rows = kg.backend.select(f"SELECT ?id WHERE {{ GRAPH {n3(META)} {{ {n3(version_iri(version))} {n3(NFEX.commitId)} ?id }} }}").rows
    return str(rows[0]["id"]) if rows else None


def store_key(kg: KnowledgeGraph) -> str | None:
    """The store a table is compiled from, as the cache names it: a folder's absolute path or a server's URL, with
    the named graph that holds the knowledge; None for a store in memory (nothing outlives the process)."""
    location = kg.location
    if location == ":memory:":
        return None
    if not location.startswith(("http://", "https://")):
        location = str(Path(location).resolve())
    return f"{location}#{getattr(kg.backend, 'graph', None) or ''}"


class CompiledCache:
    """The file holding the compiled table of the store at ``kg.location`` (the module's docstring)."""

    def __init__(self, folder: Path, location: str) -> None:
        self.folder = folder
        self.path = folder / (hashlib.sha1(location.encode()).hexdigest() + ".pickle")
        self.location = location
        self._saving = threading.Lock()
        self._holds: tuple[int, str] | None = None  # (version, commit) of the table the file holds, as read or written here

    def load(self, kg: KnowledgeGraph, absent: dict[str, Any]) -> RuleTable | None:
        """The table kept for this store, if it was compiled from it by this code with the backends ``absent``
        missing; else None (and why, in the log)."""
        started = time.perf_counter()
        try:
            with self.path.open("rb") as f:
                head = pickle.load(f)
                if not isinstance(head, dict) or head.get("format") != FORMAT or head.get("code") != code_digest():
                    log.info("compiled table %s: written by other code; compiling", self.path)
                    return None
                if head.get("location") != self.location or head.get("commit") != commit_of(kg, int(head.get("version", -1))):
                    log.info("compiled table %s: not of this store's version %s; compiling", self.path, head.get("version"))
                    return None
                table = pickle.load(f)
        except FileNotFoundError:
            return None
        except Exception as e:  # a truncated or unreadable file is a cache miss, not an outage
            log.warning("compiled table %s does not read (%s: %s); compiling", self.path, type(e).__name__, e)
            return None
        carry = getattr(table, "carry", None)
        if carry is None or dict(carry.setup.absent) != dict(absent):
            log.info("compiled table %s: other extractor backends missing; compiling", self.path)
            return None
        table.kept_in = str(self.path)
        self._holds = (table.version, head["commit"])
        try:
            os.utime(self.path)  # recently used: kept by _prune
        except OSError:  # pruned meanwhile by another process: what was read stands
            pass
        log.info("compiled table of version %d read from %s in %.0f ms", table.version, self.path,
                 (time.perf_counter() - started) * 1000)
        return table

    def save(self, kg: KnowledgeGraph, table: RuleTable) -> None:
        """Write ``table`` (its evidence view detached) for the next start; a failure is logged, not raised."""
        with self._saving:
            started = time.perf_counter()
            try:
                commit = commit_of(kg, table.version)
                if commit is None or self._holds == (table.version, commit):  # nothing to write: the file has it
                    return
                carry = table.carry
                # the next compile may take the view meanwhile (take_view): the next start then makes one
                view = carry.view if carry is not None else None
                kept = dataclasses.replace(
                    table, decisions=dict(table.decisions),
                    carry=dataclasses.replace(carry, view=view.detached() if view is not None else None) if carry else None,
                    kept_in=None, made_before=None)  # the memo pickles empty (ContextMemo.__reduce__)
                head = {"format": FORMAT, "code": code_digest(), "location": self.location, "version": table.version, "commit": commit}

                def write(f: BinaryIO) -> None:
                    pickle.dump(head, f, protocol=pickle.HIGHEST_PROTOCOL)
                    pickle.dump(kept, f, protocol=pickle.HIGHEST_PROTOCOL)

                write_atomically(self.path, write, folder_mode=0o700)  # pickles: this user's only
                self._holds = (table.version, commit)
                prune(self.folder, "*.pickle", KEEP)
                log.info("compiled table of version %d written to %s in %.0f ms", table.version, self.path,
                         (time.perf_counter() - started) * 1000)
            except Exception as e:  # the next start compiles, as without the file
                log.warning("cannot keep the compiled table in %s: %s", self.folder, e)

