"""Talking to other SPARQL servers: credentials by the server's challenge, the dataset of a query when the
knowledge lives in a named graph, and what a server whose default graph is the union of all graphs gets."""
from __future__ import annotations

import base64
from pathlib import Path

import httpx
import pyoxigraph as ox
import pytest

from nfex_core.config import Settings
from nfex_core.errors import StoreUnavailable
from nfex_core.kg import KnowledgeGraph, parse_rdf
from nfex_core.kg.protocol import ServerAuth, dataset_params
from nfex_core.kg.store import META
from nfex_core.knowledge import open_graph
from tests.conftest import KNOWLEDGE_GRAPH, SparqlServer

CONFIG = """@prefix nfex: <https://w3id.org/nfex#> .
nfex:cfg1 a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg1_nf .
nfex:cfg1_nf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures ; nfex:value 1000 ."""


def test_dataset_names_the_knowledge_graph_and_the_graphs_a_query_names() -> None:
    assert dataset_params("SELECT * { ?s ?p ?o }", None) == {}
    q = "SELECT * { GRAPH <urn:nfex:meta> { ?v ?p ?o } # GRAPH <urn:commented>\n GRAPH <urn:nfex:version:3:added> {} }"
    assert dataset_params(q, "urn:k") == {"default-graph-uri": "urn:k",
                                          "named-graph-uri": ["urn:nfex:meta", "urn:nfex:version:3:added"]}
    assert dataset_params("ASK { ?s ?p ?o }", "urn:k") == {"default-graph-uri": "urn:k"}


def _server(scheme: str, seen: list[str | None]) -> httpx.MockTransport:
    """A server that challenges with ``scheme`` and accepts ``u``/``p`` (the one thing this test must control)."""

    def handle(request: httpx.Request) -> httpx.Response:
        given = request.headers.get("authorization")
        seen.append(given)
        if scheme == "Basic" and given == "Basic " + base64.b64encode(b"u:p").decode():
            return httpx.Response(200, json={"boolean": True})
        if scheme == "Digest" and given and given.startswith('Digest username="u"'):
            return httpx.Response(200, json={"boolean": True})
        challenge = 'Basic realm="r"' if scheme == "Basic" else 'Digest realm="r", nonce="n1", qop="auth", algorithm="MD5"'
        return httpx.Response(401, headers={"WWW-Authenticate": challenge})

    return httpx.MockTransport(handle)


@pytest.mark.parametrize("scheme", ["Basic", "Digest"])
def test_credentials_answer_the_scheme_the_server_asks_for(scheme: str) -> None:
    seen: list[str | None] = []
    auth = ServerAuth("u", "p")
    with httpx.Client(transport=_server(scheme, seen), auth=auth) as client:
        assert client.post("http://h/sparql", data={"query": "ASK {}"}).status_code == 200
        assert seen[0] is None  # nothing sent before the server asked
        assert auth.scheme == scheme.lower()
        seen.clear()
        assert client.post("http://h/sparql", data={"query": "ASK {}"}).status_code == 200
        assert len(seen) == 1 and seen[0] is not None  # from then on, up front


def test_the_knowledge_can_live_in_a_named_graph_of_the_embedded_store(tmp_path: Path) -> None:
    settings = Settings.from_env().replace(store_graph=KNOWLEDGE_GRAPH)
    kg = open_graph(str(tmp_path / "store"), settings=settings)
    n = kg.triple_count()
    assert n > 1000 and kg.add(parse_rdf(CONFIG), author="t").version == 2
    raw = kg.backend._store  # type: ignore[attr-defined]
    assert not list(raw.quads_for_pattern(None, None, None, ox.DefaultGraph()))  # nothing in the default graph
    assert len(list(raw.quads_for_pattern(None, None, None, ox.NamedNode(KNOWLEDGE_GRAPH)))) == n + 6
    assert kg.ask("ASK { nfex:cfg1 nfex:ofExtractor nfex:ORB }") and kg.version == 2
    assert kg.ask(f"ASK {{ GRAPH <{META}> {{ <urn:nfex:head> nfex:versionNumber 2 }} }}")
    assert not kg.ask("ASK { <urn:nfex:head> ?p ?o }")  # the history stays out of the knowledge
    kg.close()


@pytest.mark.parametrize("sparql_server", ["virtuoso"], indirect=True)
def test_a_union_default_graph_is_refused_with_the_setting_to_use(sparql_server: SparqlServer) -> None:
    """Virtuoso shows every named graph in its default graph: without NFEX_STORE_GRAPH nFEX would read its
    version history as knowledge. It says so at open, before seeding."""
    bare = sparql_server.settings().replace(store_graph=None)
    with pytest.raises(StoreUnavailable, match="NFEX_STORE_GRAPH"):
        KnowledgeGraph.open(settings=bare)


@pytest.mark.parametrize("sparql_server", ["virtuoso"], indirect=True)
def test_wrong_credentials_are_a_clear_error(sparql_server: SparqlServer) -> None:
    wrong = sparql_server.settings().replace(store_password="not-the-password")
    with pytest.raises(StoreUnavailable, match="NFEX_STORE_USER / NFEX_STORE_PASSWORD"):
        KnowledgeGraph.open(settings=wrong)


def test_a_change_larger_than_one_request_is_staged_and_lands_whole(kg: KnowledgeGraph) -> None:
    """What a SPARQL server gets for a large change (Virtuoso takes ~500 template triples a request): the
    triples staged, then moved in by one operation; the version and its change set as if written inline."""
    from rdflib import Literal, URIRef

    from nfex_core.kg import ChangeSet

    kg.backend.max_inline_triples = 10
    head = kg.version
    change = ChangeSet.adding((URIRef(f"urn:test:s{i}"), URIRef("urn:test:p"), Literal(i)) for i in range(57))
    assert kg.commit(change, author="t").version == head + 1
    assert kg.changes(head + 1).added == change.added
    assert kg.select("SELECT (COUNT(*) AS ?n) WHERE { ?s <urn:test:p> ?o }").rows[0]["n"].toPython() == 57
    removal = ChangeSet.removing(list(change.added)[:20])
    assert kg.commit(removal, author="t").version == head + 2 and kg.changes(head + 2).removed == removal.removed
    left = kg.backend.select("SELECT (COUNT(*) AS ?n) WHERE { GRAPH ?g { ?s ?p ?o } FILTER STRSTARTS(STR(?g), 'urn:nfex:staging:') }")
    assert left.rows[0]["n"].toPython() == 0  # the staging graphs are gone
