"""The lexical guard against LOAD/CLEAR/…/SERVICE (kg/sparql_guard.py): found wherever SPARQL would see
them, never inside strings, IRIs, comments, variables or prefixed names."""
from __future__ import annotations

import pytest
from rdflib import Literal, URIRef
from rdflib.namespace import SH

from nfex_core.kg.changes import ChangeSet
from nfex_core.kg.sparql_guard import (
    FORBIDDEN_UPDATES,
    ForbiddenOperation,
    forbidden_in,
    refuse_unsafe_change,
    refuse_unsafe_query,
    refuse_unsafe_update,
)
from nfex_core.namespaces import NFEX


@pytest.mark.parametrize("text,found", [
    ("LOAD <http://x>", ["LOAD"]),
    ("load<http://x>", ["LOAD"]),
    ("\\u004cOAD <http://x>", ["LOAD"]),
    ("\\U0000004cOAD <http://x>", ["LOAD"]),
    ("INSERT DATA { <a> <b> <c> } ;\nCLEAR ALL", ["CLEAR"]),
    ("DROP SILENT GRAPH <x> ; copy default to <y>", ["DROP", "COPY"]),
    ("INSERT { ?s ?p ?o } WHERE { SERVICE <http://x> { ?s ?p ?o } }", ["SERVICE"]),
    ("SELECT * WHERE { ?s ?p ?o FILTER(?s<?p) SERVICE<http://e>{} }", ["SERVICE"]),
    ("ADD <a> TO <b> ; MOVE <a> TO <b> ; CREATE GRAPH <c>", ["ADD", "MOVE", "CREATE"]),
    ('INSERT DATA { <a> <b> "LOAD <x>" }', []),
    ('INSERT DATA { <a> <b> """x " LOAD""" }', []),
    ("INSERT DATA { <a> <b> 'CLEAR' }", []),
    ("# LOAD\nINSERT DATA { <a> <b> <c> }", []),
    ("INSERT DATA { ex:LOAD ex:CLEAR ?load $drop }", []),
    ("PREFIX load: <x> INSERT DATA { load:x load:y load: }", []),
    ("INSERT { ?s a <http://e/LOAD> } WHERE { ?s ?p ?o }", []),
    ("INSERT DATA { _:LOAD <p> 1 }", []),
    ("DELETE WHERE { ?s ?p ?o }", []),
])
def test_forbidden_operations_are_found_where_sparql_sees_them(text: str, found: list[str]) -> None:
    assert forbidden_in(text, FORBIDDEN_UPDATES) == found


def test_refusals_name_the_operation() -> None:
    with pytest.raises(ForbiddenOperation, match="LOAD") as e:
        refuse_unsafe_update("LOAD <http://127.0.0.1:1/x>")
    assert e.value.status == 403 and e.value.extra["operations"] == ["LOAD"]
    with pytest.raises(ForbiddenOperation, match="SERVICE"):
        refuse_unsafe_query("SELECT * { SERVICE <http://x> { ?s ?p ?o } }")
    refuse_unsafe_query("SELECT * { ?s ?p ?o }")


def test_stored_sparql_is_checked_on_commit() -> None:
    rule = ChangeSet.adding([(NFEX.rule_x, NFEX.query, Literal("SELECT * { SERVICE <http://x> { } }"))])
    with pytest.raises(ForbiddenOperation):
        refuse_unsafe_change(rule)
    shape = ChangeSet.adding([(URIRef("urn:c"), SH.select, Literal("SELECT $this { } ; LOAD <http://x>"))])
    with pytest.raises(ForbiddenOperation):
        refuse_unsafe_change(shape)
    refuse_unsafe_change(ChangeSet.adding([(NFEX.ORB, NFEX.query, Literal("SELECT ?extractor ?reason { }"))]))
