"""The static methods come from the graph; dynamic ones read the measured-best configuration per frame."""
from __future__ import annotations

import pytest
from nfex_slam.datasets.base import Frame

from nfex_core.errors import BadInput
from nfex_core.evaluation import DynChooser, chooser_for, known_methods, static_methods, tuned_static
from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.engine import RuleEngine

from .conftest import add_rows, measured_row


def test_every_extractor_in_the_graph_is_a_static_baseline(bare_kg: KnowledgeGraph) -> None:
    vocab = bare_kg.vocabulary()
    methods = static_methods(vocab)
    for x in vocab.extractors:
        assert f"{x.lower()}-default" in methods and f"{x.lower()}-dyn" in methods
    assert "tuned-static" in methods and "nfex" in known_methods(vocab) and "nfex" not in methods
    table = RuleEngine(bare_kg).table()
    with pytest.raises(BadInput, match="unknown method 'fog-default'; known: .*orb-default"):
        chooser_for("fog-default", vocab, table, None, {})


def test_an_extractor_added_as_data_is_a_baseline_at_once(bare_kg: KnowledgeGraph) -> None:
    import rdflib

    from tests.nfex_core.vision.test_registry import KAZE_TTL  # KAZE: an OpenCV extractor described in Turtle

    bare_kg.add(rdflib.Graph().parse(data=KAZE_TTL, format="turtle"), author="test")
    assert {"kaze-default", "kaze-dyn"} <= set(static_methods(bare_kg.vocabulary()))


def test_dyn_takes_the_best_configuration_measured_under_each_frames_conditions(bare_kg: KnowledgeGraph) -> None:
    rows = [measured_row(bare_kg, "ORB", {"nfeatures": 1000}, 0.2, f"a{i}", light="dark") for i in range(3)]
    rows += [measured_row(bare_kg, "ORB", {"nfeatures": 2000}, 0.1, f"b{i}", light="bright") for i in range(3)]
    add_rows(bare_kg, rows)
    table = RuleEngine(bare_kg).table()
    dyn = DynChooser(table, "ORB", {"agent": "car"})
    dark = dyn(Frame(0, 0.0, None, None, {"light": "dark"}), [])  # type: ignore[arg-type]
    bright = dyn(Frame(1, 0.1, None, None, {"light": "bright"}), [])  # type: ignore[arg-type]
    assert dark.params["nfeatures"] == 1000 and bright.params["nfeatures"] == 2000
    assert dyn(Frame(2, 0.2, None, None, {}), []).params["nfeatures"] in (1000, 2000)  # type: ignore[arg-type]
    assert dyn(Frame(3, 0.3, None, None, {"light": "dark"}), []) is dark  # type: ignore[arg-type]  # cached per context
    assert DynChooser(table, "SIFT", {"agent": "car"})(Frame(0, 0.0, None, None, {}), []).params == {}  # type: ignore[arg-type]


def test_tuned_static_is_the_lowest_median_over_all_conditions(bare_kg: KnowledgeGraph) -> None:
    with pytest.raises(BadInput, match="needs measured configurations"):
        tuned_static(RuleEngine(bare_kg).table())
    rows = [measured_row(bare_kg, "ORB", {"nfeatures": 1000}, a, f"a{i}") for i, a in enumerate((0.1, 0.2, 9.0))]
    rows += [measured_row(bare_kg, "SIFT", {}, a, f"b{i}") for i, a in enumerate((0.3, 0.3, 0.3))]
    rows += [measured_row(bare_kg, "ORB", {"nfeatures": 2000}, 0.01, f"c{i}", failed=i == 0) for i in range(3)]
    add_rows(bare_kg, rows)
    x, params, note = tuned_static(RuleEngine(bare_kg).table())
    assert x == "ORB" and params["nfeatures"] == 1000 and "median ATE 0.200" in note  # the median shrugs off 9.0
