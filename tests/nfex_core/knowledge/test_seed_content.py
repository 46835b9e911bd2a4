"""The seed is computed once per content: a cache named by a digest of the files and the code."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from nfex_core.config import Settings
from nfex_core.kg.changes import graph_triples
from nfex_core.knowledge import seed_graph
from nfex_core.knowledge.seed_content import KEEP, digest, seed_content


def settings_in(tmp_path: Path) -> Settings:
    real = Settings.from_env()
    home = tmp_path / "home"
    shutil.copytree(real.ontology_dir, home / "ontology")
    shutil.copytree(real.rules_dir, home / "rules")
    return real.replace(home=home, seed_cache=tmp_path / "cache")


def test_the_cache_gives_back_the_computed_seed(tmp_path: Path) -> None:
    settings = settings_in(tmp_path)
    first = seed_content(settings, seed_graph)
    assert not first.cached and [p.name for p in settings.seed_cache.iterdir()] == [f"{first.digest}.nt"]
    again = seed_content(settings, seed_graph)
    assert again.cached and again.lines == first.lines
    assert again.triples() == first.triples() == graph_triples(seed_graph(settings))


def test_an_edited_file_is_another_seed(tmp_path: Path) -> None:
    settings = settings_in(tmp_path)
    before = digest(settings)
    metrics = settings.ontology_dir / "metrics.ttl"
    metrics.write_text(metrics.read_text().replace('"texturedness"@en', '"texture variance"@en'))
    assert digest(settings) != before


def test_a_cache_that_cannot_be_written_costs_only_time(tmp_path: Path) -> None:
    settings = settings_in(tmp_path).replace(seed_cache=tmp_path / "a-file" / "seed")
    (tmp_path / "a-file").write_text("not a folder")
    content = seed_content(settings, seed_graph)
    assert not content.cached and content.triples() == graph_triples(seed_graph(settings))


def test_a_relative_iri_ties_the_seed_to_the_working_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    settings = settings_in(tmp_path)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    monkeypatch.chdir(tmp_path / "a")
    here = digest(settings)
    monkeypatch.chdir(tmp_path / "b")
    assert digest(settings) == here  # the shipped files name every IRI in full
    (settings.ontology_dir / "local.ttl").write_text("<note> <http://www.w3.org/2000/01/rdf-schema#label> \"x\" .\n")
    there = digest(settings)
    monkeypatch.chdir(tmp_path / "a")
    assert digest(settings) != there


def test_the_same_files_elsewhere_are_the_same_seed(tmp_path: Path) -> None:
    """A copy of the home in another folder (each test session makes one) reads the same cached seed."""
    here = settings_in(tmp_path / "here")
    there = settings_in(tmp_path / "there")
    assert digest(here) == digest(there)


def test_the_cache_keeps_the_most_recently_used_seeds(tmp_path: Path) -> None:
    settings = settings_in(tmp_path)
    settings.seed_cache.mkdir()
    for i in range(KEEP + 2):
        (settings.seed_cache / f"old{i}.nt").write_text("")
    first = seed_content(settings, seed_graph)
    kept = sorted(p.name for p in settings.seed_cache.iterdir())
    assert len(kept) == KEEP and f"{first.digest}.nt" in kept


def test_round_trips_checks_every_term() -> None:
    from rdflib import Literal, URIRef
    from rdflib.namespace import XSD

    from nfex_core.knowledge.seed_content import PROBE, round_trips

    fine = {URIRef("https://w3id.org/nfex#ORB"), Literal("a\nb \"q\""), Literal("x", lang="en"), Literal("1.5", datatype=XSD.decimal), PROBE}
    assert round_trips(fine)
    assert not round_trips(fine | {URIRef("https://example.org/a b")})  # not an IRI N-Triples can write
    assert not round_trips(fine | {URIRef("relative")})
    assert not round_trips(fine | {Literal("x", datatype=URIRef("relative"))})


def test_a_seed_that_does_not_round_trip_is_not_cached(tmp_path: Path) -> None:
    from rdflib import RDFS, Literal, URIRef

    settings = settings_in(tmp_path)
    odd = (URIRef("https://example.org/a b"), RDFS.label, Literal("x"))  # a source built by code, not parsed
    content = seed_content(settings, lambda s: seed_graph(s) | {odd})
    assert not content.cached and not settings.seed_cache.exists()
    assert odd in content.triples() and content.triples() == graph_triples(seed_graph(settings) | {odd})
    assert not seed_content(settings, seed_graph).cached
