"""Programs in the knowledge graph: check, apply (one versioned, SHACL-checked transaction), read back.

Applying a program replaces that program's previous statements: the commit removes the triples of
the old version of the program that the new one does not have and adds the new ones, so statements
that did not change keep their IRIs and the graph version records exactly what changed.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import rdflib

from ...config import Settings
from ...errors import NfexError, ParseError
from ...kg.changes import ChangeSet, graph_triples
from ...kg.identity import program_iri
from ...kg.namespaces import NFEX
from ...kg.shipped import ontology_vocabulary
from ...kg.terms import n3
from ...kg.vocab import Vocabulary
from ..shape_text import shape_graph
from .check import check, problems
from .compiler import compile_program, decompile
from .parser import Program, parse, parse_file

if TYPE_CHECKING:
    from ...kg.store import CommitResult, KnowledgeGraph


@dataclass(frozen=True)
class ProgramInfo:
    name: str
    iri: str
    statements: int
    source: str | None


def source_name(path: Path, settings: Settings) -> str:
    """``path`` relative to the repository when it lies inside it (what nfex:sourceFile records)."""
    try:
        return str(path.resolve().relative_to(settings.home.resolve()))
    except ValueError:
        return str(path)


def load(path: Path, vocab: Vocabulary, settings: Settings | None = None) -> tuple[Program, rdflib.Graph]:
    """Parse, check and compile a ``.nfex`` file; raises ParseError / UnknownName / ParameterError."""
    source = source_name(path, settings or Settings.from_env())
    program = check(parse_file(path, source=source), vocab)
    return program, compile_program(program, vocab, source_file=source)


def compile_text(text: str, vocab: Vocabulary, *, name: str, source: str | None = None) -> tuple[Program, rdflib.Graph]:
    program = check(parse(text, name=name, source=source), vocab)
    return program, compile_program(program, vocab, source_file=source)


def program_graph(kg: KnowledgeGraph, name: str) -> rdflib.Graph:
    """Every triple of the program ``name`` in the graph: the program node, its statements, their atoms and pair tests."""
    p = n3(program_iri(name))
    g = kg.construct(
        f"""CONSTRUCT {{ ?s ?p ?o }} WHERE {{
            {{ BIND ({p} AS ?s) ?s ?p ?o }}
            UNION {{ ?s nfex:inProgram {p} ; ?p ?o }}
            UNION {{ ?st nfex:inProgram {p} ; nfex:hasCondition ?s . ?s ?p ?o }}
            UNION {{ ?st nfex:inProgram {p} ; nfex:hasTest ?s . ?s ?p ?o }}
        }}"""
    )
    g += shape_graph(kg, set(g.objects(None, NFEX.shape)))  # the SHACL shapes of its require statements
    return g


def change_of(kg: KnowledgeGraph, graph: rdflib.Graph, name: str) -> ChangeSet:
    """The change that replaces program ``name`` in the graph by ``graph`` (its compiled triples)."""
    old = graph_triples(program_graph(kg, name))
    new = graph_triples(graph)
    return ChangeSet.of(added=new - old, removed=old - new)


def apply(kg: KnowledgeGraph, graph: rdflib.Graph, name: str, *, author: str, message: str = "", expected_version: int | None = None) -> CommitResult:
    """Replace program ``name`` in the graph by ``graph`` (its compiled triples) as one transaction."""
    change = change_of(kg, graph, name)
    return kg.commit(change, author=author, message=message or f"apply program {name}", expected_version=expected_version)


def check_text(text: str, vocab: Vocabulary, *, name: str, source: str | None = None) -> tuple[Program | None, list[NfexError]]:
    """Parse and check ``text`` without raising: (the program or None on a syntax error, every problem).

    A syntax error stops parsing, so it is the only problem reported; otherwise every unknown name and
    number out of range is listed in source order, each with its line and column (``problems``)."""
    try:
        program = parse(text, name=name, source=source)
    except ParseError as e:
        return None, [e]
    return program, problems(program, vocab)


def remove(kg: KnowledgeGraph, name: str, *, author: str, message: str = "") -> CommitResult:
    """Remove program ``name`` and all its statements as one transaction."""
    old = graph_triples(program_graph(kg, name))
    return kg.commit(ChangeSet.removing(old), author=author, message=message or f"remove program {name}")


def show(kg: KnowledgeGraph, name: str) -> Program:
    """The program ``name`` as the graph holds it (NotFound when there is none)."""
    return decompile(program_graph(kg, name), name, kg.vocabulary())


def programs(kg: KnowledgeGraph) -> list[ProgramInfo]:
    rows = kg.select(
        """SELECT ?p ?name ?file (COUNT(?s) AS ?n) WHERE {
            ?p a nfex:Program ; rdfs:label ?name .
            OPTIONAL { ?p nfex:sourceFile ?file } OPTIONAL { ?s nfex:inProgram ?p }
        } GROUP BY ?p ?name ?file ORDER BY ?name"""
    ).rows
    return [
        ProgramInfo(str(r["name"]), str(r["p"]), int(str(r["n"])), str(r["file"]) if "file" in r else None)
        for r in rows
    ]


def programs_graph(settings: Settings) -> rdflib.Graph:
    """Seed source: rules/programs/*.nfex, checked against the vocabulary of the ontology being seeded (so
    a program with a typo stops ``nfex kg seed`` with its line and column) and compiled to statements."""
    g = rdflib.Graph()
    paths = sorted((settings.rules_dir / "programs").glob("*.nfex"))
    if not paths:
        return g
    vocab = ontology_vocabulary(settings)
    for path in paths:
        g += load(path, vocab, settings)[1]
    return g
