"""The knowledge graph: store backends, versioned SHACL-checked transactions, seeding, vocabulary."""
from __future__ import annotations

from .storage.changes import ChangeSet, graph_triples, parse_rdf, read_rdf_file
from .store import CommitResult, KnowledgeGraph, Version

__all__ = ["ChangeSet", "CommitResult", "KnowledgeGraph", "Version", "graph_triples", "parse_rdf", "read_rdf_file"]
