"""Programs compile to triples in the statement vocabulary and read back to the same program."""
from __future__ import annotations

import rdflib
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rdflib.namespace import RDF

from nfex_core.kg.namespaces import NFEX
from nfex_core.kg.vocab import Vocabulary
from nfex_core.rules.dsl.check import check
from nfex_core.rules.dsl.compiler import compile_program, decompile, program_iri
from nfex_core.rules.dsl.parser import Atom, Program, Statement, parse, render

REASON = st.text(st.characters(blacklist_categories=("Cs", "Cc")) | st.sampled_from('"\\\n\t'), max_size=30)
NAME = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,12}", fullmatch=True)


def atoms(vocab: Vocabulary) -> st.SearchStrategy[Atom]:
    def for_dim(dim: str) -> st.SearchStrategy[Atom]:
        values = st.lists(st.sampled_from(sorted(vocab.dimensions[dim].values)), min_size=1, unique=True)
        return st.builds(lambda vs, neg: Atom(dim, tuple(sorted(vs)), neg), values, st.booleans())

    return st.sampled_from(sorted(vocab.dimensions)).flatmap(for_dim)


def statements(vocab: Vocabulary) -> st.SearchStrategy[Statement]:
    xs = sorted(vocab.extractors)
    tunable = sorted((p.extractor, p.name) for x in vocab.extractors.values() for p in x.parameters.values() if p.tunable and p.datatype != "boolean")
    bounded = [p for x in vocab.extractors.values() for p in x.parameters.values() if p.datatype == "boolean" or (p.min is not None and p.max is not None and p.allowed is None)]
    common = {"when": st.lists(atoms(vocab), max_size=3).map(tuple), "reason": st.none() | REASON}
    positive = st.floats(min_value=1e-3, max_value=1e3, allow_nan=False)

    def require(p):  # type: ignore[no-untyped-def]
        if p.datatype == "boolean":
            return st.builds(Statement, st.just("require"), extractor=st.just(p.extractor), parameter=st.just(p.name), comparator=st.just("="), value=st.booleans(), **common)
        values = st.integers(int(p.min), int(p.max)) if p.datatype == "integer" else st.floats(float(p.min), float(p.max))
        return st.builds(Statement, st.just("require"), extractor=st.just(p.extractor), parameter=st.just(p.name),
                         comparator=st.sampled_from(["<=", "<", ">=", ">", "="]), value=values, **common)

    return st.one_of(
        st.builds(Statement, st.just("prune"), extractor=st.sampled_from(xs), **common),
        st.sampled_from(tunable).flatmap(
            lambda xp: st.builds(Statement, st.just("adjust"), extractor=st.just(xp[0]), parameter=st.just(xp[1]), value=positive, **common)
        ),
        st.builds(Statement, st.just("weight"), metric=st.sampled_from(sorted(vocab.metrics)), value=st.floats(0, 100), **common),
        st.builds(Statement, st.just("prefer"), extractor=st.sampled_from(xs), value=st.floats(-10, 10), **common),
        st.sampled_from(bounded).flatmap(require),
    )


def programs(vocab: Vocabulary) -> st.SearchStrategy[Program]:
    return st.builds(Program, NAME, st.lists(statements(vocab), max_size=8).map(tuple))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_round_trip_parse_compile_decompile_parse(vocab: Vocabulary, data: st.DataObject) -> None:
    program = data.draw(programs(vocab))
    text = render(program)
    parsed = check(parse(text), vocab)
    assert parsed == program
    graph = compile_program(parsed, vocab, source_file="x.nfex")
    back = decompile(graph, program.name, vocab)
    assert back == program
    assert parse(render(back)) == program
    assert render(back) == text


def test_triples_in_the_statement_vocabulary(vocab: Vocabulary) -> None:
    p = parse('program t\nprune SIFT when agent is car and motion is not one of (slow) because "why"\n'
              "adjust ORB.nfeatures by 1.6 when light is dark\nrequire ORB.fastThreshold <= 10")
    g = compile_program(p, vocab, source_file="rules/programs/t.nfex")
    prog = program_iri("t")
    assert (prog, RDF.type, NFEX.Program) in g
    prune = next(g.subjects(NFEX.prunes, NFEX.SIFT))
    assert (prune, RDF.type, NFEX.PruneStatement) in g and (prune, NFEX.inProgram, prog) in g
    assert str(g.value(prune, NFEX.reason)) == "why" and g.value(prune, NFEX.line).toPython() == 2
    conds = {str(g.value(a, NFEX.dimension)).rsplit("#")[-1]: a for a in g.objects(prune, NFEX.hasCondition)}
    assert set(g.objects(conds["agent"], NFEX.oneOf)) == {NFEX.agent_car}
    assert g.value(conds["motion"], NFEX.negated).toPython() is True
    adjust = next(g.subjects(NFEX.parameter, NFEX.ORB_nfeatures))
    assert g.value(adjust, NFEX.factor) == rdflib.Literal(1.6, datatype=rdflib.XSD.double)
    require = next(g.subjects(RDF.type, NFEX.RequireStatement))
    assert g.value(require, NFEX.bound) == rdflib.Literal(10, datatype=rdflib.XSD.integer)
    assert str(g.value(require, NFEX.comparator)) == "<=" and (g.value(require, NFEX.shape), RDF.type, NFEX.ContextShape) in g


def test_statement_iris_are_stable_under_edits(vocab: Vocabulary) -> None:
    a = compile_program(parse("program t\nprune SIFT when agent is car\nweight motion 2"), vocab)
    b = compile_program(parse("program t\nprune BRISK\nprune SIFT when agent is car\nweight motion 2"), vocab)
    assert set(a.subjects(NFEX.prunes, NFEX.SIFT)) == set(b.subjects(NFEX.prunes, NFEX.SIFT))
    dup = compile_program(parse("program t\nprune SIFT\nprune SIFT"), vocab)
    assert len(set(dup.subjects(NFEX.prunes, NFEX.SIFT))) == 2
