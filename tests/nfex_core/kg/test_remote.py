"""The same transactions against real SPARQL servers shared by several clients: `oxigraph serve`, and Virtuoso
(its default graph the union of all graphs, updates behind HTTP Digest): each test runs on both."""
from __future__ import annotations

import threading

import pytest
from rdflib import Literal
from rdflib.namespace import RDFS

from nfex_core.errors import Conflict, ParseError, StoreUnavailable, ValidationFailed
from nfex_core.kg import ChangeSet, KnowledgeGraph, parse_rdf
from nfex_core.kg.backends import RemoteBackend
from nfex_core.kg.history import prefix_block
from nfex_core.kg.namespaces import NFEX
from tests.conftest import SparqlServer

CONFIG = """@prefix nfex: <https://w3id.org/nfex#> .
nfex:cfg1 a nfex:Configuration ; nfex:ofExtractor nfex:ORB ; nfex:hasSetting nfex:cfg1_nf .
nfex:cfg1_nf a nfex:ParameterSetting ; nfex:parameter nfex:ORB_nfeatures ; nfex:value 1000 ."""


def test_seed_query_commit_rollback_over_http(sparql_server: SparqlServer) -> None:
    kg = sparql_server.open()
    assert kg.version == 1
    params = kg.select("SELECT ?p WHERE { ?p a nfex:Parameter }")
    assert len(params) == 40  # ORB 9, ORB_GRID 11, SIFT 6, AKAZE 8, BRISK 3, XFEAT 3
    before = set(kg.data_graph())
    assert kg.add(parse_rdf(CONFIG), author="a").version == 2
    with pytest.raises(ValidationFailed):
        kg.add(parse_rdf(CONFIG.replace("1000", "-1").replace("cfg1", "cfg2")), author="a")
    assert kg.version == 2
    kg.rollback(1, author="a")
    assert set(kg.data_graph()) == before
    with pytest.raises(ParseError):
        kg.select("SELECT nonsense")


def test_a_second_node_sees_the_same_graph(sparql_server: SparqlServer) -> None:
    a = sparql_server.open()
    b = sparql_server.open()
    a.add(parse_rdf(CONFIG), author="a")
    assert b.version == 2
    assert b.ask("ASK { nfex:cfg1 nfex:ofExtractor nfex:ORB }")


def test_concurrent_writers_never_lose_a_change(sparql_server: SparqlServer) -> None:
    """Two nodes commit at once; compare-and-swap lets exactly one win each round, the other retries."""
    nodes = [sparql_server.open() for _ in range(4)]
    per_node = 5
    errors: list[Exception] = []

    def writer(i: int) -> None:
        kg = nodes[i]
        for j in range(per_node):
            change = ChangeSet.adding([(NFEX[f"note_{i}_{j}"], RDFS.comment, Literal(f"note {i}-{j}"))])
            for _ in range(50):
                try:
                    kg.commit(change, author=f"node{i}")
                    break
                except Conflict:
                    continue
            else:
                errors.append(RuntimeError(f"node {i} never committed"))

    threads = [threading.Thread(target=writer, args=(i,)) for i in range(len(nodes))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    notes = {str(o) for o in nodes[0].data_graph().objects(None, RDFS.comment) if str(o).startswith("note")}
    assert notes == {f"note {i}-{j}" for i in range(len(nodes)) for j in range(per_node)}
    versions = [v.number for v in nodes[0].versions(limit=None)]
    assert sorted(versions) == list(range(1, 2 + len(nodes) * per_node))


def test_unreachable_server_is_a_clear_error() -> None:
    from tests.conftest import free_port

    with pytest.raises(StoreUnavailable, match="cannot reach"):
        KnowledgeGraph(RemoteBackend(f"http://127.0.0.1:{free_port()}"))


def test_endpoint_urls_follow_server_conventions() -> None:
    assert RemoteBackend("http://h:7878").update_url == "http://h:7878/update"
    assert RemoteBackend("http://h:7878").query_url == "http://h:7878/query"
    fuseki = RemoteBackend("http://h:3030/ds/query")
    assert (fuseki.query_url, fuseki.update_url) == ("http://h:3030/ds/query", "http://h:3030/ds/update")


def test_writes_valid_alone_but_not_together_cannot_both_land(sparql_server: SparqlServer) -> None:
    """Write skew: two nodes each add an ORB parameter named "extra" — each valid alone. Commits are
    serialised and each is validated against the head it lands on, so exactly one lands."""
    nodes = [sparql_server.open() for _ in range(2)]
    outcomes: list[str] = []
    barrier = threading.Barrier(2)

    def writer(i: int) -> None:
        g = parse_rdf(
            f"""@prefix nfex: <https://w3id.org/nfex#> . @prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
            nfex:ORB_extra{i} a nfex:Parameter ; nfex:parameterOf nfex:ORB ; nfex:opencvName "extra" ;
                nfex:role nfex:OtherRole ; nfex:datatype xsd:integer ; nfex:defaultValue 1 ."""
        )
        barrier.wait()
        try:
            nodes[i].add(g, author=f"node{i}")
            outcomes.append("landed")
        except ValidationFailed:
            outcomes.append("rejected")

    threads = [threading.Thread(target=writer, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(outcomes) == ["landed", "rejected"]
    assert nodes[0].version == 2


def test_values_are_the_lexical_forms_on_every_store(sparql_server: SparqlServer, kg: KnowledgeGraph) -> None:
    """``Backend.values`` (the CSV results format) reads each value as its lexical form, on the embedded store and on
    both servers alike, and a server that does not answer CSV is read through ``select``."""
    remote = sparql_server.open()
    text = 'a comment, "quoted"\nover two lines: ü'
    change = ChangeSet(added={(NFEX.ORB, RDFS.comment, Literal(text))})
    for graph in (remote, kg):
        graph.commit(change, author="a", message="comment")
    query = """SELECT ?x ?c ?n ?none WHERE { ?x rdfs:comment ?c FILTER (CONTAINS(STR(?c), "quoted"))
        nfex:ORB_nfeatures nfex:defaultValue ?n OPTIONAL { ?x nfex:noSuchAttribute ?none } }"""
    expected = [[str(NFEX.ORB), text, "500", ""]]
    query = prefix_block() + query
    assert kg.backend.values(query) == expected
    assert remote.backend.values(query) == expected

    class JsonOnly(RemoteBackend):  # a server that answers JSON whatever it is asked
        def query_to(self, query: str, media: str, out, timeout_s: float | None = None) -> str:  # type: ignore[no-untyped-def]
            return super().query_to(query, "application/sparql-results+json", out, timeout_s)

    settings = sparql_server.settings()
    json_only = JsonOnly(sparql_server.url, user=settings.store_user, password=settings.store_password, graph=settings.store_graph)
    assert json_only.values(query) == expected
