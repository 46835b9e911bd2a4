"""The trust rule (evidence/trust.py) and the robust aggregate (evidence/aggregate.py) on made-up observations."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nfex_core.evidence import Observation, TrustPolicy, admit, robust

CAR = frozenset({("agent", "car")})


def obs(i: int, reporter: str | None = None, cfg: str = "cfg_a", conditions: frozenset[tuple[str, str]] = CAR,
        accepted: str | None = None, run: str | None = "run_sweep") -> Observation:
    return Observation(f"m{i}", "ORB", cfg, conditions, ate=0.1, run=run, reporter=reporter, accepted_by=accepted)


def test_own_measurements_count_reports_need_min_sources_or_an_editor() -> None:
    items = [obs(0), obs(1, run=None),  # a sweep's, an editor's
             obs(2, "carol"), obs(3, "carol"), obs(4, "dave"),  # two reporters: not enough for 3
             obs(5, "erin", cfg="cfg_c", accepted="alice"),  # accepted (alone on its configuration)
             obs(6, "x", cfg="cfg_b"), obs(7, "y", cfg="cfg_b"), obs(8, "z", cfg="cfg_b")]  # corroborated
    a = admit(items, TrustPolicy(min_sources=3))
    assert set(a.admitted) == {"m0", "m1", "m5", "m6", "m7", "m8"}
    assert set(a.quarantined) == {"m2", "m3", "m4"}
    assert "2 of the 3 reporters" in a.quarantined["m2"] and "accepted by alice" in a.admitted["m5"]
    assert a.admitted["m6"] == "report corroborated by 3 reporters"


def test_corroboration_needs_the_same_configuration_and_the_same_conditions() -> None:
    dark = frozenset({("agent", "car"), ("light", "dark")})
    items = [obs(0, "x"), obs(1, "y", conditions=dark), obs(2, "z", cfg="cfg_b")]
    assert not admit(items, TrustPolicy(min_sources=2)).admitted
    assert set(admit(items + [obs(3, "w")], TrustPolicy(min_sources=2)).admitted) == {"m0", "m3"}


def test_one_reporter_many_reports_is_one_source() -> None:
    items = [obs(i, "carol") for i in range(50)]
    assert not admit(items, TrustPolicy(min_sources=2)).admitted


def test_the_median_and_its_outliers() -> None:
    agg = robust([0.10, 0.11, 0.12, 0.13, 5.0], ["a", "b", "a"])
    assert agg.value == pytest.approx(0.12) and agg.windows == 5 and agg.outliers == 1 and agg.sources == ("a", "b")
    assert "median ATE 0.120 m over 5 windows from 2 sources (1 outlier)" == agg.describe()
    assert robust([1.0, 1.0, 1.0, 9.0]).outliers == 0  # MAD = 0: nothing is flagged


@given(st.lists(st.floats(0, 100, allow_nan=False), min_size=3, max_size=40), st.floats(1e3, 1e9))
def test_a_minority_of_wild_windows_moves_the_median_no_further_than_the_honest_range(values: list[float], wild: float) -> None:
    """Breakdown point: fewer wild windows than honest ones keep the median inside the honest values."""
    k = (len(values) - 1) // 2
    agg = robust(values + [wild] * k)
    assert min(values) <= agg.value <= max(values)
    assert agg.value == pytest.approx(float(np.median(values + [wild] * k)))
