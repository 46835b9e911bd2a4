"""Writers killed with ``kill -9`` inside ``KnowledgeGraph.commit``: the store stays at the last committed
version, and a writer that dies between its claim and its commit does not hold the others up.

The writer is a real process that commits through ``commit()``; the only thing the test controls is
*when* it dies: its backend announces each update on stdout before sending it (and, in the second test,
stops before the commit update), and the test kills it there.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rdflib import Literal, URIRef
from rdflib.namespace import RDFS

from nfex_core.errors import Conflict
from nfex_core.kg import ChangeSet, KnowledgeGraph, claims
from nfex_core.kg import store as store_module
from nfex_core.kg.claims import Rival
from nfex_core.kg.namespaces import NFEX
from nfex_core.knowledge import open_graph

WRITER = r"""
import os, sys, time
from rdflib import Literal, URIRef
from nfex_core.kg import ChangeSet, KnowledgeGraph
location, size, stop_before_commit = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "stop"
kg = KnowledgeGraph.open(location)
real_update = kg.backend.update

def announced(text):
    committing = "nfex#commitId" in text or "nfex:commitId" in text
    print("commit" if committing else "update", flush=True)
    if committing and stop_before_commit:
        time.sleep(3600)  # claimed (on a shared server), not committed: the test kills it here
    real_update(text)

kg.backend.update = announced
for round in range(1000):
    change = ChangeSet.adding(
        (URIRef(f"urn:crash:{os.getpid()}:{round}:{i}"), URIRef("urn:crash:p"), Literal(i)) for i in range(size)
    )
    kg.commit(change, author="crash", message=f"round {round}")
    print("done", round, flush=True)
"""


def _writer(tmp_path: Path, location: str, size: int, stop: bool) -> subprocess.Popen[str]:
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    repo = str(Path(__file__).resolve().parents[3])  # this checkout's nfex_core, not an installed one
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [repo, os.environ.get("PYTHONPATH")]))}
    return subprocess.Popen([sys.executable, str(script), location, str(size), "stop" if stop else "go"],
                            stdout=subprocess.PIPE, text=True, env=env)


def _wait_for(proc: subprocess.Popen[str], word: str, times: int = 1) -> None:
    assert proc.stdout is not None
    seen = 0
    while seen < times:
        line = proc.stdout.readline()
        assert line, f"the writer exited ({proc.wait()}) before printing {word!r}"
        seen += line.split()[0] == word


def _crash_notes(kg: KnowledgeGraph) -> int:
    return int(kg.select("SELECT (COUNT(?s) AS ?n) WHERE { ?s <urn:crash:p> ?o }").rows[0]["n"].toPython())  # type: ignore[union-attr]


def test_killed_writer_leaves_a_consistent_store(store_path: Path, tmp_path: Path) -> None:
    """Killed while ``commit()`` sends its update (20,000 triples): every version up to the head is
    complete and nothing of a later one is there."""
    for delay in (0.0, 0.05, 0.3):
        proc = _writer(tmp_path, str(store_path), 20000, stop=False)
        _wait_for(proc, "done")  # one commit done
        _wait_for(proc, "commit")  # the next one is being sent
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        kg = KnowledgeGraph.open(str(store_path))
        crashed = [v for v in kg.versions() if v.author == "crash"]
        assert _crash_notes(kg) == 20000 * len(crashed) and crashed
        assert all(v.added == 20000 for v in crashed)
        kg.close()
        del kg


def _next_write_after_a_dead_claim(location: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[list[list[Rival]], KnowledgeGraph]:
    """A writer killed between its claim and its commit, then the next write in this process: what each of its
    reads of the other claims found (the claims the code waits on), and the graph after it committed."""
    proc = _writer(tmp_path, location, 3, stop=True)
    _wait_for(proc, "commit")  # claimed (shared server) and about to commit
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    kg = KnowledgeGraph.open(location)
    head = kg.version
    found: list[list[Rival]] = []
    rivals = store_module.rival_claims
    monkeypatch.setattr(store_module, "rival_claims", lambda backend, claim: found.append(rivals(backend, claim)) or found[-1])
    result = kg.commit(ChangeSet.adding([(NFEX.note_after_crash, RDFS.comment, Literal("after"))]), author="next")
    assert result.version == head + 1 and kg.version == head + 1
    return found, kg


def test_a_writer_killed_between_claim_and_commit_holds_the_next_write_only_until_its_claim_expires(
    oxigraph_server: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The next writer finds the dead writer's claim (a rival with at most its time to live left: claims.ttl_for of
    its 3 triples), waits on it, and commits once a read finds it expired — well within CLAIM_WAIT_S, past which
    the commit would have raised Conflict."""
    open_graph(oxigraph_server).close()  # seed
    found, kg = _next_write_after_a_dead_claim(oxigraph_server, tmp_path, monkeypatch)
    assert found[0], "the dead writer's claim was not seen: the write did not wait for it"
    assert all(0 < r.left_s <= claims.ttl_for(3) for r in found[0]), found[0]
    assert found[-1] == []  # committed once the claim had expired
    assert not kg.select("SELECT ?c WHERE { GRAPH <urn:nfex:meta> { ?c nfex:claimsVersion ?n } }").rows  # settled
    assert _crash_notes(kg) == 0


def test_a_writer_killed_before_its_commit_does_not_delay_the_next_on_an_embedded_store(
    store_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An embedded store is one process's: no claims, so nothing a dead writer left can hold the next one."""
    found, kg = _next_write_after_a_dead_claim(str(store_path), tmp_path, monkeypatch)
    assert found == []  # no claim was read, none waited on
    assert _crash_notes(kg) == 0
    kg.close()


def test_a_live_claim_is_reported_as_what_it_is(oxigraph_server: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Regression: a writer blocked by another's claim was told "other writers kept committing first"."""
    kg = open_graph(oxigraph_server)
    claims.take(kg.backend, kg.version + 1, 60.0)  # a writer that claimed and went quiet
    monkeypatch.setattr(store_module, "CLAIM_WAIT_S", 0.5)
    with pytest.raises(Conflict, match=rf"another writer claimed version {kg.version + 1} and has not committed it") as e:
        kg.commit(ChangeSet.adding([(URIRef("urn:x"), RDFS.comment, Literal("x"))]), author="t")
    assert "committing first" not in e.value.detail


SEEDER = r"""
import sys, time
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.backends import EmbeddedBackend
from nfex_core.knowledge import seed

real_bulk_load = EmbeddedBackend.bulk_load

def half_then_wait(self, data):
    real_bulk_load(self, data[: data.rindex(b"\n", 0, len(data) // 2) + 1])  # the loader stopped halfway
    print("bulk", flush=True)
    time.sleep(3600)  # the test kills it here

EmbeddedBackend.bulk_load = half_then_wait
seed(KnowledgeGraph.open(sys.argv[1]))
"""


def test_a_seed_killed_in_its_bulk_write_is_taken_out_at_the_next_open(tmp_path: Path) -> None:
    """The bulk loader is not atomic (kg/history.py ``bulk_write_first``): a seeder killed with half its quads
    written leaves them behind with the marker; the next open takes them out, and the store seeds as new."""
    store_path = tmp_path / "store"
    script = tmp_path / "seeder.py"
    script.write_text(SEEDER)
    repo = str(Path(__file__).resolve().parents[3])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [repo, os.environ.get("PYTHONPATH")]))}
    proc = subprocess.Popen([sys.executable, str(script), str(store_path)], stdout=subprocess.PIPE, text=True, env=env)
    _wait_for(proc, "bulk")
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    import pyoxigraph as ox

    left = ox.Store(str(store_path))
    assert len(left) > 1000  # half of the knowledge and of its change-set graph, and the marker
    del left
    kg = KnowledgeGraph.open(str(store_path))
    assert kg.version == 0 and not kg.ask("ASK { ?s ?p ?o }")
    assert not kg.ask("ASK { GRAPH ?g { ?s ?p ?o } FILTER (?g != <urn:nfex:meta>) }")
    assert kg.select("SELECT ?s ?p ?o WHERE { GRAPH <urn:nfex:meta> { ?s ?p ?o } }").rows == \
        [{"s": URIRef("urn:nfex:head"), "p": NFEX.versionNumber, "o": Literal(0)}]
    kg.close()
    del kg
    seeded = open_graph(str(store_path))
    fresh = open_graph(str(tmp_path / "fresh"))
    assert seeded.version == fresh.version == 1
    assert set(seeded.data_graph()) == set(fresh.data_graph()) and seeded.changes(1) == fresh.changes(1)
