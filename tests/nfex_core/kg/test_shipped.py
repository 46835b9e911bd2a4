"""The shipped files are read by Oxigraph's parser (kg/shipped.py): the same graph rdflib's parser gives."""
from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import pytest
import rdflib

from nfex_core.config import Settings
from nfex_core.errors import DataMissing, ParseError
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.changes import graph_triples, read_turtle_triples
from nfex_core.kg.shipped import ontology_files, ontology_graph, ontology_vocabulary, shapes_graph
from nfex_core.kg.vocab import Vocabulary


def rdflib_parse(paths: list[Path]) -> rdflib.Graph:
    g = rdflib.Graph()
    for path in paths:
        g.parse(data=path.read_bytes(), format="turtle")
    return g


def test_both_parsers_give_the_shipped_files_the_same_triples() -> None:
    settings = Settings.from_env()
    assert graph_triples(ontology_graph(settings)) == graph_triples(rdflib_parse(ontology_files(settings)))
    shapes = sorted((settings.rules_dir / "shapes").rglob("*.ttl"))
    assert graph_triples(shapes_graph(settings)) == graph_triples(rdflib_parse(shapes))


def test_a_relative_iri_resolves_as_rdflib_resolves_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "local.ttl"
    path.write_text('<note> <http://www.w3.org/2000/01/rdf-schema#label> "x" ; <#p> [ <#q> 1.0, 2e0, "01"^^<http://www.w3.org/2001/XMLSchema#integer> ] .\n')
    monkeypatch.chdir(tmp_path)
    ours = graph_triples(read_turtle_triples(path))
    assert (rdflib.URIRef(tmp_path.as_uri() + "/note"), rdflib.RDFS.label, rdflib.Literal("x")) in ours
    assert ours == graph_triples(rdflib_parse([path]))


def test_a_syntax_error_names_the_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.ttl"
    path.write_text('@prefix a: <http://x/> .\na:b a:c a:d .\na:b a:c "unterminated\n')
    with pytest.raises(ParseError, match="bad.ttl: not valid turtle") as e:
        read_turtle_triples(path)
    assert e.value.line == 3


def test_the_ontology_vocabulary_is_the_seeded_stores(kg: KnowledgeGraph) -> None:
    """The programs are checked against a vocabulary read from the files, blank nodes unskolemised."""
    ours = ontology_vocabulary(kg.settings)
    assert dataclasses.replace(ours, version=0) == dataclasses.replace(Vocabulary.load(kg), version=0)


def test_a_home_without_an_ontology_is_told_so(tmp_path: Path) -> None:
    real = Settings.from_env()
    home = tmp_path / "home"
    shutil.copytree(real.rules_dir, home / "rules")
    with pytest.raises(DataMissing, match="no ontology to seed from"):
        ontology_vocabulary(real.replace(home=home))


def test_a_blank_node_label_in_two_files_is_two_nodes(tmp_path: Path) -> None:
    """Regression: Oxigraph keeps `_:a` as written unless told to rename; rdflib makes each file's its own."""
    one, two = tmp_path / "one.ttl", tmp_path / "two.ttl"
    one.write_text('_:a <https://example.org/p> "one" .\n')
    two.write_text('_:a <https://example.org/p> "two" .\n')
    from nfex_core.kg.shipped import turtle_triples

    ours = graph_triples(turtle_triples([one, two]))
    assert len({s for s, _, _ in ours}) == 2
    assert ours == graph_triples(rdflib_parse([one, two]))
