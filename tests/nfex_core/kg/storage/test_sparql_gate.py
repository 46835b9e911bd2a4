"""The SPARQL gate (kg/storage/sparql_gate.py): forbidden operations found wherever the parse holds them and nowhere
else, the depth bound, and agreement with Oxigraph on generated spellings."""
from __future__ import annotations

import glob
import socket
from collections.abc import Callable, Iterator
from pathlib import Path

import pyoxigraph as ox
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from rdflib import Literal, URIRef
from rdflib.namespace import SH

from nfex_core.errors import BadInput, ParseError
from nfex_core.kg.rdf.namespaces import NFEX
from nfex_core.kg.storage.changes import ChangeSet
from nfex_core.kg.storage.sparql_gate import (
    MAX_CHARS,
    MAX_DEPTH,
    ForbiddenOperation,
    TooComplex,
    TooLarge,
    gate_change,
    gate_query,
    gate_update,
)

ROOT = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def closed_port() -> Iterator[int]:
    """A loopback port bound but not listening: a fetch there is refused at once, and seen."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    yield s.getsockname()[1]
    s.close()


@pytest.mark.parametrize("text,found", [
    ("LOAD <http://x>", ["LOAD"]),
    ("load<http://x>", ["LOAD"]),
    ("INSERT DATA { <a:a> <a:b> <a:c> } ;\nCLEAR ALL", ["CLEAR"]),
    ("DROP SILENT GRAPH <a:x> ; copy default to <a:y>", ["DROP", "COPY"]),
    ("INSERT { ?s ?p ?o } WHERE { SERVICE <http://x> { ?s ?p ?o } }", ["SERVICE"]),
    ("ADD <a:a> TO <a:b> ; MOVE <a:a> TO <a:b> ; CREATE GRAPH <a:c>", ["CREATE", "ADD", "MOVE"]),
    ("PREFIX ex: <http://e/> INSERT DATA { ex:a\\# ex:b ex:c } ; LOAD <http://127.0.0.1:1/x.nt>", ["LOAD"]),
    ('INSERT DATA { <a:a> <a:b> "LOAD <x>" }', []),
    ('INSERT DATA { <a:a> <a:b> """x " LOAD""" }', []),
    ("INSERT DATA { <a:a> <a:b> 'CLEAR' }", []),
    ("# LOAD\nINSERT DATA { <a:a> <a:b> <a:c> }", []),
    ("PREFIX ex: <http://e/> INSERT DATA { ex:LOAD ex:CLEAR ex:DROP }", []),
    ("PREFIX load: <http://e/> INSERT DATA { load:x load:y load: }", []),
    ("INSERT { ?s a <http://e/LOAD> } WHERE { ?s ?p ?o }", []),
    ("DELETE WHERE { ?s ?p ?o }", []),
])
def test_forbidden_operations_are_found_where_the_parse_holds_them(text: str, found: list[str]) -> None:
    if found:
        with pytest.raises(ForbiddenOperation) as e:
            gate_update(text)
        assert e.value.status == 403 and e.value.extra["operations"] == found
    else:
        assert gate_update(text).form == "update"


def test_the_walk_around_through_a_local_name_escape_is_refused() -> None:
    text = ("PREFIX ex: <http://e/> SELECT * WHERE { OPTIONAL { ?s ex:a\\# ?o } "
            "SERVICE <http://127.0.0.1:1/sparql> { ?x ?y ?z } }")
    with pytest.raises(ForbiddenOperation, match="SERVICE"):
        gate_query(text)
    assert gate_query("PREFIX ex: <http://e/> SELECT * WHERE { ?s ex:a\\# ?o }").form == "select"


def test_forms_and_kinds() -> None:
    assert gate_query("ASK { ?s ?p ?o }").form == "ask"
    assert gate_query("# a comment\nDESCRIBE <a:b>").form == "describe"
    assert gate_query("CONSTRUCT WHERE { ?s ?p ?o }").form == "construct"
    with pytest.raises(BadInput, match="SPARQL Update"):
        gate_query("INSERT DATA { <a:a> <a:b> <a:c> }")
    with pytest.raises(BadInput, match="not an update"):
        gate_update("SELECT * { ?s ?p ?o }")
    with pytest.raises(ParseError) as e:
        gate_query("SELECT * WHERE {\n  ?s ?p ?o FILTER(?o > ) }")
    assert e.value.extra["line"] == 2
    with pytest.raises(BadInput, match="empty"):
        gate_query("  ")
    with pytest.raises(BadInput, match="surrogate"):
        gate_query("SELECT * { ?s ?p '\ud800' }")


@pytest.mark.parametrize("text", [
    "SELECT * WHERE " + "{" * 3000 + "?s ?p ?o" + "}" * 3000,
    "SELECT * WHERE { ?s ?p ?a FILTER(" + "(" * 10_000 + "?a" + ")" * 10_000 + ") }",
    "SELECT * WHERE { ?s ?p ?a FILTER(" + "+".join(["?a"] * 2000) + " > 0) }",
    "SELECT * WHERE { ?s ?p ?a FILTER(" + "||".join(["?a = 1"] * 2000) + ") }",
    "SELECT * WHERE { " + " UNION ".join(["{ ?s ?p ?o }"] * 2000) + " }",
    "SELECT * WHERE { " + " ".join(["{ ?s ?p ?o }"] * 2000) + " }",
    "SELECT * WHERE { ?s " + "/".join(["<http://e/p>"] * 2000) + " ?o }",
])
def test_deep_or_long_chained_text_is_too_complex(text: str) -> None:
    with pytest.raises(TooComplex) as e:
        gate_query(text)
    assert e.value.status == 400


def test_what_oxigraph_alone_would_read_is_refused() -> None:
    with pytest.raises(ParseError):  # '!' takes a primary expression (SPARQL 1.1 §19.8): Oxigraph nests them anyway
        gate_query("SELECT * WHERE { ?s ?p ?a FILTER(" + "!" * 2000 + "?a) }")
    with pytest.raises(ParseError):  # code-point escapes outside strings: the grammar has none
        gate_query("SELECT * WHERE { \\u0053ERVICE <http://127.0.0.1:1/> { ?s ?p ?o } }")


def test_flat_lists_do_not_count_as_depth() -> None:
    triples = " . ".join(f"?s <http://e/p{i}> ?o{i}" for i in range(2000))
    assert gate_query(f"SELECT * WHERE {{ {triples} }}").depth < 50
    values = " ".join(str(i) for i in range(5000))
    assert gate_query(f"SELECT * WHERE {{ VALUES ?x {{ {values} }} }}").depth < 50
    data = " ".join(f"<a:s{i}> <a:p> {i} ." for i in range(5000))
    assert gate_update(f"INSERT DATA {{ {data} }}").depth < 50


def test_a_text_past_the_length_limit_is_refused_before_parsing() -> None:
    with pytest.raises(TooLarge) as e:
        gate_query("SELECT * WHERE { ?s ?p ?o } #" + "x" * MAX_CHARS)
    assert e.value.status == 413


def test_every_shipped_rule_passes_the_gate_well_within_its_bound() -> None:
    rules = sorted(glob.glob(str(ROOT / "rules" / "**" / "*.rq"), recursive=True))
    assert rules
    for path in rules:
        assert gate_query(Path(path).read_text()).depth < MAX_DEPTH // 4, path


def test_stored_sparql_is_checked_on_commit() -> None:
    rule = ChangeSet.adding([(NFEX.rule_x, NFEX.query, Literal("SELECT * { SERVICE <http://x> { } }"))])
    with pytest.raises(ForbiddenOperation):
        gate_change(rule.added)
    hidden = ChangeSet.adding([(NFEX.rule_x, NFEX.query, Literal(
        "PREFIX ex: <http://e/> SELECT ?extractor ?reason { ?extractor ex:a\\# ?reason SERVICE <http://x> { } }"))])
    with pytest.raises(ForbiddenOperation):
        gate_change(hidden.added)
    shape = ChangeSet.adding([(URIRef("urn:c"), SH.update, Literal("INSERT DATA { <a:a> <a:b> 1 } ; LOAD <http://x>"))])
    with pytest.raises(ForbiddenOperation):
        gate_change(shape.added)
    gate_change(ChangeSet.adding([(NFEX.ORB, NFEX.query, Literal("SELECT ?extractor ?reason { }"))]).added)


# -- the gate and Oxigraph agree on what a text is ------------------------------------------------------------
# Texts are built from a forbidden operation and fragments that confuse a lexical reading (local-name escapes,
# comments, strings with escaped quotes, IRIs with '#', prefixed names and variables that spell a keyword),
# in any case. Oxigraph runs each on an empty in-memory store whose fetches go to a closed loopback port, so
# whether it evaluated SERVICE or LOAD shows as a refused connection.
HIDERS = ["ex:a\\#", "ex:a\\'", "ex:a\\.b", "ex:b", '"x \\" # y"', "'it\\'s # x'", '"""a " # b"""', "<http://e/#x>",
          "ex:SERVICE", "?service", "ex:LOAD", "'SERVICE <http://127.0.0.1:1/> { }'"]
HIDDEN = ["", "#", "# {", "\n", "'", '"', "\\#"]


def _case(word: str, mask: int) -> str:
    return "".join(c.lower() if mask >> i & 1 else c for i, c in enumerate(word))


@st.composite
def spellings(draw: st.DrawFn, port: int) -> str:
    hider = draw(st.sampled_from(HIDERS))
    before = draw(st.sampled_from(HIDDEN))
    keyword = _case("SERVICE", draw(st.integers(0, 127)))
    service = draw(st.booleans())
    body = f"{keyword} <http://127.0.0.1:{port}/sparql> {{ ?x ?y ?z }}" if service else "?x ?y ?z"
    return f"PREFIX ex: <http://e/>\nSELECT * WHERE {{ ?s ?p {hider} {before} {body} }}"


def _matched_store() -> ox.Store:
    """A store in which ``?s ?p <hider>`` matches every hider, so that no join is cut short before SERVICE."""
    store = ox.Store()
    objects = [ox.NamedNode(f"http://e/{x}") for x in ("a#", "a'", "a.b", "b", "#x", "SERVICE", "LOAD")]
    objects += [ox.Literal(x) for x in ('x " # y', "it's # x", 'a " # b', "SERVICE <http://127.0.0.1:1/> { }")]
    for o in objects:
        store.add(ox.Quad(ox.NamedNode("urn:s"), ox.NamedNode("urn:p"), o))
    return store


def _effect(run: Callable[[], bool]) -> bool | None:
    """What Oxigraph did with a text: True, it fetched (or wiped, as ``run`` says); False, it ran harmlessly;
    None, it could not parse the text."""
    try:
        return run()
    except SyntaxError:
        return None
    except ConnectionRefusedError:
        return True
    except OSError as e:
        return "refused" in str(e).lower() or None


def _agrees(gate: Callable[[str], object], text: str, effect: bool | None) -> None:
    """The gate refuses as forbidden only what Oxigraph would run with an effect, and lets through only what
    Oxigraph runs without one (a text refused as unparsable reaches no store either way)."""
    try:
        gate(text)
    except ForbiddenOperation:
        assert effect is not False, f"the gate calls forbidden what Oxigraph runs harmlessly: {text!r}"
    except BadInput:
        pass
    else:
        assert effect is False, f"the gate let through what Oxigraph {'fetches or wipes' if effect else 'cannot parse'}: {text!r}"


def _query_fetches(text: str) -> bool:
    result = _matched_store().query(text)
    if isinstance(result, ox.QuerySolutions):
        list(result)
    return False


@settings(max_examples=300, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
@example(data=None)
def test_gate_and_oxigraph_agree_on_service(closed_port: int, data: st.DataObject | None) -> None:
    text = (f"PREFIX ex: <http://e/>\nSELECT * WHERE {{ OPTIONAL {{ ?s ex:a\\# ?o }} "
            f"SERVICE <http://127.0.0.1:{closed_port}/sparql> {{ ?x ?y ?z }} }}") if data is None \
        else data.draw(spellings(closed_port))
    _agrees(gate_query, text, _effect(lambda: _query_fetches(text)))


@st.composite
def update_spellings(draw: st.DrawFn, port: int) -> str:
    hider = draw(st.sampled_from(HIDERS[:8]))
    before = draw(st.sampled_from(HIDDEN))
    op = draw(st.sampled_from(["LOAD", "CLEAR", "DROP", "none"]))
    tail = {"LOAD": f"LOAD <http://127.0.0.1:{port}/x.nt>", "CLEAR": "CLEAR ALL", "DROP": "DROP ALL", "none": ""}[op]
    tail = _case(tail, draw(st.integers(0, 15))) if op != "LOAD" else _case("LOAD", draw(st.integers(0, 15))) + tail[4:]
    return f"PREFIX ex: <http://e/>\nINSERT DATA {{ ex:s ex:p {hider} }} {before} {';' if tail else ''} {tail}"


def _update_wipes(text: str) -> bool:
    store = ox.Store()
    kept = ox.Quad(ox.NamedNode("urn:a"), ox.NamedNode("urn:b"), ox.NamedNode("urn:c"), ox.NamedNode("urn:g"))
    store.add(kept)
    store.update(text)
    return kept not in store


@settings(max_examples=200, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_gate_and_oxigraph_agree_on_updates(closed_port: int, data: st.DataObject) -> None:
    text = data.draw(update_spellings(closed_port))
    _agrees(gate_update, text, _effect(lambda: _update_wipes(text)))


@pytest.mark.parametrize("text", ["SELECT * WHERE { SERVICE <http://127.0.0.1:9/> { ?s ?p ?o } }",
                                  "SELECT * WHERE { " + "?s ?p ?o . " * 900 + "SERVICE <http://127.0.0.1:9/> { ?s ?p ?o } }"])
def test_a_refusal_is_a_fresh_exception_each_time(text: str) -> None:
    """A refused text, short (its verdict cached) or long (judged each time), raises a new exception on every call:
    one cached exception raised again would grow its traceback by every raise's frames and keep their locals."""
    seen = []
    for _ in range(3):
        with pytest.raises(BadInput) as caught:
            gate_query(text)
        seen.append(caught.value)
        tb, depth = caught.value.__traceback__, 0
        while tb is not None:
            depth, tb = depth + 1, tb.tb_next
        assert depth <= 3, depth
    assert len({id(e) for e in seen}) == 3 and {e.detail for e in seen} == {seen[0].detail}
