"""Transactions, versions, rollback and export on the embedded store."""
from __future__ import annotations

import pytest
from rdflib import Literal, URIRef
from rdflib.namespace import RDFS

from nfex_core.errors import BadInput, NotFound, ParseError, PreconditionFailed, ValidationFailed
from nfex_core.kg import ChangeSet, KnowledgeGraph, graph_triples, parse_rdf
from nfex_core.kg.namespaces import NFEX

P = "@prefix nfex: <https://w3id.org/nfex#> . @prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n"
CONFIG = P + """
nfex:cfg1 a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg1_nf .
nfex:cfg1_nf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures ; nfex:value 1000 .
"""


def snapshot(kg: KnowledgeGraph) -> set:  # type: ignore[type-arg]
    return set(kg.data_graph())


def test_seeded_store_is_at_version_1(kg: KnowledgeGraph) -> None:
    assert kg.version == 1
    [v] = kg.versions()
    assert (v.number, v.author) == (1, "nfex seed") and v.added == kg.triple_count()


def test_add_commits_a_version_with_author_time_and_change_set(kg: KnowledgeGraph) -> None:
    result = kg.add(parse_rdf(CONFIG), author="alice", message="a config")
    assert (result.changed, result.version, result.added) == (True, 2, 6)
    v = kg.version_info(2)
    assert (v.author, v.message, v.added, v.removed) == ("alice", "a config", 6, 0)
    assert v.time is not None
    assert kg.changes(2).added == graph_triples(parse_rdf(CONFIG))


def test_adding_what_is_there_is_a_no_op(kg: KnowledgeGraph) -> None:
    kg.add(parse_rdf(CONFIG), author="a")
    again = kg.add(parse_rdf(CONFIG), author="a")
    assert (again.changed, again.version) == (False, 2)
    assert [v.number for v in kg.versions()] == [2, 1]


def test_only_real_changes_are_recorded(kg: KnowledgeGraph) -> None:
    """A change set records what changed, not what was asked: rollbacks stay exact."""
    g = parse_rdf(CONFIG)
    g.add((NFEX.ORB, RDFS.label, Literal("ORB", lang="en")))  # already in the seed
    kg.add(g, author="a")
    assert (NFEX.ORB, RDFS.label, Literal("ORB", lang="en")) not in kg.changes(2).added


def test_remove_then_rollback_restores_the_exact_graph(kg: KnowledgeGraph) -> None:
    before = snapshot(kg)
    kg.add(parse_rdf(CONFIG), author="a")
    after_add = snapshot(kg)
    kg.remove(parse_rdf(CONFIG), author="a")
    assert snapshot(kg) == before
    r = kg.rollback(2, author="a")
    assert r.version == 4 and snapshot(kg) == after_add
    r = kg.rollback(1, author="a")
    assert r.version == 5 and snapshot(kg) == before
    assert kg.version_info(5).message == "rollback to version 1"


def test_diff_composes_versions(kg: KnowledgeGraph) -> None:
    kg.add(parse_rdf(CONFIG), author="a")
    kg.commit(ChangeSet.adding([(NFEX.cfg1, RDFS.comment, Literal("x"))]), author="a")
    net = kg.diff(1)
    assert len(net.added) == 7 and not net.removed
    assert kg.diff(3, 1) == net.inverse()


def test_rejected_write_changes_nothing(kg: KnowledgeGraph) -> None:
    before, version = snapshot(kg), kg.version
    bad = CONFIG.replace("nfex:value 1000", "nfex:value -5")
    with pytest.raises(ValidationFailed):
        kg.add(parse_rdf(bad), author="a")
    assert snapshot(kg) == before and kg.version == version and len(kg.versions()) == 1


def test_expected_version_guards_against_stale_writers(kg: KnowledgeGraph) -> None:
    kg.add(parse_rdf(CONFIG), author="a")
    with pytest.raises(PreconditionFailed) as e:
        kg.add(parse_rdf(P + 'nfex:cfg1 rdfs:comment "late" .'), author="b", expected_version=1)
    assert e.value.extra["current_version"] == 2


def test_sparql_update_is_a_checked_transaction(kg: KnowledgeGraph) -> None:
    r = kg.update(
        'PREFIX nfex: <https://w3id.org/nfex#> PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#> '
        'INSERT { ?x rdfs:comment "touched" } WHERE { ?x a nfex:FeatureExtractor }',
        author="editor",
    )
    assert r.changed and r.added == len(kg.vocabulary().extractors)
    with pytest.raises(ValidationFailed):
        kg.update(
            'PREFIX nfex: <https://w3id.org/nfex#> DELETE { nfex:ORB nfex:opencvConstructor ?c } WHERE { nfex:ORB nfex:opencvConstructor ?c }',
            author="editor",
        )
    with pytest.raises(ParseError):
        kg.update("INSERT NONSENSE", author="editor")
    with pytest.raises(BadInput):
        kg.update("INSERT DATA { GRAPH <urn:x> { <urn:a> <urn:b> <urn:c> } }", author="editor")


def test_blank_nodes_are_skolemised_so_a_file_can_be_removed_again(kg: KnowledgeGraph) -> None:
    text = P + 'nfex:ORB nfex:note [ rdfs:label "a note" ; rdfs:comment "with a blank node" ] .'
    before = snapshot(kg)
    kg.add(parse_rdf(text), author="a")
    assert len(snapshot(kg) - before) == 3
    kg.remove(parse_rdf(text), author="a")
    assert snapshot(kg) == before


def test_change_sets_with_blank_nodes_are_refused(kg: KnowledgeGraph) -> None:
    from rdflib import BNode

    with pytest.raises(BadInput):
        kg.commit(ChangeSet.adding([(BNode(), RDFS.label, Literal("x"))]), author="a")


def test_unknown_versions(kg: KnowledgeGraph) -> None:
    with pytest.raises(NotFound):
        kg.rollback(9, author="a")
    with pytest.raises(NotFound):
        kg.changes(9)


def test_store_survives_reopening(store_path) -> None:  # type: ignore[no-untyped-def]
    kg = KnowledgeGraph.open(str(store_path))
    kg.add(parse_rdf(CONFIG), author="a")
    kg.close()
    del kg
    kg2 = KnowledgeGraph.open(str(store_path))
    assert kg2.version == 2 and (URIRef(NFEX.cfg1), NFEX.ofExtractor, NFEX.ORB) in kg2.data_graph()


def test_second_process_on_the_same_folder_gets_a_clear_error(store_path) -> None:  # type: ignore[no-untyped-def]
    import subprocess
    import sys

    kg = KnowledgeGraph.open(str(store_path))
    code = f"from nfex_core.kg import KnowledgeGraph; KnowledgeGraph.open({str(store_path)!r})"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode != 0 and "in use by another process" in p.stderr
    kg.close()


def test_seed_sync_removes_what_left_the_files(kg: KnowledgeGraph, tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """`nfex kg seed` brings the store in line with the repository without touching other data."""
    import shutil

    from nfex_core.knowledge import seed

    home = tmp_path / "home"
    shutil.copytree(kg.settings.home / "ontology", home / "ontology")
    shutil.copytree(kg.settings.home / "rules", home / "rules")
    kg.add(parse_rdf(CONFIG), author="user")
    text = (home / "ontology" / "metrics.ttl").read_text()
    (home / "ontology" / "metrics.ttl").write_text(text.replace('rdfs:label "texturedness"@en', 'rdfs:label "texture variance"@en'))
    kg.settings = kg.settings.replace(home=home)
    result = seed(kg)
    assert result.changed and (result.added, result.removed) == (1, 1)
    labels = {str(o) for o in kg.data_graph().objects(NFEX.texturedness, RDFS.label)}
    assert labels == {"texture variance"}
    assert (NFEX.cfg1, NFEX.ofExtractor, NFEX.ORB) in kg.data_graph()


def test_shapes_carry_over_a_commit_that_leaves_them_alone(kg: KnowledgeGraph) -> None:
    from nfex_core.kg.validation import extract_shapes

    before = kg.shapes()
    kg.add(parse_rdf(CONFIG), author="a")
    assert kg.shapes() is before and kg.shapes().nodes == extract_shapes(kg.backend).nodes
    shape = P + "@prefix sh: <http://www.w3.org/ns/shacl#> . nfex:TestShape a sh:NodeShape ; sh:targetClass nfex:Nothing ."
    kg.add(parse_rdf(shape), author="a")
    after = kg.shapes()
    assert after is not before and NFEX.TestShape in after.nodes and after.nodes == extract_shapes(kg.backend).nodes


SPARQL_P = "PREFIX nfex: <https://w3id.org/nfex#> PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#> "
VOCAB_EDITS = [
    # what the vocabulary reads: each must reload it
    "DELETE DATA { nfex:ORB_nfeatures nfex:maxValue 20000 } ; INSERT DATA { nfex:ORB_nfeatures nfex:maxValue 9000 }",
    'INSERT DATA { nfex:ORB rdfs:label "ORB (edited)"@en }',
    'INSERT DATA { nfex:light_dusk a nfex:ConditionValue ; nfex:inDimension nfex:light ; nfex:token "dusk" ; nfex:ordinal 2 ; '
    'rdfs:label "dusk"@en }',
    # what it does not read: each carries it
    "INSERT DATA { nfex:ORB rdfs:seeAlso <https://example.org/orb> }",
    "INSERT DATA { <STATEMENT> nfex:enabled false }",
]


@pytest.mark.parametrize("edits", [VOCAB_EDITS, list(reversed(VOCAB_EDITS))])
def test_the_vocabulary_carries_over_a_change_it_does_not_read(kg: KnowledgeGraph, edits: list[str]) -> None:
    """A carried vocabulary (the change missed its queries' footprint) equals one loaded afresh, edit after edit."""
    import dataclasses

    from nfex_core.kg.vocab import Vocabulary

    statement = str(kg.select("SELECT ?s WHERE { ?s nfex:inProgram ?p } ORDER BY ?s").rows[0]["s"])
    for edit in edits:
        before = kg.vocabulary()
        kg.update(SPARQL_P + edit.replace("STATEMENT", statement), author="a")
        after = kg.vocabulary()
        fresh = Vocabulary.load(kg)
        assert dataclasses.replace(after, version=0) == dataclasses.replace(fresh, version=0), edit
        assert (after is before) == ("seeAlso" in edit or "enabled" in edit), edit
