from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from nfex_core.neural.dataset import read_table, split
from nfex_core.neural.train import auto_epochs

from .tablegen import make_table


def test_learns_the_planted_rule_better_than_baselines(trained) -> None:  # type: ignore[no-untyped-def]
    report, model = trained
    m = report.metrics
    assert report.windows == {"train": 24, "validate": 24}
    assert m["paramnet"]["val_mse"] < m["paramnet"]["val_mse_train_mean"]
    assert m["selectornet"]["val_accuracy"] > m["selectornet"]["val_accuracy_majority"]
    assert model.manifest["data"]["sha256"] and model.manifest["training"]["lr"] == 1e-4
    assert model.manifest["code"]["git_commit"]


def test_split_never_shares_a_sequence(tmp_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    windows = read_table(make_table(tmp_path / "t.csv", vocab, sequences=("00", "01", "02"), windows=3))
    tr, va, note = split(windows, ["02"])
    assert {w.seq_key for w in tr} == {"kitti/00", "kitti/01"} and {w.seq_key for w in va} == {"kitti/02"}
    assert "02" in note
    with pytest.raises(ValueError):
        split(windows, ["00", "01", "02"])


def test_one_sequence_splits_by_contiguous_halves(tmp_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    windows = read_table(make_table(tmp_path / "t.csv", vocab, sequences=("00",), windows=5))
    tr, va, note = split(windows)
    assert tr and va and "halves" in note
    assert max(w.end for w in tr) <= min(w.start for w in va)
    # every corruption of one window stays on one side
    assert not {(w.start, w.end) for w in tr} & {(w.start, w.end) for w in va}


def test_read_table_labels(tmp_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    windows = read_table(make_table(tmp_path / "t.csv", vocab, sequences=("00",), windows=2))
    assert len(windows) == 4  # 2 windows × (none, dark)
    dark = [w for w in windows if w.corruption == "dark"]
    assert all(w.label == "ORB" for w in dark) and all(w.context["light"] == "dark" for w in dark)
    assert all(set(w.best_params) == set(vocab.extractors) for w in windows)
    assert all(w.context["motion"] is None for w in windows)


@pytest.mark.slow  # a real nfex process that seeds nothing but trains
def test_cli_train_writes_a_loadable_model(tmp_path: Path, store_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    table = make_table(tmp_path / "t.csv", vocab, windows=4)
    out = tmp_path / "model"
    p = subprocess.run(
        [sys.executable, "-m", "nfex_core.cli.main", "--store", str(store_path), "train", "--table", str(table),
         "--out", str(out), "--epochs", "3", "--no-images", "--val-sequences", "00", "--refit-all"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert p.returncode == 0, p.stderr
    answer = json.loads(p.stdout)
    assert "validate ['kitti/00']" in answer["split"]
    assert {"val_accuracy", "val_cross_entropy"} <= set(answer["validation"]["selectornet"])
    assert sorted(f.name for f in out.iterdir()) == ["manifest.json", "paramnet.npz", "selectornet.npz"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["data"]["weights_trained_on"].startswith("all windows") and manifest["training"]["epochs"] == 3


def test_auto_epochs() -> None:
    assert auto_epochs(24, 8) == 1334 and auto_epochs(10_000, 8) == 300


def test_cli_train_missing_table_exits_2(tmp_path: Path, store_path: Path) -> None:
    p = subprocess.run(
        [sys.executable, "-m", "nfex_core.cli.main", "--store", str(store_path), "train", "--table", str(tmp_path / "no.csv")],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert p.returncode == 2 and "no training table" in p.stderr
