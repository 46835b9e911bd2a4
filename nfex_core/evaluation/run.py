"""``nfex evaluate`` as a library function: every method × corruption × run through the VO on one
sequence, ATE (Sim(3), evo ``-as``) against the ground truth, and the cost per frame (paper §V-B,
Table I; issue 8's accuracy/cost trade-off).
"""
from __future__ import annotations

import time
from collections.abc import Sequence as Seq
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..datasets.base import Sequence
from ..vo import VOParams, VOResult, run_vo
from .methods import AdvisorChooser, chooser_for

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph


@dataclass
class RunRecord:
    method: str
    corruption: str
    run: int
    ate_rmse: float | None
    failed: bool
    lost: int
    frames: int
    extraction_ms: float  # mean per frame
    matching_ms: float  # mean per frame pair
    wall_s: float
    note: str = ""
    budget_ms: float | None = None
    result: VOResult | None = field(default=None, repr=False)
    selections: list[dict[str, Any]] = field(default_factory=list, repr=False)

    @property
    def ms_per_frame(self) -> float:
        return self.extraction_ms + self.matching_ms


@dataclass
class Evaluation:
    dataset: str
    sequence: str
    frames: int
    records: list[RunRecord]
    ground_truth: np.ndarray | None = None

    def methods(self) -> list[str]:
        return list(dict.fromkeys(r.method for r in self.records if r.budget_ms is None))

    def corruptions(self) -> list[str]:
        return list(dict.fromkeys(r.corruption for r in self.records))

    def cell(self, method: str, corruption: str | None = None, budget: float | None = None) -> list[RunRecord]:
        return [r for r in self.records if r.method == method and (corruption is None or r.corruption == corruption)
                and r.budget_ms == budget]

    @staticmethod
    def mean_ate(records: Seq[RunRecord]) -> float | None:
        ok = [r.ate_rmse for r in records if not r.failed and r.ate_rmse is not None]
        return float(np.mean(ok)) if ok else None


def evaluate(
    sequence: Sequence,
    kg: KnowledgeGraph,
    *,
    methods: Seq[str],
    runs: int = 1,
    corruptions: Seq[str] = ("none",),
    severity: float = 0.7,
    budgets: Seq[float] = (),
    frames: int | None = None,
    progress: bool = False,
) -> Evaluation:
    """Run every method (and nFEX at each budget) on ``sequence`` and each corruption, ``runs`` times."""
    from ..sweeps.cells import window_errors
    from ..vision.registry import ExtractorRegistry

    registry = ExtractorRegistry.from_vocabulary(kg.vocabulary())
    stop = len(sequence) if frames is None else min(frames, len(sequence))
    label = f"{sequence.dataset} {sequence.name}"
    jobs: list[tuple[str, str, float | None]] = [(m, c, None) for c in corruptions for m in methods]
    jobs += [("nfex", c, b) for c in corruptions for b in budgets]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(jobs) * runs, desc="evaluate", unit="run")
    records: list[RunRecord] = []
    for method, corruption, budget in jobs:
        seq = sequence
        if corruption != "none":
            from ..datasets.corruptions import corrupt

            seq = corrupt(sequence, corruption, severity, seed=0)
        context = {k: v for k, v in seq.context.items() if v}
        for r in range(runs):
            chooser, note = chooser_for(method, kg, context, label, budget)
            t0 = time.perf_counter()
            # each run its own, reproducible RANSAC draw (runs differ as a SLAM system's would)
            res = run_vo(seq, chooser, registry=registry, stop=stop, params=VOParams(seed=r))
            ate, _ = window_errors(seq, res) if not res.failed else (None, None)
            records.append(RunRecord(
                method, corruption, r, ate, res.failed or ate is None, res.lost_count, len(res.frames),
                res.mean("extraction_ms"), res.mean("matching_ms", skip_first=True), time.perf_counter() - t0,
                note, budget, res, list(chooser.selections) if isinstance(chooser, AdvisorChooser) else [],
            ))
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    gt = sequence.poses[:stop] if sequence.poses is not None else None
    return Evaluation(sequence.dataset, sequence.name, stop, records, gt)
