"""A process killed in the middle of a write leaves a readable store at the last committed version."""
from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

from nfex_core.kg import KnowledgeGraph

WRITER = r"""
import os, sys
from rdflib import Literal, URIRef
from nfex_core.kg import ChangeSet, KnowledgeGraph
kg = KnowledgeGraph.open(sys.argv[1])
for round in range(1000):
    change = ChangeSet.adding(
        (URIRef(f"urn:crash:{os.getpid()}:{round}:{i}"), URIRef("urn:crash:p"), Literal(i)) for i in range(int(sys.argv[2]))
    )
    # skip SHACL: this test is about the store's atomicity, not validation
    kg.backend.update(kg._commit_update(kg._effective(change), kg.version, kg.version + 1, "crash", "", "x"))
    print(round, flush=True)
"""


def test_killed_writer_leaves_a_consistent_store(store_path: Path, tmp_path: Path) -> None:
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    for delay in (0.3, 0.7, 1.1):
        proc = subprocess.Popen([sys.executable, str(script), str(store_path), "20000"], stdout=subprocess.PIPE, text=True)
        assert proc.stdout is not None
        proc.stdout.readline()  # one commit done; the next is in flight
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        kg = KnowledgeGraph.open(str(store_path))
        head = kg.version
        # every version up to the head is complete, nothing of a later one is there
        rounds = kg.select("SELECT (COUNT(?s) AS ?n) WHERE { ?s <urn:crash:p> ?o }").rows[0]["n"].toPython()
        assert rounds == 20000 * (head - sum(1 for v in kg.versions() if v.author != "crash"))
        assert kg.triple_count() >= 20000
        kg.close()
        del kg
