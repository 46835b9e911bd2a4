"""``nfex evaluate`` as a library function: every method × condition × paired run through the same VO.

- **Paired runs.** Run r uses seed r for every method: the corruption's draws and the RANSAC order, so
  two methods' run-r ATEs differ by their choices alone (``stats``).
- **Conditions.** Each whole-sequence corruption of ``corruptions`` (``none`` is the sequence as it is),
  and a ``schedule`` (``datasets.schedule``) under the condition name ``schedule``.
- **Evidence scope.** Every method reads the graph through one scope that holds the evaluated sequence
  out (``identity.sequence_iri``; ``kg.scope``): the dynamic baselines, tuned-static and the advisor
  alike, by construction.
- **The same front end.** Every method runs with the front-end checks of the sequence's agent from the
  graph (``motion.StepChecks``), unless ``checks`` is False.
- **Oracles** (``oracle``): the hindsight choices over the static methods' own pair estimates (``oracle``).

- **Shared work.** Every method and run of a sequence extracts and matches through one ``nfex_slam.vo.Reusing``:
  a configuration's features of an image, and the matches of two such extractions, are computed once — paired
  runs of a clean sequence see the same images — and reused with the time they took when computed.

- **The motion-prior control** (``outcomes``): in every condition and run, the first tracked step of the first
  static method repeated at constant velocity — what coasting alone gives.

Per run: the front-end figures (pose AUC at 5/10/20°, the ATE with ground-truth step lengths; ``outcomes``),
ATE and RPE (Sim(3), evo ``-as``), per segment and per transition pair under a schedule, lost and coasted
pairs (coasted: rejected by the front-end checks, or sent to the motion prior by verification), candidates
tried per pair (mean and max), extraction ms per frame (mean and max: what a budget bounds, every try and the
re-extraction on a switch included), matching ms, and the cost model's expected ms of the configurations run.
A run fails on loss beyond 30 % of its pairs or coasting beyond ``nfex:maxCoastedFraction`` (``outcomes``).
"""
from __future__ import annotations

import time
from collections.abc import Sequence as Seq
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from nfex_slam.datasets.base import Sequence
from nfex_slam.datasets.schedule import SCHEDULE, Schedule, under
from nfex_slam.motion import NO_CHECKS, StepChecks
from nfex_slam.vo import Reusing, VOParams, VOResult, run_vo

from ..errors import BadInput
from ..kg.rdf.identity import sequence_iri
from ..kg.scope import EvidenceScope, scoped_graph
from .figures import ATE, Figure, rank
from .methods import (
    NFEX,
    ORACLES,
    TUNED,
    AdvisorChooser,
    DynChooser,
    chooser_for,
    static_methods,
    tuned_static,
)
from .oracle import per_pair, per_segment, replay
from .outcomes import MOTION_PRIOR, Outcomes, frontend, max_coasted_fraction, motion_prior
from .record import RunRecord
from .segments import by_segment, run_errors, transitions

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph
    from ..rules.engine import RuleTable


@dataclass
class Evaluation:
    dataset: str
    sequence: str
    frames: int
    records: list[RunRecord]
    ground_truth: np.ndarray | None = None
    conditions: list[str] = field(default_factory=list)
    schedule: Schedule | None = None
    severity: float = 0.7
    runs: int = 1
    checks: str = "off"
    scope: str = ""
    static: list[str] = field(default_factory=list)
    max_coasted: float | None = None  # nfex:maxCoastedFraction as read from the graph
    control: str = ""  # where the motion-prior control's step comes from
    skipped: dict[str, str] = field(default_factory=dict)  # method → why it could not run on this sequence

    @property
    def label(self) -> str:
        return f"{self.dataset}/{self.sequence}"

    def keys(self) -> list[str]:
        return list(dict.fromkeys(r.key for r in self.records))

    def methods(self) -> list[str]:
        return list(dict.fromkeys(r.method for r in self.records if r.budget_ms is None))

    def corruptions(self) -> list[str]:
        return self.conditions

    def cell(self, method: str, condition: str | None = None, budget: float | None = None) -> list[RunRecord]:
        return [r for r in self.records if r.method == method and (condition is None or r.condition == condition)
                and r.budget_ms == budget]

    def by_key(self, key: str, condition: str) -> list[RunRecord]:
        return sorted((r for r in self.records if r.key == key and r.condition == condition), key=lambda r: r.run)

    def ates(self, key: str, condition: str) -> list[float | None]:
        """Run r's ATE at index r (None: failed)."""
        return [None if r.failed else r.ate_rmse for r in self.by_key(key, condition)]

    def values(self, key: str, condition: str, figure: Figure) -> list[float | None]:
        """Run r's value of ``figure`` at index r (None: the run has none)."""
        return [figure.of(r) for r in self.by_key(key, condition)]

    @staticmethod
    def mean_ate(records: Seq[RunRecord]) -> float | None:
        ok = [r.ate_rmse for r in records if not r.failed and r.ate_rmse is not None]
        return float(np.mean(ok)) if ok else None

    def best_static(self, condition: str, budget: float | None = None, figure: Figure = ATE) -> str | None:
        """The static method best by ``figure`` (``figures.rank``: for ATE the fewest failed runs, then the
        lowest mean); under a budget only those whose expected extraction ms per frame (the cost model's, the
        advisor's criterion) fits it."""
        best: tuple[int, float, str] | None = None
        for m in self.static:
            recs = self.by_key(m, condition)
            if not recs:
                continue
            if budget is not None:
                exp = [r.expected_ms for r in recs]
                if any(e is None for e in exp) or float(np.mean([e for e in exp if e is not None])) > budget:
                    continue
            ok = [v for v in (figure.of(r) for r in recs) if v is not None]
            key = (*rank(figure, sum(r.failed for r in recs), float(np.mean(ok)) if ok else None), m)
            if best is None or key < best:
                best = key
        return best[2] if best is not None else None


VO_SCALES = {"two-view": "triangulated", "map": "map"}  # nfex evaluate --vo → VOParams.scale


def evaluate(
    sequence: Sequence,
    kg: KnowledgeGraph,
    *,
    methods: Seq[str],
    runs: int = 5,
    corruptions: Seq[str] = ("none",),
    severity: float = 0.7,
    budgets: Seq[float] = (),
    frames: int | None = None,
    schedule: str | None = None,
    checks: bool = True,
    oracle: bool = False,
    control: bool = True,
    progress: bool = False,
    session: bool = False,
    vo: str = "two-view",
) -> Evaluation:
    """Run every method (and nFEX at each budget) on ``sequence`` under each condition, ``runs`` paired times;
    with ``control``, the motion-prior control beside them.
    ``session``: nFEX decides as a service session does (methods.AdvisorChooser). ``vo``: ``two-view`` (each
    step's length from the points the previous step also triangulated) or ``map`` (the local map with its window
    bundle adjustment, docs/vo.md)."""
    if vo not in VO_SCALES:
        from ..errors import BadInput

        raise BadInput(f"vo must be one of {', '.join(VO_SCALES)}, not {vo!r}")
    from ..advisor import Advisor
    from ..rules.engine import RuleEngine
    from ..vision.registry import ExtractorRegistry

    seq = sequence[: min(frames, len(sequence))] if frames is not None and frames < len(sequence) else sequence
    sched = Schedule.parse(schedule, len(seq)) if schedule else None
    scope = EvidenceScope.holding_out([sequence_iri(seq.dataset, seq.name)])
    view = scoped_graph(kg, scope)
    vocab = view.vocabulary()
    table = RuleEngine(view).table()
    registry = Reusing(ExtractorRegistry.from_vocabulary(vocab))  # paired runs share extractions and matches
    advisor = Advisor(view, scope=scope) if NFEX in methods or budgets else None
    agent = seq.context.get("agent")
    step_checks = table.step_checks.get(agent or "", NO_CHECKS) if checks else NO_CHECKS
    conditions = [*corruptions, *([SCHEDULE] if sched else [])]
    skipped = _without_evidence(methods, table)
    methods = [m for m in methods if m not in skipped]
    static = [m for m in methods if m in static_methods(vocab)]
    jobs: list[tuple[str, float | None]] = [(m, None) for m in methods] + [(NFEX, b) for b in budgets]
    n_oracle = len(ORACLES) if oracle and static else 0
    prior_from = (static or [m for m in methods] or [NFEX])[0] if control and jobs else None
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(conditions) * runs * (len(jobs) + n_oracle), desc=f"evaluate {seq.dataset}/{seq.name}",
                   unit="run")
    trial = _Trial(registry, step_checks, seq, sched, _ExpectedCost(vocab, table), bar, max_coasted_fraction(view),
                   VO_SCALES[vo])
    context = {k: v for k, v in seq.context.items() if v}
    for condition in conditions:
        for r in range(runs):
            trial.start(condition, r, under(seq, condition, severity, r, sched))
            static_runs: dict[str, VOResult] = {}
            prior_source: VOResult | None = None
            for method, budget in jobs:
                chooser, note = chooser_for(method, vocab, table, advisor, context, budget, session)
                rec = trial.measure(method, chooser, note, budget)
                if method in static and rec.result is not None:
                    static_runs[method] = rec.result
                if method == prior_from and budget is None:
                    prior_source = rec.result
            if prior_source is not None:
                trial.control(motion_prior(prior_source), f"the first tracked step of {prior_from}, at constant velocity")
            if n_oracle:
                fallback = min(static_runs, key=lambda m: (trial.ate_or_inf(m), m))
                seg_choices, taken = per_segment(static_runs, sched, fallback)
                trial.measure("oracle-segment", replay(seg_choices), "per segment: " + ", ".join(
                    f"{s} {m}" for s, m in taken.items()), None)
                trial.measure("oracle-pair", replay(per_pair(static_runs, fallback)),
                              "per frame pair, the static estimate closest to the ground truth", None)
    records = trial.records
    if bar is not None:
        bar.close()
    gt = seq.poses
    return Evaluation(seq.dataset, seq.name, len(seq), records, gt, conditions, sched, severity, runs,
                      _describe(step_checks), scope.describe(), [m for m in static if m in methods], trial.max_coasted,
                      f"{MOTION_PRIOR}: the first tracked step of {prior_from}, repeated at constant velocity"
                      if prior_from else "", skipped)


def _without_evidence(methods: Seq[str], table: RuleTable) -> dict[str, str]:
    """The methods that the evidence in scope cannot form (tuned static, where no configuration measured outside the
    held-out sequence is left), with why: they are left out of this sequence's tables, not the whole study."""
    if TUNED not in methods:
        return {}
    try:
        tuned_static(table)
    except BadInput as e:
        return {TUNED: str(e)}
    return {}


class _Trial:
    """Runs methods on the variant of one condition and run, and keeps their records."""

    def __init__(self, registry: Any, checks: StepChecks, seq: Sequence, sched: Schedule | None,
                 expected: _ExpectedCost, bar: Any, max_coasted: float | None, scale: str = "triangulated") -> None:
        self.registry, self.checks, self.seq, self.sched, self.expected, self.bar = registry, checks, seq, sched, expected, bar
        self.max_coasted = max_coasted
        self.scale = scale
        self.records: list[RunRecord] = []
        self.condition, self.run, self.variant = "none", 0, seq

    def start(self, condition: str, run: int, variant: Sequence) -> None:
        self.condition, self.run, self.variant = condition, run, variant

    def measure(self, method: str, chooser: Any, note: str, budget: float | None) -> RunRecord:
        t0 = time.perf_counter()
        res = run_vo(self.variant, chooser, registry=self.registry, params=VOParams(seed=self.run, scale=self.scale),
                     checks=self.checks)
        if isinstance(chooser, DynChooser):
            note = "; ".join(sorted(chooser.notes))
        rec = _record(method, self.condition, self.run, budget, res, self.seq, self.sched, self.expected,
                      time.perf_counter() - t0, note, self.max_coasted)
        rec.selections = list(chooser.selections) if isinstance(chooser, AdvisorChooser) else []
        self.records.append(rec)
        if self.bar is not None:
            self.bar.update(1)
        return rec

    def control(self, res: VOResult, note: str) -> RunRecord:
        """The motion-prior control's record: exempt from the coasting bound, no expected cost of its own."""
        rec = _record(MOTION_PRIOR, self.condition, self.run, None, res, self.seq, self.sched, self.expected, 0.0, note, None)
        rec.expected_ms = None
        self.records.append(rec)
        return rec

    def ate_or_inf(self, method: str) -> float:
        for rec in self.records:
            if (rec.method, rec.condition, rec.run, rec.budget_ms) == (method, self.condition, self.run, None):
                return rec.ate_rmse if rec.ate_rmse is not None and not rec.failed else float("inf")
        return float("inf")


def _describe(c: StepChecks) -> str:
    if not c.active:
        return "off"
    parts = []
    if c.max_rotation_rate is not None:
        parts.append(f"rotation ≤ {c.max_rotation_rate:g}°/s")
    if c.max_heading_change_rate is not None:
        parts.append(f"heading change ≤ {c.max_heading_change_rate:g}°/s")
    return f"agent {c.agent}: " + ", ".join(parts)


class _ExpectedCost:
    """The cost model's expected extraction ms of a configuration at a frame size (cached)."""

    def __init__(self, vocab: Any, table: Any) -> None:
        self.vocab, self.cost = vocab, table.cost
        self._cache: dict[tuple[Any, ...], float | None] = {}

    def __call__(self, extractor: str, params: dict[str, Any], w: int, h: int) -> float | None:
        key = (extractor, tuple(sorted(params.items())), w, h)
        if key not in self._cache:
            e = self.cost.expected(self.vocab.extractor(extractor), params, w, h)
            self._cache[key] = e.ms
        return self._cache[key]

    def mean(self, res: VOResult) -> float | None:
        values = [self(f.extractor, f.params, res.width, res.height) for f in res.frames]
        return None if any(v is None for v in values) or not values else float(np.mean(values))  # type: ignore[arg-type]


def _record(
    method: str, condition: str, run: int, budget: float | None, res: VOResult, seq: Sequence,
    sched: Schedule | None, expected: _ExpectedCost, wall_s: float, note: str, max_coasted: float | None,
) -> RunRecord:
    outcomes = Outcomes.of(res)
    fails = outcomes.fails(res.max_lost_fraction, max_coasted)
    errors = run_errors(seq.poses, res, fails)
    failed = fails or errors.ate is None
    front = frontend(seq.poses, res)
    use_sched = sched if condition == SCHEDULE else None
    return RunRecord(
        method=method, condition=condition, run=run, ate_rmse=errors.ate, rpe_rmse=errors.rpe, failed=failed,
        lost=outcomes.lost, rejected=sum(f.rejected for f in res.frames), frames=len(res.frames),
        extraction_ms=res.mean("extraction_ms"),
        extraction_max_ms=max((f.extraction_ms for f in res.frames), default=0.0),
        matching_ms=res.mean("matching_ms", skip_first=True), expected_ms=expected.mean(res), wall_s=wall_s,
        note=note, budget_ms=budget,
        tries=float(np.mean([f.tries for f in res.frames[1:]])) if len(res.frames) > 1 else 1.0,
        tries_max=max((f.tries for f in res.frames), default=1),
        fell_back=sum(f.reason.startswith("verify:") for f in res.frames),
        segments=by_segment(errors, res, use_sched, front) if use_sched else [],
        transitions=transitions(errors, res, use_sched) if use_sched else [],
        result=res, coasted=outcomes.coasted, auc=dict(front.auc) if front else {},
        frontend_ate=front.ate if front else None, front=front,
    )


__all__ = ["MOTION_PRIOR", "SCHEDULE", "TUNED", "Evaluation", "RunRecord", "evaluate"]
