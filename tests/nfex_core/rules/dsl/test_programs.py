"""Applying a program is one versioned transaction; the very next selection follows it; rollback undoes it."""
from __future__ import annotations

from pathlib import Path

import pytest

from nfex_core.advisor import Advisor
from nfex_core.config import REPO_ROOT
from nfex_core.errors import NotFound, ValidationFailed
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.changes import ChangeSet, graph_triples
from nfex_core.kg.namespaces import NFEX
from nfex_core.kg.vocab import Vocabulary
from nfex_core.rules.dsl import programs
from nfex_core.rules.dsl.parser import parse_file

DEFAULT = REPO_ROOT / "rules" / "programs" / "default.nfex"


def _apply(kg: KnowledgeGraph, text: str, name: str = "site") -> int:
    _, graph = programs.compile_text(text, kg.vocabulary(), name=name, source=f"{name}.nfex")
    return programs.apply(kg, graph, name, author="test").version


def test_the_seeded_default_program_reads_back_as_its_file(kg: KnowledgeGraph) -> None:
    assert programs.show(kg, "default") == parse_file(DEFAULT)
    [info] = [p for p in programs.programs(kg) if p.name == "default"]
    assert info.source == "rules/programs/default.nfex" and info.statements == len(parse_file(DEFAULT).statements)


def test_a_program_changes_the_next_selection_with_its_statement_cited_and_rollback_restores(kg: KnowledgeGraph) -> None:
    advisor = Advisor(kg, neural="symbolic")
    # indoor: the shipped measurements (ontology/measurements/, KITTI) are outdoor and would add evidence
    ctx = {"light": "bright", "texture": "high", "scene": "indoor"}
    before = advisor.select(ctx)
    assert before.extractor == "ORB"  # default program: prefer ORB in bright, well-textured scenes
    v0 = kg.version

    _apply(kg, 'program site\nprune ORB when scene is indoor and light is bright because "site survey: glare on the lens"\n'
               "adjust AKAZE.threshold by 0.5 when scene is indoor")
    after = advisor.select(ctx)
    assert after.versions["graph"] == v0 + 1
    assert after.extractor != "ORB" and "ORB" not in {c.extractor for c in after.candidates}
    [pruned] = [p for p in after.pruned if p.extractor == "ORB"]
    [cite] = pruned.because
    assert cite.rule.startswith(str(NFEX) + "statement_site_") and cite.kind == "prune"
    assert cite.label == "prune ORB when scene is indoor and light is bright"
    assert cite.reason == "site survey: glare on the lens" and cite.source == "site.nfex:2"
    akaze = next(c for c in after.candidates if c.extractor == "AKAZE")
    assert akaze.params["threshold"] == pytest.approx(0.0005)
    assert after.versions["programs"]["site"] == 2

    kg.rollback(v0, author="test")
    again = advisor.select(ctx)
    assert again.extractor == before.extractor == "ORB" and again.params == before.params
    assert not any(p.extractor == "ORB" for p in again.pruned) and "site" not in again.versions["programs"]


def test_applying_replaces_the_programs_previous_statements(kg: KnowledgeGraph) -> None:
    _apply(kg, "program site\nprune BRISK when light is dark\nweight motion 2.0")
    keep = set(kg.select("SELECT ?s WHERE { ?s nfex:prunes nfex:BRISK }").rows[0].values())
    v = kg.version
    _apply(kg, "program site\nprune BRISK when light is dark\nweight motion 3.0\nprefer SIFT by 0.5")
    assert kg.version == v + 1
    assert programs.show(kg, "site").statements[1].value == 3.0
    assert len(programs.show(kg, "site").statements) == 3
    assert set(kg.select("SELECT ?s WHERE { ?s nfex:prunes nfex:BRISK }").rows[0].values()) == keep  # unchanged IRI
    assert kg.select('SELECT ?w WHERE { ?s nfex:metric/nfex:token "motion" ; nfex:weight ?w ; nfex:inProgram nfex:program_site }').rows[0]["w"].toPython() == 3.0
    # the same program again is no new version
    _apply(kg, "program site\nprune BRISK when light is dark\nweight motion 3.0\nprefer SIFT by 0.5")
    assert kg.version == v + 1
    programs.remove(kg, "site", author="test")
    with pytest.raises(NotFound):
        programs.show(kg, "site")
    assert programs.show(kg, "default").statements  # other programs untouched


def test_shacl_rejects_a_statement_without_its_program(kg: KnowledgeGraph) -> None:
    _, graph = programs.compile_text("program site\nprune BRISK", kg.vocabulary(), name="site")
    v = kg.version
    stmt_only = {t for t in graph_triples(graph) if t[0] != programs.program_iri("site")}
    with pytest.raises(ValidationFailed, match="StatementShape"):
        kg.commit(ChangeSet.adding(stmt_only), author="test")
    assert kg.version == v


def test_seeding_stops_on_a_program_with_an_unknown_name(tmp_path: Path) -> None:
    import shutil

    from nfex_core.config import Settings
    from nfex_core.errors import UnknownName
    from nfex_core.knowledge import seed_graph

    home = tmp_path / "home"
    shutil.copytree(REPO_ROOT / "ontology", home / "ontology")
    shutil.copytree(REPO_ROOT / "rules", home / "rules")
    (home / "rules" / "programs" / "typo.nfex").write_text("prune ORB when light is dim\n")
    s = Settings.from_env()
    with pytest.raises(UnknownName, match=r"typo.nfex:1:25: unknown value of light 'dim'; known: bright, dark"):
        seed_graph(Settings(store=s.store, home=home, data=s.data, models=s.models))


def test_a_program_pruning_xfeat_for_drones_applies(kg: KnowledgeGraph) -> None:
    """`prune XFEAT when agent is drone` compiles to the graph and the rule table prunes it, citing the line."""
    from nfex_core.rules.engine import RuleEngine

    _apply(kg, 'program learned\nprune XFEAT when agent is drone because "no accelerator on board"\n')
    table = RuleEngine(kg).table()
    drone = table.decide({"agent": "drone"})
    assert "XFEAT" not in drone.candidates
    assert any(c.reason == "no accelerator on board" for c in drone.pruned["XFEAT"])
    assert all(c.reason != "no accelerator on board" for c in table.decide({"agent": "car"}).pruned.get("XFEAT", ()))


def test_check_text_lists_every_problem_without_raising(vocab: Vocabulary) -> None:
    from nfex_core.errors import ParseError, UnknownName
    from nfex_core.rules.dsl.programs import check_text

    program, found = check_text("prune ORB when light is drak\nadjust ORB.nfeaturs by 2\n", vocab, name="t")
    assert program is not None and [type(e) for e in found] == [UnknownName, UnknownName]
    assert [(e.extra["line"], e.extra["column"]) for e in found] == [(1, 25), (2, 12)]  # at the value, at the parameter after "ORB."
    assert "dark" in found[0].extra["allowed"]
    program, found = check_text("prune ORB when light\n", vocab, name="t")
    assert program is None and len(found) == 1 and isinstance(found[0], ParseError) and found[0].line == 2  # at the end
    program, found = check_text("prune ORB when light is dark\n", vocab, name="t")
    assert program is not None and found == [] and len(program.statements) == 1
