"""Θ′ from the graph's own measurements: the best measured configuration of α under E.

Beyond the paper (its Θ′ is g(Θ, E) or ParamNet): where the graph holds Measurements of α under the
request's conditions (``RuleTable.measured``: at least ``nfex:minMeasurements`` admitted windows that
share a known condition value with the context and contradict none, none of them failed), Θ′ is the
measured configuration with the lowest median ATE among them (evidence/aggregate.py),

    Θ′ = argmin_{Θ measured for α under E} median ATE(α, Θ | E),

and under a budget the lowest among those whose expected cost fits it (else the best, which the
budget step then fits or prunes). This is the "dynamically optimised" configuration of the paper's
baselines (§V-B), read from the graph at request time and updated by every sweep or feedback commit.
ParamNet or the rules' factors set Θ′ where nothing was measured. Each parameter that differs from
the graph's default cites ``nfex:rule_measured_configuration`` (disable it as data to keep g(Θ, E)).
"""
from __future__ import annotations

from collections.abc import Sequence

from ..evidence import Aggregate
from ..evidence.cost import CostModel
from ..kg.namespaces import NFEX
from ..kg.vocab import ExtractorSpec, Value
from ..rules.types import Adjustment, Citation, MeasuredConfiguration
from .budget import Budget, expected

MEASURED_RULE = str(NFEX.rule_measured_configuration)
MEASURED_LABEL = "Best measured configuration under these conditions"


def measured_params(
    spec: ExtractorSpec,
    ranked: Sequence[MeasuredConfiguration],
    conditions: str,
    cost: CostModel | None = None,
    budget: Budget | None = None,
) -> tuple[dict[str, Value], list[Adjustment], MeasuredConfiguration, Citation]:
    """Θ′ from ``ranked`` (lowest median ATE first, each a full Θ valid in the graph; ``conditions`` names
    the context for the reason), the adjustments from the defaults citing the measurement, the
    configuration chosen and the citation (also when Θ′ is the defaults)."""
    chosen = ranked[0]
    note = f"the lowest of {len(ranked)} measured configurations"
    if budget is not None and cost is not None:
        for c in ranked:
            e = expected(cost, spec, c.params, budget)
            if e.ms is not None and e.ms <= budget.ms:
                if c is not chosen:
                    note = (f"the lowest of the measured configurations whose expected {e.ms:.1f} ms fits "
                            f"the budget {budget.ms:g} ms (the best, {chosen.ate:.3f} m, does not)")
                chosen = c
                break
    theta = dict(chosen.params)
    cite = Citation(
        MEASURED_RULE,
        MEASURED_LABEL,
        f"{chosen.iri.rsplit('#', 1)[-1]}: {_describe(chosen)} measured under {conditions}, {note}",
        "measured",
    )
    defaults = spec.defaults()
    adjustments = [
        Adjustment(k, defaults[k], v, float(v) / float(defaults[k]) if _numeric(v) and float(defaults[k]) else 1.0, (cite,))
        for k, v in theta.items()
        if k in defaults and v != defaults[k]
    ]
    return theta, adjustments, chosen, cite


def _describe(c: MeasuredConfiguration) -> str:
    return Aggregate(c.ate, c.windows, c.outliers, c.sources).describe()


def _numeric(v: Value) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)
