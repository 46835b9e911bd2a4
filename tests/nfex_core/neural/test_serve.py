"""The advisor with the neural step: modes, Θ′ from ParamNet inside the graph's ranges, masking, fallbacks."""
from __future__ import annotations

from pathlib import Path

import pytest

from nfex_core.advisor import Advisor
from nfex_core.errors import UnknownName
from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.sparql_query import with_prefixes
from nfex_core.rules.fitness import adjust_params

from .test_artifacts import NARROW_NFEATURES

DARK = {"agent": "car", "scene": "outdoor", "light": "dark"}
BRIGHT = {"agent": "car", "scene": "outdoor", "light": "bright"}


def symbolic_params(kg: KnowledgeGraph, extractor: str, context: dict[str, str]) -> dict[str, object]:
    a = Advisor(kg, neural="symbolic")
    decision = a.snapshot().table.decide({**{d: None for d in a.snapshot().vocab.dimensions}, **context})
    return adjust_params(a.snapshot().vocab.extractor(extractor), decision.factors.get(extractor, {}))[0]


def test_both_uses_the_networks_and_reports_the_model(trained, kg: KnowledgeGraph) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    s = Advisor(kg, models=model.path).select(DARK)
    info = s.versions["model"]
    assert info["used"] == "paramnet+selectornet" and info["version"] == model.version
    assert s.mode == "selectornet"
    assert abs(sum(c.score for c in s.candidates) - 1.0) < 1e-6  # type: ignore[misc]
    vocab = kg.vocabulary()
    for c in s.candidates:
        spec = vocab.extractor(c.extractor)
        assert spec.resolve(c.params) == c.params  # every θ′ valid in the graph
        assert any("ParamNet" in a.citations[0].label for a in c.adjustments)


def test_the_planted_rule_comes_back(trained, kg: KnowledgeGraph) -> None:  # type: ignore[no-untyped-def]
    """The generated table makes ORB with a low FAST threshold best in the dark, SIFT best in bright light."""
    _, model = trained
    a = Advisor(kg, models=model.path)
    dark, bright = a.select(DARK), a.select(BRIGHT)
    assert (dark.extractor, bright.extractor) == ("ORB", "SIFT")
    orb = {s: next(c for c in sel.candidates if c.extractor == "ORB") for s, sel in (("dark", dark), ("bright", bright))}
    assert orb["dark"].params["fastThreshold"] < orb["bright"].params["fastThreshold"]


@pytest.mark.parametrize("mode,used", [("paramnet", "paramnet"), ("selectornet", "selectornet"), ("symbolic", "symbolic")])
def test_modes(trained, kg: KnowledgeGraph, mode: str, used: str) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    s = Advisor(kg, models=model.path, neural=mode).select(DARK)
    assert s.versions["model"]["used"] == used
    assert (s.mode == "selectornet") == (mode == "selectornet")
    if mode in ("selectornet", "symbolic"):
        assert s.params == symbolic_params(kg, s.extractor, DARK)
    else:
        assert s.params != symbolic_params(kg, s.extractor, DARK)


@pytest.mark.slow  # a SHACL-checked commit on the seeded graph
def test_changed_vocabulary_falls_back_and_says_so(trained, kg: KnowledgeGraph) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    a = Advisor(kg, models=model.path)
    assert a.select(DARK).versions["model"]["used"] == "paramnet+selectornet"
    kg.update(with_prefixes(NARROW_NFEATURES), author="test", message="narrow ORB.nfeatures")
    s = a.select(DARK)
    assert s.versions["model"]["used"] == "symbolic"
    assert "changed since training" in s.versions["model"]["fallback"]
    assert s.params == symbolic_params(kg, s.extractor, DARK)


def test_no_model_is_symbolic(kg: KnowledgeGraph, tmp_path: Path) -> None:
    s = Advisor(kg, models=tmp_path).select(DARK)
    assert s.versions["model"]["used"] == "symbolic" and "no model" in s.versions["model"]["fallback"]


def test_unknown_mode_lists_the_modes(kg: KnowledgeGraph) -> None:
    with pytest.raises(UnknownName, match="selectornet"):
        Advisor(kg, neural="magic")


def test_with_a_kitti_frame(trained, kg: KnowledgeGraph, data_dir: Path) -> None:  # type: ignore[no-untyped-def]
    import cv2

    _, model = trained
    frame = cv2.imread(str(data_dir / "kitti" / "sequences" / "00" / "image_0" / "000000.png"), cv2.IMREAD_GRAYSCALE)
    s = Advisor(kg, models=model.path).select({"agent": "car"}, frame=frame)
    assert s.mode == "selectornet" and s.extractor in {c.extractor for c in s.candidates}
    assert {x.extractor for x in s.pruned}.isdisjoint(c.extractor for c in s.candidates)
    nfeat = next(c for c in s.candidates if c.extractor == "ORB").params["nfeatures"]
    assert 1 <= nfeat <= 20000


def test_extractors_the_sweep_did_not_measure_keep_the_symbolic_params(trained, kg: KnowledgeGraph, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """ParamNet's outputs for an extractor without any training target are untrained: g(Θ, E) is used instead."""
    import json
    import shutil

    _, model = trained
    d = tmp_path / "m"
    shutil.copytree(model.path, d)
    manifest = json.loads((d / "manifest.json").read_text())
    manifest["paramnet_trained"] = [q for q in manifest["paramnet_trained"] if not q.startswith("AKAZE.")]
    (d / "manifest.json").write_text(json.dumps(manifest))
    s = Advisor(kg, models=d, neural="paramnet").select(DARK)
    by = {c.extractor: c for c in s.candidates}
    assert by["AKAZE"].params == symbolic_params(kg, "AKAZE", DARK)
    assert by["ORB"].params != symbolic_params(kg, "ORB", DARK)


def test_served_values_are_values_the_sweep_measured(trained, kg: KnowledgeGraph) -> None:  # type: ignore[no-untyped-def]
    import csv
    import json

    report, model = trained
    measured: dict[str, set[object]] = {}
    with open(model.manifest["data"]["table"]) as f:
        for row in csv.DictReader(f):
            for k, v in json.loads(row["params"]).items():
                measured.setdefault(f"{row['extractor']}.{k}", set()).add(v)
    s = Advisor(kg, models=model.path, neural="paramnet").select(DARK)
    checked = 0
    for c in s.candidates:
        for a in c.adjustments:
            if any(cite.kind == "shape" for cite in a.citations):
                continue  # a context shape clamped it after the network (rules/shapes/context.ttl)
            q = f"{c.extractor}.{a.parameter}"
            if not kg.vocabulary().extractor(c.extractor).parameter(a.parameter).scales_with_resolution:
                assert any(abs(float(a.after) - float(v)) <= 1e-6 * max(1.0, abs(float(v))) for v in measured[q]), q  # type: ignore[arg-type]
                checked += 1
    assert checked >= 10


def _edited(model, tmp_path: Path, **changes: object) -> Path:  # type: ignore[no-untyped-def]
    import json
    import shutil

    d = tmp_path / "edited"
    shutil.copytree(model.path, d)
    manifest = json.loads((d / "manifest.json").read_text())
    manifest.update(changes)
    (d / "manifest.json").write_text(json.dumps(manifest))
    return d


def test_selector_never_picks_an_extractor_absent_from_training(trained, kg: KnowledgeGraph, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    d = _edited(model, tmp_path, selectornet_extractors=["AKAZE", "BRISK", "SIFT"])
    s = Advisor(kg, models=d, neural="selectornet").select(DARK)  # ORB wins the dark windows when it may
    assert s.extractor != "ORB"
    assert next(c for c in s.candidates if c.extractor == "ORB").score == 0.0


def test_context_values_unseen_in_training_enter_as_unknown(trained, kg: KnowledgeGraph, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    seen = {**model.manifest["context_seen"], "light": ["bright"]}
    d = _edited(model, tmp_path, context_seen=seen)
    a = Advisor(kg, models=d, neural="selectornet")
    unknown = {k: v for k, v in DARK.items() if k != "light"}
    assert [c.score for c in a.select(DARK).candidates] == [c.score for c in a.select(unknown).candidates]
    assert [c.score for c in a.select(DARK).candidates] != [c.score for c in Advisor(kg, models=model.path, neural="selectornet").select(DARK).candidates]


def test_nfex_select_reports_the_model(trained, store_path: Path, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """A real `nfex select` process answers with the model (and without importing torch)."""
    import json
    import os
    import subprocess
    import sys

    _, model = trained
    code = (
        "import sys, runpy; sys.argv = ['nfex', '--store', sys.argv[1], 'select', '--context', 'agent=car,light=dark', '--json'];"
        "import cli.main as m\ntry:\n    m.main()\nfinally:\n    print('TORCH' if 'torch' in sys.modules else 'NOTORCH', file=sys.stderr)"
    )
    env = {**os.environ, "NFEX_MODELS": str(model.path), "NFEX_NEURAL": "both"}
    p = subprocess.run([sys.executable, "-c", code, str(store_path)], capture_output=True, text=True, timeout=120, env=env)
    assert p.returncode == 0, p.stderr
    assert p.stderr.strip().endswith("NOTORCH")
    answer = json.loads(p.stdout)
    assert answer["versions"]["model"]["used"] == "paramnet+selectornet"
    assert answer["versions"]["model"]["version"] == model.version and answer["mode"] == "selectornet"


def test_both_skips_a_network_that_validated_worse_than_its_baseline(trained, kg: KnowledgeGraph, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    metrics = {**model.manifest["metrics"], "paramnet": {"val_mse": 0.05, "val_mse_best_constant": 0.01, "val_mse_lookup": 0.02}}
    d = _edited(model, tmp_path, metrics=metrics)
    both = Advisor(kg, models=d).select(DARK)
    assert both.versions["model"]["used"] == "selectornet"
    assert "0.05 >= 0.01 of the best constant" in both.versions["model"]["skipped"]["paramnet"]
    assert both.params == symbolic_params(kg, both.extractor, DARK)
    forced = Advisor(kg, models=d, neural="paramnet").select(DARK)
    assert forced.versions["model"]["used"] == "paramnet" and "skipped" not in forced.versions["model"]


def test_selectornet_declines_when_its_first_choice_was_pruned(trained, kg: KnowledgeGraph) -> None:  # type: ignore[no-untyped-def]
    """Trained on each window's best extractor, its ranking of the rest is untrained: F_metrics decides then."""
    from nfex_core.rules.dsl import programs

    _, model = trained
    advisor = Advisor(kg, models=model.path, neural="selectornet")
    free = advisor.select(DARK)
    assert free.mode == "selectornet" and free.extractor == "ORB"  # ORB wins the dark windows when it may
    _, g = programs.compile_text('program no_orb\nprune ORB when light is dark because "test"', kg.vocabulary(), name="no_orb")
    programs.apply(kg, g, "no_orb", author="test")
    s = advisor.select(DARK)
    assert s.mode == "prior" and s.extractor != "ORB"
    assert "SelectorNet names ORB" in s.versions["model"]["declined"]
