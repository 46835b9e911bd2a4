"""The shipped seed is validated here, in CI, so an empty store can receive it without validating it again.

``knowledge.seed`` writes the seed into an empty store in bulk (``KnowledgeGraph.load_validated``): no
pySHACL at the first start. These tests are what makes that safe: the whole shipped graph (ontology/ with
its measurements, rules/) conforms to its shapes, and the bulk write leaves the same knowledge and the
same history as the validated commit it replaces.
"""
from __future__ import annotations

from pathlib import Path

import pytest
from rdflib import Literal, URIRef

from nfex_core.config import Settings
from nfex_core.errors import PreconditionFailed
from nfex_core.kg import ChangeSet, KnowledgeGraph
from nfex_core.kg.history import ChangeText, version_iri
from nfex_core.kg.namespaces import NFEX
from nfex_core.kg.store import META
from nfex_core.kg.terms import n3
from nfex_core.knowledge import SEED_AUTHOR, SEED_MESSAGE, open_graph, seed, seed_graph, seed_triples
from nfex_core.knowledge.seed_content import seed_content


def test_the_shipped_seed_conforms(shipped_kg: KnowledgeGraph) -> None:
    """Whole-graph pySHACL on the shipped seed with its measurements (the bare-home seed: tests/rules)."""
    assert shipped_kg.versions()[-1].author == SEED_AUTHOR and shipped_kg.triple_count() > 30_000
    report = shipped_kg.validate()
    assert report.conforms, report.text


def version_node(kg: KnowledgeGraph, n: int) -> dict[URIRef, Literal]:
    rows = kg.select(f"SELECT ?p ?o WHERE {{ GRAPH {n3(META)} {{ {n3(version_iri(n))} ?p ?o }} }}").rows
    return {r["p"]: r["o"] for r in rows if r["p"] not in (NFEX.commitId, URIRef("http://www.w3.org/ns/prov#generatedAtTime"))}  # type: ignore[misc]


def test_the_bulk_seed_writes_what_the_validated_commit_writes(tmp_path: Path) -> None:
    settings = Settings.from_env()
    bulk = open_graph(str(tmp_path / "bulk"), settings=settings)
    committed = KnowledgeGraph.open(str(tmp_path / "committed"), settings=settings)
    committed.commit(ChangeSet.adding(seed_triples(settings)), author=SEED_AUTHOR, message=SEED_MESSAGE)
    assert bulk.version == committed.version == 1
    assert set(bulk.data_graph()) == set(committed.data_graph())
    assert bulk.changes(1) == committed.changes(1)
    assert version_node(bulk, 1) == version_node(committed, 1)
    assert [v.as_dict() | {"time": None} for v in bulk.versions()] == [v.as_dict() | {"time": None} for v in committed.versions()]
    # the head, the version and nothing else in the history graph
    assert bulk.select(f"SELECT (COUNT(*) AS ?n) WHERE {{ GRAPH {n3(META)} {{ ?s ?p ?o }} }}").rows == \
        committed.select(f"SELECT (COUNT(*) AS ?n) WHERE {{ GRAPH {n3(META)} {{ ?s ?p ?o }} }}").rows


def test_only_an_empty_store_is_loaded_without_validation(kg: KnowledgeGraph, tmp_path: Path) -> None:
    with pytest.raises(PreconditionFailed, match="empty store"):
        kg.load_validated(ChangeText(["<urn:a> <urn:b> <urn:c> ."]), author="x")
    # version 0 but holding triples written by something else: the seed goes through the validated commit
    other = KnowledgeGraph.open(str(tmp_path / "other"), settings=kg.settings)
    other.backend.update("INSERT DATA { <urn:nfex:test:a> <urn:nfex:test:b> <urn:nfex:test:c> }")
    with pytest.raises(PreconditionFailed):
        other.load_validated(ChangeText(["<urn:a> <urn:b> <urn:c> ."]), author="x")
    result = seed(other)
    assert result.version == 1 and result.report is not None and result.report.conforms


def test_a_bulk_write_that_fails_leaves_the_store_empty(tmp_path: Path) -> None:
    """The loader stops partway (here: the quads' second half does not parse): what it wrote is taken out,
    the error is raised, and the store is at version 0 with nothing in it but the head."""
    kg = KnowledgeGraph.open(str(tmp_path / "store"))
    lines = list(seed_content(kg.settings, seed_graph).lines)
    broken = [*lines[:1000], "<urn:a> <urn:b> not N-Triples .", *lines[1000:]]
    with pytest.raises(SyntaxError):
        kg.load_validated(ChangeText(broken, ntriples=True), author="x")
    assert kg.version == 0 and not kg.ask("ASK { ?s ?p ?o }")
    assert not kg.ask("ASK { GRAPH ?g { ?s ?p ?o } FILTER (?g != <urn:nfex:meta>) }")
    assert len(kg.select("SELECT * WHERE { GRAPH <urn:nfex:meta> { ?s ?p ?o } }").rows) == 1  # the head
    assert seed(kg).version == 1


def test_a_bulk_write_keeps_a_message_of_several_lines(tmp_path: Path) -> None:
    """The version node goes into the N-Quads the bulk loader reads: a message with a line break and quotes is
    written on one line, and read back as it was given."""
    kg = KnowledgeGraph.open(str(tmp_path / "store"))
    message = 'first line\nsecond "quoted" line'
    kg.load_validated(ChangeText(["<urn:nfex:test:a> <urn:nfex:test:b> <urn:nfex:test:c> ."], ntriples=True),
                      author="tester\ttab", message=message)
    [version] = kg.versions()
    assert (version.number, version.author, version.message) == (1, "tester\ttab", message)
