"""Pooling sequences: the reference by mean rank, ATE divided per sequence before the paired test over
(sequence, run) pairs, the detectable difference; and the manifest that joins other datasets' sequences."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nfex_core.errors import BadInput
from nfex_core.evaluation import Evaluation, RunRecord
from nfex_core.evaluation.figures import BY_NAME
from nfex_core.evaluation.pooled import Study, paired, pooled_figure, pooled_json, pooled_markdown, reference
from nfex_core.evaluation.sources import Source, from_arguments, read_manifest


def _rec(method: str, ate: float, run: int, auc: float) -> RunRecord:
    return RunRecord(method, "none", run, ate, 0.1, False, 0, 0, 10, 5.0, 7.5, 1.0, 5.0, 0.1,
                     auc={5.0: auc / 2, 10.0: auc, 20.0: min(1.0, auc * 1.5)}, frontend_ate=ate / 2)


def _ev(sequence: str, scale: float, runs: int = 4) -> Evaluation:
    """SIFT 20 % below ORB in ATE on every run, at the sequence's scale of metres; nfex 10 % below SIFT."""
    recs = []
    for r in range(runs):
        base = scale * (1.0 + 0.1 * r)
        recs += [_rec("orb-default", base, r, 0.5), _rec("sift-default", 0.8 * base, r, 0.6 + 0.01 * r),
                 _rec("nfex", 0.72 * base, r, 0.62 + 0.01 * r)]
    return Evaluation("kitti", sequence, 10, recs, conditions=["none"], runs=runs, static=["orb-default", "sift-default"])


def test_ate_is_pooled_as_a_ratio_to_the_reference_on_each_sequence() -> None:
    """A long sequence (metres ×100) does not decide alone: nfex is 10 % below SIFT on both."""
    study = Study([_ev("00", 100.0), _ev("01", 1.0)])
    assert reference(study, "none", BY_NAME["ate"]) == "sift-default"
    assert reference(study, "none", BY_NAME["auc10"]) == "sift-default"
    a, b = paired(study, "nfex", "sift-default", "none", BY_NAME["ate"])
    assert len(a) == 8 and max(x for x in a if x is not None) < 1.5  # ratios, not metres
    p = pooled_figure(study, "nfex", "none", BY_NAME["ate"])
    vs = p["vs_best_static"]
    assert vs["pairs"] == 8 and vs["relative"] == pytest.approx(-0.1) and vs["verdict"] == "better"
    assert vs["detectable_relative"] is not None and vs["detectable_relative"] >= 0
    assert p["mean"] == pytest.approx(0.9) and "ratio to sift-default" in p["scale"]
    auc = pooled_figure(study, "nfex", "none", BY_NAME["auc10"])["vs_best_static"]
    assert auc["verdict"] == "better" and auc["relative"] > 0  # higher AUC is better
    js = pooled_json(study)
    assert js["sequences"] == ["kitti/00", "kitti/01"] and js["conditions"]["none"]["best_static"]["ate"] == "sift-default"
    md = pooled_markdown(study)
    assert "### Pooled over kitti/00, kitti/01: none" in md and "(reference)" in md


def test_the_reference_is_the_best_mean_rank_not_the_best_on_the_longest_sequence() -> None:
    a, b = _ev("00", 100.0), _ev("01", 1.0)
    for r in a.records:  # on 00 alone, ORB is slightly ahead of SIFT
        if r.method == "orb-default":
            r.ate_rmse = 0.7 * (r.ate_rmse or 0)
    c = _ev("07", 5.0)
    assert reference(Study([a, b, c]), "none", BY_NAME["ate"]) == "sift-default"  # ranks 2, 1, 1 against 1, 2, 2


def test_sources_from_arguments_and_a_manifest(tmp_path: Path) -> None:
    assert from_arguments(Path("k"), "kitti", ["00", "07"], 1) == [Source(Path("k"), "kitti", "00"), Source(Path("k"), "kitti", "07")]
    assert from_arguments(Path("k"), "kitti", [], 2) == [Source(Path("k"), "kitti", None, 2)]
    assert from_arguments(None, "kitti", ["00"], 1) == []
    m = tmp_path / "m.toml"
    m.write_text('[[sequence]]\npath = "kitti"\nsequence = "07"\n\n'
                 '[[sequence]]\npath = "/abs/handheld"\nformat = "handheld"\nsequence = "checkerboard"\nstep = 4\n')
    assert read_manifest(m, Path("/data")) == [Source(Path("/data/kitti"), "kitti", "07"),
                                               Source(Path("/abs/handheld"), "handheld", "checkerboard", 4)]


@pytest.mark.parametrize(("text", "says"), [
    ("[[sequence]]\nformat = 'kitti'\n", "needs a path"),
    ("[[sequence]]\npath = 'k'\nframes = 3\n", "unknown: frames"),
    ("[[sequence]]\npath = 'k'\nstep = 0\n", "step must be"),
    ("title = 'x'\n", "no \\[\\[sequence\\]\\] tables"),
    ("[[sequence\n", "not TOML"),
])
def test_a_bad_manifest_names_what_is_wrong(tmp_path: Path, text: str, says: str) -> None:
    m = tmp_path / "m.toml"
    m.write_text(text)
    with pytest.raises(BadInput, match=says):
        read_manifest(m, tmp_path)
    with pytest.raises(BadInput, match="cannot read"):
        read_manifest(tmp_path / "gone.toml", tmp_path)


@settings(max_examples=30, deadline=None)
@given(scales=st.lists(st.floats(0.01, 1000.0), min_size=2, max_size=4), noise=st.integers(0, 10_000))
def test_the_pooled_ate_comparison_does_not_depend_on_each_sequences_metres(scales: list[float], noise: int) -> None:
    """Multiplying every ATE of a sequence by a constant (a longer drive, other units) changes no pooled figure."""
    import numpy as np

    def study(factors: list[float]) -> Study:
        evs = []
        for i, f in enumerate(factors):
            ev = _ev(f"{i:02d}", 1.0, runs=3)
            for r in ev.records:
                r.ate_rmse = f * (r.ate_rmse or 0) * float(np.random.default_rng((noise, i, r.run, len(r.method))).uniform(0.7, 1.3))
            evs.append(ev)
        return Study(evs)

    a = pooled_figure(study([1.0] * len(scales)), "nfex", "none", BY_NAME["ate"])
    b = pooled_figure(study(scales), "nfex", "none", BY_NAME["ate"])
    assert a["reference"] == b["reference"] and a["mean"] == pytest.approx(b["mean"], rel=1e-9)
    va, vb = a["vs_best_static"], b["vs_best_static"]
    assert va["p_wilcoxon"] == pytest.approx(vb["p_wilcoxon"]) and va["relative"] == pytest.approx(vb["relative"], rel=1e-9)
