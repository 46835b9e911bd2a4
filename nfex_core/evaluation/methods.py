"""The methods ``nfex evaluate`` compares, as VO choosers (§V-B of the paper, made honest).

Static methods — one extractor throughout — come from the graph, so an extractor added as data is a
baseline at once:

- ``<x>-default``: extractor x (its token in lower case, e.g. ``orb_grid``) with the graph's defaults;
- ``<x>-dyn``: x with, per frame, the configuration of x with the lowest median ATE measured under the frame's
  known conditions (the same lookup the advisor's measured Θ′ uses, ``RuleTable.measured``; the defaults
  where nothing was measured) — the paper's "dynamically optimised" baseline;
- ``tuned-static``: the one configuration (any extractor) with the lowest median ATE over every measurement
  in scope with at least ``nfex:minMeasurements`` windows and no failed one — what a careful engineer
  would put in a config file without seeing the test sequence.

``nfex``: the advisor per frame with its stream state; where the graph's verification program is in force for the
context, the VO tries the selection's proposals in order and the stream's pair judge (``verification.PairJudge``) judges each pair. Every method reads the graph through the
evaluation's evidence scope, which holds the evaluated sequence out (``kg.scope``).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from nfex_slam.datasets.base import Frame
from nfex_slam.vo import Choice, Chooser, FrameRecord, Proposals, fixed

from ..errors import BadInput
from ..evidence import robust
from ..kg.vocabulary.vocab import Value, Vocabulary
from ..rules.table import RuleTable
from ..verification import PairJudge

if TYPE_CHECKING:
    from ..advisor import Advisor

STATIC_KINDS = ("default", "dyn")
TUNED = "tuned-static"
NFEX = "nfex"
ORACLES = ("oracle-segment", "oracle-pair")


def method_name(extractor: str, kind: str) -> str:
    return f"{extractor.lower()}-{kind}"


def static_methods(vocab: Vocabulary) -> list[str]:
    """Every extractor of the graph at its default and its dynamic configuration, and tuned-static."""
    return [method_name(x, k) for x in vocab.extractors for k in STATIC_KINDS] + [TUNED]


def known_methods(vocab: Vocabulary) -> list[str]:
    return [*static_methods(vocab), NFEX]


def parse_static(method: str, vocab: Vocabulary) -> tuple[str, str]:
    """``orb_grid-dyn`` → ("ORB_GRID", "dyn"); BadInput listing the methods for anything else."""
    name, _, kind = method.rpartition("-")
    by_lower = {x.lower(): x for x in vocab.extractors}
    if kind not in STATIC_KINDS or name not in by_lower:
        raise BadInput(f"unknown method {method!r}; known: {', '.join(known_methods(vocab))}")
    return by_lower[name], kind


@dataclass
class DynChooser:
    """x with the best configuration measured under each frame's known conditions."""

    table: RuleTable
    extractor: str
    context: Mapping[str, str]
    notes: set[str] = field(default_factory=set)
    _cache: dict[tuple[Any, ...], Choice] = field(default_factory=dict)

    def __call__(self, frame: Frame, history: list[FrameRecord]) -> Choice:
        values = {d: v for d, v in {**self.context, **frame.context}.items() if d in self.table.dimensions and v}
        key = self.table.key(values)
        choice = self._cache.get(key)
        if choice is None:
            ranked = self.table.measured(values).get(self.extractor)
            if ranked:
                best = ranked[0]
                choice = Choice(self.extractor, dict(best.params))
                self.notes.add(f"{best.iri.rsplit('#', 1)[-1]} ({best.ate:.3f} m over {best.windows} windows)")
            else:
                choice = Choice(self.extractor, {})
                self.notes.add("defaults (nothing measured)")
            self._cache[key] = choice
        return choice


def tuned_static(table: RuleTable) -> tuple[str, dict[str, Value], str]:
    """The configuration with the lowest median ATE over all admitted measurements in scope (module docstring)."""
    best: tuple[float, str, str, dict[str, Value], int] | None = None
    for x, configurations in table.configurations.items():
        for iri, (params, observations) in configurations.items():
            ates = [o.ate for o in observations]
            if len(ates) < table.min_measurements or any(a is None for a in ates):
                continue
            value = robust([a for a in ates if a is not None]).value
            if best is None or (value, iri) < (best[0], best[1]):
                best = (value, iri, x, dict(params), len(ates))
    if best is None:
        raise BadInput("tuned-static needs measured configurations in the graph (run `nfex sweep` first)")
    value, iri, x, params, n = best
    return x, params, f"{iri.rsplit('#', 1)[-1]}: {x}, median ATE {value:.3f} m over {n} windows (all conditions)"


@dataclass
class AdvisorChooser:
    """The nFEX advisor as a VO chooser: one selection per frame, the stream state carried along. ``session``: run
    as a service session does (advisor/reuse.py: the decision reused while its evidence — the condition estimate
    and this loop's own verdicts — holds), so the loop equals a client's session frame for frame. The pairs are
    judged by one ``verification.PairJudge``, as a session's are: its policy, motion prior and budget window."""

    advisor: Advisor
    context: Mapping[str, str]
    budget_ms: float | None = None
    session: bool = False
    selections: list[dict[str, Any]] = field(default_factory=list)
    verification: PairJudge = field(init=False)
    _state: Any = None

    def __post_init__(self) -> None:
        self.verification = PairJudge(self.advisor.snapshot().table.budget_terms)

    def __call__(self, frame: Frame, history: list[FrameRecord]) -> Choice | Proposals:
        sel = self.advisor.select({**self.context, **frame.context}, frame.image, self._state, budget_ms=self.budget_ms,
                                  session=self.session, verdict_held=self.verification.held)
        self._state = sel.state
        self.verification.begin(sel)
        self.selections.append({
            "frame": frame.index, "extractor": sel.extractor, "params": sel.params, "mode": sel.mode,
            "pruned": [p.extractor for p in sel.pruned],
            "candidates": [{"extractor": c.extractor, "score": c.score, "f_metrics": c.evidence.f_metrics,
                            "measured_accuracy": c.evidence.measured_accuracy,
                            "ate_m": c.evidence.measured.ate if c.evidence.measured else None}
                           for c in sel.candidates],
        })
        if not sel.verification.active:
            return Choice(sel.extractor, dict(sel.params))
        return Proposals(tuple(Choice(c.extractor, dict(c.params)) for c in sel.proposals), self.verification)


def chooser_for(
    method: str, vocab: Vocabulary, table: RuleTable, advisor: Advisor | None, context: Mapping[str, str],
    budget_ms: float | None = None, session: bool = False,
) -> tuple[Chooser, str]:
    """The chooser of ``method`` and a note saying which parameters it runs with (``session``: nFEX as a service
    session, AdvisorChooser)."""
    if method == NFEX:
        if advisor is None:
            raise BadInput("the nfex method needs an advisor")
        return AdvisorChooser(advisor, context, budget_ms, session), ("advisor as a session" if session else "advisor per frame") + (
            f", budget {budget_ms:g} ms" if budget_ms is not None else "")
    if method == TUNED:
        x, params, note = tuned_static(table)
        return fixed(x, params), note
    x, kind = parse_static(method, vocab)
    if kind == "default":
        return fixed(x), "the graph's defaults"
    return DynChooser(table, x, context), "best measured configuration per frame's known conditions"
