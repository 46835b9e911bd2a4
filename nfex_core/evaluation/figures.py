"""The figures an evaluation reports per run, front-end first, and how each is compared and pooled.

| figure | per run | better | a failed run | pooled over sequences |
|---|---|---|---|---|
| ``auc5``, ``auc10``, ``auc20`` | pose AUC at 5°, 10°, 20° (``outcomes``) | higher | counts (its lost pairs at 180°) | as is |
| ``frontend_ate`` | ATE with ground-truth step lengths, SE(3), m | lower | has none | ÷ the reference's mean on the sequence |
| ``ate`` | monocular ATE, Sim(3), m | lower | has none | ÷ the reference's mean on the sequence |
| ``lost`` | lost pairs | lower | counts | as is |
| ``coasted`` | coasted pairs | lower | counts | as is |

A figure's reference in a condition is the best static method *by that figure*: the fewest failed runs for the
figures a failed run lacks, then the best mean. ATE in metres is not comparable across sequences (a long
sequence drifts more), so pooling divides each run's value by the reference's mean on its own sequence.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .record import RunRecord


@dataclass(frozen=True)
class Figure:
    name: str
    title: str
    higher_is_better: bool
    value: Callable[[RunRecord], float | None]
    failed_has_none: bool = False  # a failed run has no value
    pool_by_ratio: bool = False  # pooled as value / the reference's mean on the sequence

    def of(self, r: RunRecord) -> float | None:
        if self.failed_has_none and r.failed:
            return None
        return self.value(r)


def _auc(t: float) -> Callable[[RunRecord], float | None]:
    return lambda r: r.auc.get(t)


FIGURES: tuple[Figure, ...] = (
    Figure("auc5", "AUC@5°", True, _auc(5.0)),
    Figure("auc10", "AUC@10°", True, _auc(10.0)),
    Figure("auc20", "AUC@20°", True, _auc(20.0)),
    Figure("frontend_ate", "front-end ATE (m)", False, lambda r: r.frontend_ate, failed_has_none=True, pool_by_ratio=True),
    Figure("ate", "monocular ATE (m)", False, lambda r: r.ate_rmse, failed_has_none=True, pool_by_ratio=True),
    Figure("lost", "lost pairs", False, lambda r: float(r.lost)),
    Figure("coasted", "coasted pairs", False, lambda r: float(r.coasted)),
)
BY_NAME = {f.name: f for f in FIGURES}
ATE = BY_NAME["ate"]
HEADLINE = BY_NAME["auc10"]  # the front-end figure the tables lead with


def rank(figure: Figure, failed: int, mean: float | None) -> tuple[int, float]:
    """Sort key of a static method by ``figure`` (lower ranks first; module docstring)."""
    if mean is None:
        return (failed if figure.failed_has_none else 0, float("inf"))
    return (failed if figure.failed_has_none else 0, -mean if figure.higher_is_better else mean)
