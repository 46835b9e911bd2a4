"""Statistics of paired runs: a method's mean with a 95 % confidence interval, and a paired comparison.

Runs are paired: run r uses the same seed (corruption draws, RANSAC order) for every method, so the
difference d_r = ATE_r(method) − ATE_r(reference) removes what the draw does to both. Reported:

- mean and 95 % CI of the mean: x̄ ± t_{0.975, n−1} · s / √n (Student's t);
- the paired test: Wilcoxon's signed-rank test on d_r, two-sided, exact for small n (scipy.stats.wilcoxon);
  it assumes no distribution of ATE (ATE over runs is skewed: a lost track costs metres). The paired t
  test (scipy.stats.ttest_rel) is reported beside it. A difference is claimed only where Wilcoxon's
  p < 0.05; otherwise the table says "on par".
- the relative difference of the means, (x̄ − ȳ) / ȳ;
- beside each verdict, the smallest relative difference the comparison could have detected: at α = 0.05
  (two-sided) with 80 % power, the paired t test detects a mean difference of
  δ = (t_{0.975, n−1} + t_{0.80, n−1}) · s_d / √n (s_d: the differences' standard deviation); Wilcoxon's
  signed-rank test needs about 1/(3/π) as many pairs again (its Pitman efficiency against t is 3/π ≈ 0.955
  for normal differences), so δ_W = δ / √(3/π), reported relative to |ȳ|. With n ≤ 5 pairs Wilcoxon's
  smallest two-sided p is 2/2ⁿ ≥ 0.0625: no difference is detectable (``detectable`` is None).

A figure where higher is better (pose AUC) is compared the same way; its verdict reads the sign the other way.

A run that failed (the VO lost more than the allowed fraction of pairs) has no ATE; a comparison uses the
runs where both methods have one and says how many that was.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

ALPHA = 0.05
POWER = 0.80
WILCOXON_ARE = 3.0 / math.pi


@dataclass(frozen=True)
class Summary:
    n: int
    mean: float | None
    ci95: tuple[float, float] | None

    def as_dict(self) -> dict[str, Any]:
        return {"n": self.n, "mean": self.mean, "ci95": list(self.ci95) if self.ci95 else None}


def summary(values: Sequence[float | None]) -> Summary:
    xs = np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    if len(xs) == 0:
        return Summary(0, None, None)
    mean = float(xs.mean())
    if len(xs) < 2:
        return Summary(len(xs), mean, None)
    from scipy.stats import t

    half = float(t.ppf(0.975, len(xs) - 1) * xs.std(ddof=1) / math.sqrt(len(xs)))
    return Summary(len(xs), mean, (mean - half, mean + half))


@dataclass(frozen=True)
class Comparison:
    """``method`` against ``reference`` over the runs both completed."""

    reference: str
    pairs: int
    relative: float | None  # (mean − reference mean) / reference mean, over the paired runs
    p_wilcoxon: float | None
    p_ttest: float | None
    detectable: float | None = None  # the smallest relative difference detectable at α = 0.05, 80 % power
    higher_is_better: bool = False

    @property
    def verdict(self) -> str:
        """"better" / "worse" where Wilcoxon's p < 0.05, else "on par"."""
        if self.p_wilcoxon is None or self.relative is None or self.p_wilcoxon >= ALPHA:
            return "on par"
        return "better" if (self.relative > 0) == self.higher_is_better else "worse"

    def as_dict(self) -> dict[str, Any]:
        return {"reference": self.reference, "pairs": self.pairs, "relative": self.relative,
                "p_wilcoxon": self.p_wilcoxon, "p_ttest": self.p_ttest, "verdict": self.verdict,
                "detectable_relative": self.detectable}


def detectable(d: np.ndarray, reference_mean: float) -> float | None:
    """The smallest |relative difference| Wilcoxon could detect over the paired differences ``d`` (module
    docstring); None with under 6 pairs or a zero reference; 0 where every pair differs alike."""
    n = len(d)
    if n < 2 or 2.0 / 2.0**n >= ALPHA or reference_mean == 0 or not math.isfinite(reference_mean):
        return None
    from scipy.stats import t

    delta = (t.ppf(1 - ALPHA / 2, n - 1) + t.ppf(POWER, n - 1)) * float(np.std(d, ddof=1)) / math.sqrt(n)
    return float(delta / math.sqrt(WILCOXON_ARE) / abs(reference_mean))


def compare(values: Sequence[float | None], reference: Sequence[float | None], name: str,
            higher_is_better: bool = False) -> Comparison:
    """Paired comparison of two per-run series (index = run)."""
    pairs = [(a, b) for a, b in zip(values, reference, strict=True)
             if a is not None and b is not None and math.isfinite(a) and math.isfinite(b)]
    if len(pairs) < 2:
        return Comparison(name, len(pairs), None, None, None, None, higher_is_better)
    a = np.array([p[0] for p in pairs], dtype=float)
    b = np.array([p[1] for p in pairs], dtype=float)
    rel = float((a.mean() - b.mean()) / b.mean()) if b.mean() != 0 else None
    d = a - b
    mde = detectable(d, float(b.mean()))
    if np.allclose(d, 0):
        return Comparison(name, len(pairs), rel, 1.0, 1.0, mde, higher_is_better)
    from scipy.stats import ttest_rel, wilcoxon

    p_w = float(wilcoxon(a, b).pvalue)
    if np.ptp(d) <= 1e-12 * max(1.0, float(np.abs(d).max())):
        # every pair differs alike: t is undefined (zero variance)
        return Comparison(name, len(pairs), rel, p_w, None, mde, higher_is_better)
    p_t = float(ttest_rel(a, b).pvalue)
    return Comparison(name, len(pairs), rel, p_w, p_t if math.isfinite(p_t) else None, mde, higher_is_better)
