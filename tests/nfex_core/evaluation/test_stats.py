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
