"""The per-frame time budget: a cost check per candidate after the compiled table's lookup (issue 8).

The budget (ms of feature extraction per frame) is part of a request's context but not a condition
dimension of the finite table (DESIGN.md, "The one flow"): the table gives C(E) and Θ′ per
candidate, then for each candidate the cost model (nfex_core/evidence/cost.py) gives its expected time at the
frame's size, times the client's compute-class factor. Over the budget:

1. fit: when the extractor's cost model has a features or levels term, lower NF (down to a quarter
   of Θ′, never below its range) and then NL (down to 4, or its minimum) to the largest setting whose
   expected time is within the budget; the candidate stays, its Θ′ adjusted, citing
   ``nfex:rule_budget_fit`` — this is what keeps a better extractor inside the budget;
2. else prune it, citing ``nfex:rule_budget`` with the expected and allowed times.

A rule marked ``nfex:relativeToBest`` (measured ATE over k× the best extractor's) judges against the
best of *all* extractors; under a budget the advisor re-admits what it pruned when that extractor is
affordable and within k× the best *affordable* extractor's median ATE (the Decision's evidence), saying so.

If the budget prunes every candidate, the advisor falls back to the cheapest one (a front end needs
features every frame) and says so in the selection's warnings; NoCandidate stays for candidates the
accuracy rules prune. A candidate whose extractor has no measured cost is pruned under a budget (it
cannot be shown to fit); when the graph has no cost measurements at all the budget is not applied
and the selection warns.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..errors import UnknownName
from ..evidence.cost import BudgetTerms, CostModel, Estimate
from ..kg.namespaces import NFEX
from ..kg.vocab import ExtractorSpec, Value
from ..rules.types import Adjustment, Citation

BUDGET_RULE = str(NFEX.rule_budget)
FIT_RULE = str(NFEX.rule_budget_fit)
NF_STEPS = (1.0, 0.85, 0.7, 0.6, 0.5, 0.4, 0.33, 0.25)
MIN_LEVELS = 4


def citation(terms: BudgetTerms, rule: str, reason: str) -> Citation:
    return Citation(rule, terms.labels.get(rule, rule.rsplit("#", 1)[-1]), reason, "budget")


@dataclass(frozen=True)
class Budget:
    """A request's budget, resolved: its ms, where it came from, the compute factor and frame size."""

    ms: float
    source: str  # "given" | "agent default (drone)"
    compute: str
    factor: float
    width: int
    height: int
    size_source: str  # "frame" | "given" | "assumed: …"

    def as_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def resolve_budget(
    terms: BudgetTerms,
    cost: CostModel,
    context: Mapping[str, str | None],
    budget_ms: float | None,
    compute: str | None,
    frame_size: tuple[int, int] | None,
    size_source: str,
) -> Budget | None:
    """The budget in force: the client's, else the agent's default; None when there is none."""
    if compute is not None and compute not in terms.compute:
        raise UnknownName("compute class", compute, terms.compute)
    source = "given"
    if budget_ms is None:
        agent = context.get("agent")
        if agent is None or agent not in terms.agent_defaults:
            return None
        budget_ms, source = terms.agent_defaults[agent], f"agent default ({agent})"
    if frame_size is None:
        frame_size, size_source = cost.typical_size or (640, 480), "assumed: the size most measurements were made at"
    name = compute or "reference"
    return Budget(float(budget_ms), source, name, terms.compute.get(name, 1.0), frame_size[0], frame_size[1], size_source)


@dataclass
class BudgetOutcome:
    params: dict[str, dict[str, Value]]  # Θ′ per surviving candidate (fitted where adjusted)
    adjustments: dict[str, list[Adjustment]]
    pruned: dict[str, tuple[Citation, ...]]
    estimates: dict[str, Estimate]
    warnings: list[str]
    readmitted: dict[str, str] = field(default_factory=dict)  # pruned relative to an unaffordable best


def expected(cost: CostModel, spec: ExtractorSpec, theta: Mapping[str, Value], b: Budget) -> Estimate:
    """The expected extraction time of Θ on the budget's frame size and compute class."""
    e = cost.expected(spec, theta, b.width, b.height)
    return Estimate(e.ms * b.factor, e.source, e.measurements) if e.ms is not None else e


def fit_params(
    cost: CostModel, spec: ExtractorSpec, theta: Mapping[str, Value], b: Budget
) -> tuple[dict[str, Value], Estimate] | None:
    """The largest NF (then NL) below Θ′ whose expected time is within the budget, or None."""
    model = cost.extractors.get(spec.name)
    if model is None or not model.has_terms:
        return None
    nf = model.nf if model.per_kfeature > 0 else None
    nl = model.nl if model.per_mp_level > 0 else None
    nf_values = [spec.parameters[nf].clamp(float(theta[nf]) * s) for s in NF_STEPS] if nf else [None]
    levels: list[Any] = [None]
    if nl:
        p = spec.parameters[nl]
        low = max(int(p.min) if p.min is not None else 1, min(MIN_LEVELS, int(theta[nl])))
        levels = list(range(int(theta[nl]), low - 1, -1))
    for level in levels:  # keep the pyramid first: fewer features cost less accuracy than fewer scales
        for count in nf_values:
            trial = dict(theta)
            if count is not None:
                trial[nf] = count  # type: ignore[index]
            if level is not None:
                trial[nl] = level  # type: ignore[index]
            e = expected(cost, spec, trial, b)
            if e.ms is not None and e.ms <= b.ms:
                return trial, e
    return None


def apply_budget(
    cost: CostModel,
    terms: BudgetTerms,
    specs: Mapping[str, ExtractorSpec],
    theta: Mapping[str, dict[str, Value]],
    b: Budget,
) -> BudgetOutcome:
    """Check every candidate's expected time against the budget: keep, fit Θ′, or prune (with citations)."""
    out = BudgetOutcome({}, {}, {}, {}, [])
    if not cost.extractors:
        out.warnings.append("the graph has no measured extraction times: the budget was not applied")
    allowed = f"the budget {b.ms:g} ms ({b.source}, compute {b.compute} ×{b.factor:g}, {b.width}×{b.height})"
    for x, params in theta.items():
        spec = specs[x]
        e = expected(cost, spec, params, b)
        out.estimates[x] = e
        if e.ms is None and not cost.extractors:  # nothing measured at all: the budget cannot be applied
            out.params[x] = dict(params)
            continue
        if e.ms is None:
            out.pruned[x] = (citation(terms, BUDGET_RULE, f"{e.describe()}, so it cannot be shown to fit {allowed}"),)
            continue
        if e.ms <= b.ms:
            out.params[x] = dict(params)
            continue
        fitted = fit_params(cost, spec, params, b)
        if fitted is not None:
            new, fe = fitted
            reason = f"expected {e.ms:.1f} ms over {allowed}; fitted to {fe.describe()}"
            cite = citation(terms, FIT_RULE, reason)
            out.params[x] = new
            out.estimates[x] = fe
            out.adjustments[x] = [
                Adjustment(k, params[k], new[k], float(new[k]) / float(params[k]) if float(params[k]) else 1.0, (cite,))
                for k in new if new[k] != params[k]
            ]
            continue
        out.pruned[x] = (citation(terms, BUDGET_RULE, f"expected {e.describe()} exceeds {allowed}"),)
    return out


def settle(
    cost: CostModel,
    terms: BudgetTerms,
    specs: Mapping[str, ExtractorSpec],
    ates: Mapping[str, float],
    theta: Mapping[str, dict[str, Value]],
    relative: Sequence[str],
    b: Budget,
) -> BudgetOutcome:
    """The budget over every admitted candidate ``theta`` (the ``relative`` ones among them were pruned by a
    relative-accuracy rule): fit or prune each, re-admit a relative one that is affordable and within k× the
    best affordable median ATE (``ates``), drop the other relative ones, and when nothing is left fall back to
    the cheapest of ``theta``. The survivors are the outcome's ``params``."""
    outcome = apply_budget(cost, terms, specs, theta, b)
    best = min((ates[x] for x in outcome.params if x in ates), default=None)
    for x in relative:
        ok = x in outcome.params and x in ates and best is not None and terms.max_relative_ate is not None
        if ok and ates[x] <= terms.max_relative_ate * best and best > min(ates.values()):  # type: ignore[operator]
            outcome.readmitted[x] = (
                f"re-admitted: median ATE {ates[x]:.3g} m is within {terms.max_relative_ate:g}x the best affordable "
                f"extractor's {best:.3g} m; the more accurate ones are over the budget"
            )
            outcome.warnings.append(f"{x}: {outcome.readmitted[x]}")
            continue
        for d in (outcome.params, outcome.estimates, outcome.adjustments, outcome.pruned):
            d.pop(x, None)
    if not outcome.params and theta:  # the fallback may also take what was pruned relative to an unaffordable best
        x, params, adj, e = cheapest(cost, terms, specs, theta, b)
        if x in relative:
            outcome.readmitted[x] = "re-admitted as the cheapest extractor: nothing fits the budget"
        outcome.pruned.pop(x, None)
        outcome.params[x] = params
        outcome.adjustments[x] = adj
        outcome.estimates[x] = e
        outcome.warnings.append(
            f"every candidate's expected extraction time exceeds the budget {b.ms:g} ms; running the cheapest, "
            f"{x} at {e.describe()}"
        )
    return outcome


def cheapest(
    cost: CostModel, terms: BudgetTerms, specs: Mapping[str, ExtractorSpec], theta: Mapping[str, dict[str, Value]], b: Budget
) -> tuple[str, dict[str, Value], list[Adjustment], Estimate]:
    """When nothing fits: the candidate whose cheapest setting (lowest NF and NL the fit may use) costs least."""
    best: tuple[str, dict[str, Value], list[Adjustment], Estimate] | None = None
    for x, params in theta.items():
        spec = specs[x]
        floor = fit_params(cost, spec, params, Budget(float("inf"), b.source, b.compute, b.factor, b.width, b.height, b.size_source))
        trial = dict(params)
        model = cost.extractors.get(x)
        if floor is not None and model is not None:
            if model.nf and model.per_kfeature > 0:
                trial[model.nf] = spec.parameters[model.nf].clamp(float(params[model.nf]) * NF_STEPS[-1])
            if model.nl and model.per_mp_level > 0:
                p = spec.parameters[model.nl]
                trial[model.nl] = max(int(p.min) if p.min is not None else 1, min(MIN_LEVELS, int(params[model.nl])))
        e = expected(cost, spec, trial, b)
        if e.ms is None:
            continue
        if best is None or e.ms < (best[3].ms or float("inf")):
            reason = f"every candidate exceeds the budget {b.ms:g} ms; the cheapest setting: {e.describe()}"
            cite = citation(terms, FIT_RULE, reason)
            adj = [Adjustment(k, params[k], trial[k], float(trial[k]) / float(params[k]) if float(params[k]) else 1.0, (cite,))
                   for k in trial if trial[k] != params[k]]
            best = (x, trial, adj, e)
    if best is None:  # no cost known at all: keep the first candidate as it is
        x = next(iter(theta))
        return x, dict(theta[x]), [], Estimate(None, "unknown")
    return best
