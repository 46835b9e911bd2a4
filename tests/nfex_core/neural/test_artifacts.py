from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from nfex_core.kg import KnowledgeGraph
from nfex_core.kg.storage.sparql_query import with_prefixes
from nfex_core.neural.artifacts import NeuralModel, find_model

NARROW_NFEATURES = """
DELETE { ?p nfex:maxValue ?m } INSERT { ?p nfex:maxValue 8000 }
WHERE { ?p nfex:parameterOf/nfex:token "ORB" ; nfex:opencvName "nfeatures" ; nfex:maxValue ?m }
"""


def test_round_trip(trained, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    copy = NeuralModel.load(model.save(tmp_path / "again"))
    assert copy.inputs == model.inputs and copy.scaler.keys == model.scaler.keys
    for a, b in ((copy.paramnet, model.paramnet), (copy.selectornet, model.selectornet)):
        assert a is not None and b is not None
        assert all(np.array_equal(a.weights[k], b.weights[k]) for k in b.weights)
    assert copy.version == model.version and len(copy.version) > 10


def test_size_is_kilobytes(trained) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    assert sum(f.stat().st_size for f in model.path.iterdir()) < 200_000


def test_vocabulary_check_follows_the_graph(trained, kg: KnowledgeGraph) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    assert model.check(kg.vocabulary()) is None
    kg.update(with_prefixes(NARROW_NFEATURES), author="test", message="narrow ORB.nfeatures")
    reason = model.check(kg.vocabulary())
    assert reason is not None and "tunable parameters" in reason


def test_refuses_a_folder_of_another_format(trained, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    d = tmp_path / "m"
    shutil.copytree(model.path, d)
    manifest = json.loads((d / "manifest.json").read_text())
    manifest["format"] = "something/0"
    (d / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match="not an nFEX model"):
        NeuralModel.load(d)


def test_find_model(trained, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    assert find_model(tmp_path) is None
    shutil.copytree(model.path, tmp_path / "default")
    assert find_model(tmp_path) == tmp_path / "default"
    assert find_model(model.path) == model.path


PN_OK = {"val_mse": 0.01, "val_mse_best_constant": 0.05, "val_mse_lookup": 0.04}


def sn(acc: float, reg: float, acc_c: float = 0.6, reg_c: float = 0.2, acc_l: float = 0.5, reg_l: float = 0.3) -> dict:
    return {"val_accuracy": acc, "val_regret": reg, "best_constant": "SIFT", "val_accuracy_best_constant": acc_c,
            "val_regret_best_constant": reg_c, "val_accuracy_lookup": acc_l, "val_regret_lookup": reg_l}  # fmt: skip


SN_OK = sn(0.9, 0.05)


@pytest.mark.parametrize(
    ("metrics", "gated"),
    [
        ({"paramnet": PN_OK, "selectornet": SN_OK}, set()),
        ({"paramnet": PN_OK, "selectornet": sn(0.6, 0.05)}, {"selectornet"}),  # ties the best constant's accuracy
        ({"paramnet": PN_OK, "selectornet": sn(0.9, 0.25)}, {"selectornet"}),  # more often right, but loses more ATE
        ({"paramnet": PN_OK, "selectornet": sn(0.9, 0.05, acc_l=0.95)}, {"selectornet"}),  # the lookup is better
        # 0.75 against the majority's 0.00, while always SIFT scored 1.00 (a model that once shipped)
        ({"paramnet": PN_OK, "selectornet": {"val_accuracy": 0.75, "val_accuracy_majority": 0.0, "majority": "ORB"}}, {"selectornet"}),
        ({"paramnet": {**PN_OK, "val_mse": 0.05}, "selectornet": SN_OK}, {"paramnet"}),  # ties the best constant
        ({"paramnet": {**PN_OK, "val_mse": 0.045}, "selectornet": SN_OK}, {"paramnet"}),  # beats the constant, not the lookup
        ({"paramnet": {"val_mse": 0.01, "val_mse_train_mean": 0.05}, "selectornet": SN_OK}, {"paramnet"}),  # majority-era
        ({}, {"paramnet", "selectornet"}),  # never validated
    ],
)
def test_a_network_must_beat_the_constant_and_the_lookup(trained, metrics, gated) -> None:  # type: ignore[no-untyped-def]
    """Regression: a SelectorNet passed a gate against the training majority (ORB, 0.00) although a constant
    SIFT scored 1.00 against its 0.75 on the same windows."""
    _, model = trained
    model = NeuralModel(**{**model.__dict__, "manifest": {**model.manifest, "metrics": metrics}})
    assert set(model.validation_gates()) == gated


def test_the_shipped_model_was_trained_by_committed_code() -> None:
    """models/default names the commit that trained it, from a clean tree: a `dirty: true` model is never
    shipped (retrain with `nfex train … --out models/default` on a clean checkout; training is deterministic)."""
    manifest = json.loads((Path(__file__).resolve().parents[3] / "models" / "default" / "manifest.json").read_text())
    assert manifest["code"]["dirty"] is False, manifest["code"]
    assert len(manifest["code"]["git_commit"] or "") == 40
