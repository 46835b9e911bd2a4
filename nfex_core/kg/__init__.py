"""The knowledge graph: versioned, SHACL-checked transactions over an embedded or remote SPARQL store.

``store.py`` (``KnowledgeGraph``) and what it derives per version (``derived.py``) sit over ``shacl/`` (the
incremental validation of a write) and ``vocabulary/`` (the vocabulary read from the graph), both over
``storage/`` (backends, change sets, the version history, SPARQL's gate and reach), over ``rdf/`` (namespaces,
minted IRIs, terms); ``scope.py`` and ``shipped.py`` use the ``KnowledgeGraph``. pyproject.toml's import
contract keeps that order."""
from __future__ import annotations

from .storage.changes import ChangeSet, graph_triples, parse_rdf, read_rdf_file
from .store import CommitResult, KnowledgeGraph, Version

__all__ = ["ChangeSet", "CommitResult", "KnowledgeGraph", "Version", "graph_triples", "parse_rdf", "read_rdf_file"]
