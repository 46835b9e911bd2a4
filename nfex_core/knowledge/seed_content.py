"""The seed as N-Triples, computed once per content and then read from a cache.

Computing the seed (``knowledge.seed_graph``: parsing ontology/ with its 1.2 MB of measurements,
compiling the DSL programs, skolemising blank nodes) takes seconds; reading its result back takes a
fraction of one. The result depends only on the files and the code that read them, so it is kept in
``NFEX_SEED_CACHE`` (default ``$XDG_CACHE_HOME/nfex/seed``) as ``<digest>.nt``, sorted N-Triples, where
the digest covers everything that determines it: every file under the home's ontology/ and rules/ (by its
path there; a file that resolves outside the home also by its absolute path, which a program's
``nfex:sourceFile`` records), nfex_core's sources, the DSL grammar, the rdflib and pyoxigraph versions,
and — when a Turtle file holds an IRI without a scheme, which kg.changes.read_turtle resolves against it — the working
directory. The folder keeps the ``KEEP`` most recently used seeds. An edited file,
another nFEX or another rdflib gives another name, so a stale file is never read; a file is written only
after it was read back to the same triples (tmp file + rename: concurrent writers are harmless), and a
folder that cannot be written only costs the computation each time.
"""
from __future__ import annotations

import hashlib
import logging
import os
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import pyoxigraph as ox
import rdflib
from rdflib.term import Node, URIRef

from ..caches import prune, write_atomically
from ..config import Settings
from ..kg.changes import graph_triples
from ..kg.history import ChangeText
from ..kg.terms import Triple, nt, oxigraph_triples, triple_n3, triple_nt
from ..rules.dsl.parser import GRAMMAR

log = logging.getLogger("nfex.seed")
PACKAGE = Path(__file__).resolve().parent
FORMAT = b"nfex-seed-1"  # bump when the file's layout or meaning changes
KEEP = 4  # seeds kept in the cache folder
PROBE = URIRef("urn:nfex:seed-probe")  # the other terms of round_trips' lines
RELATIVE_IRI = re.compile(rb"<(?![A-Za-z][A-Za-z0-9+.\-]*:)[^<>\s\"{}|^`\\]*>")  # an IRI without a scheme


@dataclass(frozen=True)
class SeedContent:
    """The seed's triples as sorted statements, one triple each: N-Triples lines (``triple_nt``)."""

    lines: tuple[str, ...]
    digest: str
    cached: bool = False  # read from the cache rather than computed
    computed: frozenset[Triple] | None = None  # the triples, when computed here
    ntriples: bool = True  # the lines are N-Triples (``triple_nt``), not ``triple_n3`` (the uncached fallback)

    def text(self) -> ChangeText:
        """What ``KnowledgeGraph.load_validated`` writes."""
        return ChangeText(self.lines, ntriples=self.ntriples)

    def triples(self) -> frozenset[Triple]:
        return self.computed if self.computed is not None else parse_lines(self.lines)


def parse_lines(lines: tuple[str, ...] | list[str]) -> frozenset[Triple]:
    data = "\n".join(lines).encode("utf-8")
    return frozenset(oxigraph_triples(ox.parse(data, format=ox.RdfFormat.N_TRIPLES)))


def round_trips(terms: set[Node]) -> bool:
    """Whether N-Triples carries each of ``terms`` unchanged (so lines of them read back to the same triples):
    each term is written once, in a line of its own, and read back — a line is its terms' texts side by side."""
    probe = f"<{PROBE}>"
    lines = [f"{nt(t)} {probe} {probe} ." if isinstance(t, URIRef) else f"{probe} {probe} {nt(t)} ." for t in terms]
    try:
        back = parse_lines(lines)
    except (SyntaxError, ValueError):
        return False
    return {s if s != PROBE else o for s, _, o in back} == terms


def _files(root: Path, pattern: str) -> list[Path]:
    if not root.is_dir():
        return []
    return sorted(p for p in root.rglob(pattern) if p.is_file() and "__pycache__" not in p.parts)


def digest(settings: Settings) -> str:
    """What determines the seed (module docstring), hashed."""
    h = hashlib.sha256(FORMAT)
    h.update(f"\0{rdflib.__version__}\0{ox.__version__}".encode())
    home = settings.home.resolve()
    relative = False
    roots = [("ontology", settings.ontology_dir, "*"), ("rules", settings.rules_dir, "*"), ("nfex_core", PACKAGE, "*.py")]
    for name, root, pattern in roots:
        for path in _files(root, pattern):
            data = path.read_bytes()
            h.update(f"\0{name}\0{path.relative_to(root).as_posix()}\0".encode())
            h.update(data)
            relative = relative or (path.suffix == ".ttl" and RELATIVE_IRI.search(data) is not None)
            if name != "nfex_core" and not path.resolve().is_relative_to(home):
                h.update(f"\0outside\0{path.resolve()}".encode())  # a program there is named by its absolute path
    if GRAMMAR.is_file():
        h.update(b"\0grammar\0" + GRAMMAR.read_bytes())
    if relative:  # read_turtle resolves a relative IRI against the working directory
        h.update(f"\0cwd\0{Path.cwd()}".encode())
    return h.hexdigest()


def seed_content(settings: Settings, compute: Callable[[Settings], Iterable[Triple]]) -> SeedContent:
    """The triples of ``compute(settings)`` (the seed graph) as N-Triples, from the cache when it has them."""
    key = digest(settings)
    path = settings.seed_cache / f"{key}.nt"
    try:
        text = path.read_text(encoding="utf-8")
        os.utime(path)  # recently used: kept by _prune
    except OSError:
        pass
    else:
        return SeedContent(tuple(line for line in text.split("\n") if line), key, cached=True)
    triples = graph_triples(compute(settings))
    lines = tuple(sorted(triple_nt(t) for t in triples))
    if not round_trips({term for t in triples for term in t}):  # a term N-Triples cannot carry as rdflib holds it: write it as commit does, and cache nothing
        log.warning("the seed does not read back from N-Triples unchanged; it is not cached")
        return SeedContent(tuple(sorted(triple_n3(t) for t in triples)), key, computed=triples, ntriples=False)
    _store(path, lines)
    return SeedContent(lines, key, computed=triples)


def _store(path: Path, lines: tuple[str, ...]) -> None:
    """Cache the seed; the KEEP most recently used seeds are kept (each edit of ontology/ or rules/ makes another)."""
    try:
        write_atomically(path, lambda f: f.write(("\n".join(lines) + "\n").encode("utf-8")))
        prune(path.parent, "*.nt", KEEP)
    except OSError as e:
        log.warning("cannot cache the seed in %s: %s", path.parent, e)
