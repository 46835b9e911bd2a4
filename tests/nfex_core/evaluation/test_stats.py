"""Paired statistics: the mean's 95 % interval and Wilcoxon / paired t against a reference."""
from __future__ import annotations

import math

import pytest

from nfex_core.evaluation.stats import compare, summary


def test_summary_is_the_student_t_interval() -> None:
    s = summary([1.0, 2.0, 3.0, 4.0, None])
    # mean 2.5, sd 1.2910, t(0.975, 3) = 3.1824: half width 2.0543
    assert s.n == 4 and s.mean == pytest.approx(2.5)
    assert s.ci95 == pytest.approx((2.5 - 2.0543, 2.5 + 2.0543), abs=1e-3)
    assert summary([None, None]).mean is None and summary([1.0]).ci95 is None


def test_a_consistent_paired_improvement_is_better_and_noise_is_on_par() -> None:
    ref = [1.0, 2.0, 1.5, 3.0, 2.5, 1.2, 0.8, 2.2, 1.9, 2.8]
    better = [r * 0.8 for r in ref]  # 20 % lower in every run
    c = compare(better, ref, "sift-default")
    assert c.verdict == "better" and c.relative == pytest.approx(-0.2) and c.p_wilcoxon < 0.01 and c.pairs == 10
    noisy = [r * (0.8 if i % 2 else 1.2) for i, r in enumerate(ref)]  # up and down: no consistent difference
    assert compare(noisy, ref, "sift-default").verdict == "on par"
    assert compare([r * 1.3 for r in ref], ref, "x").verdict == "worse"


def test_failed_runs_leave_the_pairs_they_break() -> None:
    c = compare([1.0, None, 2.0, 3.0], [1.5, 2.0, None, 3.5], "ref")
    assert c.pairs == 2
    assert compare([1.0, 2.0], [1.0, 2.0], "ref").verdict == "on par"
    assert compare([1.0], [2.0], "ref").p_wilcoxon is None and not math.isnan(summary([1.0]).mean or 0)


def test_higher_is_better_reads_the_sign_the_other_way() -> None:
    ref = [0.5, 0.6, 0.55, 0.7, 0.65, 0.52, 0.48, 0.62, 0.59, 0.68]
    assert compare([r * 1.2 for r in ref], ref, "x", higher_is_better=True).verdict == "better"
    assert compare([r * 0.8 for r in ref], ref, "x", higher_is_better=True).verdict == "worse"


def test_the_detectable_difference_is_what_wilcoxon_finds_four_times_in_five() -> None:
    """At the true difference it reports, the signed-rank test reaches p < 0.05 in about 80 % of simulated
    comparisons; with 5 pairs or fewer it reports none (Wilcoxon cannot reach 0.05)."""
    import numpy as np
    from scipy.stats import wilcoxon

    from nfex_core.evaluation.stats import detectable

    rng = np.random.default_rng(0)
    n, sigma = 10, 0.1
    delta = float(np.mean([detectable(rng.normal(0, sigma, n), 1.0) for _ in range(2000)]))  # type: ignore[misc]
    assert 0.09 < delta < 0.13  # (t.975,9 + t.8,9)·σ/√10/√(3/π) ≈ 0.102, less the bias of s
    hits = [wilcoxon(rng.normal(delta, sigma, n)).pvalue < 0.05 for _ in range(2000)]
    assert 0.7 < float(np.mean(hits)) < 0.9
    assert detectable(rng.normal(0, sigma, 5), 1.0) is None and detectable(rng.normal(0, sigma, 6), 0.0) is None
    assert compare([1.1, 2.2, 3.3, 4.4, 5.5, 6.6], [1, 2, 3, 4, 5, 6], "x").detectable is not None
