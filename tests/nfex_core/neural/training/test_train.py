from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from nfex_core.neural.training.dataset import folds, read_table, split
from nfex_core.neural.training.train import auto_epochs

from ..tablegen import make_table


def test_learns_the_planted_rule_better_than_every_baseline(trained) -> None:  # type: ignore[no-untyped-def]
    """The rule is in the frame statistics only (no light label): both networks beat the best constant and
    the lookup by condition labels under leave-one-sequence-out, so the default uses them."""
    report, model = trained
    m = report.metrics
    assert report.windows == {"folds": 2, "validated": 48, "all": 48} and "leave-one-sequence-out" in m["validation"]
    pn, sn = m["paramnet"], m["selectornet"]
    assert pn["val_mse"] < min(pn["val_mse_best_constant"], pn["val_mse_lookup"])
    assert sn["val_accuracy"] > max(sn["val_accuracy_best_constant"], sn["val_accuracy_lookup"])
    assert sn["val_regret"] < min(sn["val_regret_best_constant"], sn["val_regret_lookup"])
    assert set(sn["folds"]) == {"kitti/00", "kitti/01"}
    assert model.validation_gates() == {}
    assert model.manifest["data"]["sha256"] and model.manifest["training"]["lr"] == 1e-4
    assert model.manifest["code"]["git_commit"]


def test_a_constant_winner_gates_the_selector_out(tmp_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    """Where SIFT is best in every window, no selector can beat answering SIFT: it is not used."""
    from nfex_core.neural.artifacts import NeuralModel
    from nfex_core.neural.training.train import train

    table = make_table(tmp_path / "t.csv", vocab, windows=4, winner="SIFT")
    report = train(table, tmp_path / "model", vocab, epochs=5, log=lambda _m: None)
    sn = report.metrics["selectornet"]
    assert sn["best_constant"] == "SIFT" and sn["val_accuracy_best_constant"] == 1.0 and sn["val_regret_best_constant"] == 0.0
    assert "selectornet" in NeuralModel.load(report.path).validation_gates()


def test_folds_leave_each_sequence_out(tmp_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    windows = read_table(make_table(tmp_path / "t.csv", vocab, sequences=("00", "01", "02"), windows=2))
    fs, note = folds(windows)
    assert "leave-one-sequence-out" in note and len(fs) == 3
    for tr, va in fs:
        assert len({w.seq_key for w in va}) == 1 and not {w.seq_key for w in tr} & {w.seq_key for w in va}
    assert sorted(w.seq_key for _, va in fs for w in va) == sorted(w.seq_key for w in windows)
    assert len(folds(windows, ["02"])[0]) == 1


def test_tables_concatenate_plain_and_gzip(tmp_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    import gzip
    import shutil

    a = make_table(tmp_path / "a.csv", vocab, sequences=("00",), windows=2)
    b = make_table(tmp_path / "b.csv", vocab, sequences=("01",), windows=3)
    with b.open("rb") as src, gzip.open(tmp_path / "b.csv.gz", "wb") as dst:
        shutil.copyfileobj(src, dst)
    both = read_table([a, tmp_path / "b.csv.gz"])
    assert len(both) == 4 + 6 and {w.seq_key for w in both} == {"kitti/00", "kitti/01"}
    assert read_table([a, a]) == read_table(a)  # a window measured twice is one window


def test_a_scheduled_window_is_its_own_window(tmp_path: Path, vocab) -> None:  # type: ignore[no-untyped-def]
    """Two schedules over the same frames are two windows (regression: the key ignored the schedule)."""
    import csv

    src = make_table(tmp_path / "t.csv", vocab, sequences=("00",), windows=1)
    rows = [r for r in csv.DictReader(src.open()) if r["corruption"] == "none"]
    out = tmp_path / "s.csv"
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=[*rows[0], "schedule"])
        w.writeheader()
        for text in ("none:0-4,dark:5-9", "dark:0-4,none:5-9"):
            w.writerows({**r, "corruption": "schedule", "schedule": text} for r in rows)
    ws = read_table(out)
    assert sorted(w.schedule for w in ws) == ["dark:0-4,none:5-9", "none:0-4,dark:5-9"]
    assert all(w.ate and w.label for w in ws)


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
        [sys.executable, "-m", "cli.main", "--store", str(store_path), "train", "--table", str(table),
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
        [sys.executable, "-m", "cli.main", "--store", str(store_path), "train", "--table", str(tmp_path / "no.csv")],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert p.returncode == 2 and "no training table" in p.stderr
