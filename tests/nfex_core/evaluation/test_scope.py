"""The evidence scope: nothing measured on the held-out sequence reaches any reader of measurements.

Reproduces the leak of issue 24: the advisor (measured Θ′ and the measured pruning rules) read the
evaluated sequence's own measurements; under the scope they do not, and the graph is otherwise the same.
"""
from __future__ import annotations

import pytest

from nfex_core.advisor import Advisor
from nfex_core.errors import BadInput
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.identity import sequence_iri
from nfex_core.kg.scope import EvidenceScope, excluded_measurements, scoped_graph

from .conftest import add_rows, measured_row

HELD_OUT = EvidenceScope.holding_out([sequence_iri("kitti", "01")])


@pytest.fixture
def leaky(bare_kg: KnowledgeGraph) -> KnowledgeGraph:
    """ORB measured on KITTI 00 (nfeatures 1000 best) and on KITTI 01 (nfeatures 3000, far better); SIFT
    lost every KITTI 01 window, so the measured-failure rule prunes it unless 01 is held out."""
    rows = [measured_row(bare_kg, "ORB", {"nfeatures": 1000}, 0.20, f"a{i}") for i in range(3)]
    rows += [measured_row(bare_kg, "ORB", {"nfeatures": 2000}, 0.50, f"b{i}") for i in range(3)]
    rows += [measured_row(bare_kg, "ORB", {"nfeatures": 3000}, 0.05, f"c{i}", sequence="01") for i in range(3)]
    rows += [measured_row(bare_kg, "SIFT", {}, None, f"d{i}", sequence="01", failed=True) for i in range(4)]
    add_rows(bare_kg, rows)
    return bare_kg


def test_without_a_scope_the_advisor_reads_the_evaluated_sequence(leaky: KnowledgeGraph) -> None:
    sel = Advisor(leaky, neural="symbolic").select({"agent": "car"})
    orb = next(c for c in sel.candidates if c.extractor == "ORB")
    assert orb.params["nfeatures"] == 3000  # the leak: KITTI 01's own best configuration
    assert "SIFT" in {p.extractor for p in sel.pruned}


def test_holding_a_sequence_out_removes_it_from_every_reader(leaky: KnowledgeGraph) -> None:
    assert len(excluded_measurements(leaky, HELD_OUT)) == 7
    sel = Advisor(leaky, neural="symbolic", scope=HELD_OUT).select({"agent": "car"})
    orb = next(c for c in sel.candidates if c.extractor == "ORB")
    assert orb.params["nfeatures"] == 1000 and orb.evidence.params_source == "measured"
    assert orb.evidence.measured is not None and orb.evidence.measured.windows == 6  # KITTI 00's windows only
    assert "SIFT" in {c.extractor for c in sel.candidates}  # the failure rule no longer sees 01's windows


def test_the_scoped_graph_is_a_read_only_copy_at_the_same_version(leaky: KnowledgeGraph) -> None:
    view = scoped_graph(leaky, HELD_OUT)
    assert view.version == leaky.version and view is not leaky
    n = "SELECT (COUNT(?m) AS ?n) WHERE { ?m a nfex:Measurement }"
    assert int(view.select(n).rows[0]["n"]) == int(leaky.select(n).rows[0]["n"]) - 7
    held = sequence_iri("kitti", "01")
    assert not view.select(f"SELECT ?r WHERE {{ ?m nfex:sequence <{held}> ; nfex:hasMetricResult ?r }}").rows
    with pytest.raises(BadInput, match="read-only view"):
        view.add(leaky.construct("CONSTRUCT { ?s ?p ?o } WHERE { ?s a nfex:Run ; ?p ?o }"), author="t")
    assert scoped_graph(leaky, EvidenceScope()) is leaky


def test_a_model_trained_on_a_held_out_sequence_is_not_used(bare_kg: KnowledgeGraph) -> None:
    scope = EvidenceScope.holding_out([sequence_iri("kitti", "00")])  # the shipped model was trained on KITTI 00
    sel = Advisor(bare_kg, scope=scope).select({"agent": "car"})
    model = sel.versions["model"]
    assert model["used"] == "symbolic" and "holds out" in model.get("fallback", "")
