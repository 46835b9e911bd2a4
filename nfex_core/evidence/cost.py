"""Expected extraction cost of a configuration on a W×H frame, fitted from the graph's Measurements.

Issue 8 (the paper's future work, "Resource Optimization"). Sweeps record per Measurement the mean
extraction time per frame (``nfex:extractionMs``), the frame size (``nfex:frameWidth/Height``) and,
in the provenance, the machine. Once per graph version (the rule engine's compile step) this module
fits, per extractor x, the model

    t_x(Θ, W, H) = P·(a_x + c_x·NL) + b_x·NF/1000,        P = s²·W·H / 10⁶ (megapixels processed)

where s is the extractor's input scale when it has a parameter marked ``nfex:scalesInput`` (a learned
model resizes the frame by it before its network: XFeat), else 1,
by least squares over the extractor's measured (configuration, size) groups, keeping the NF and NL
terms only where the data varies them, every measured NF is a real cap (not 0 = unlimited) and the
fitted coefficient is positive. The expected cost of a configuration is then, in this order:

1. ``measured``: the configuration was measured at this frame size — its median time;
2. ``model``: the extractor's model, where it has a features or levels term;
3. ``scaled``: the configuration was measured at other sizes — its mean ms per megapixel × P;
4. ``fallback``: the extractor's mean ms per megapixel × P (this configuration was never measured),
   cited as such;
5. unknown (None) when the extractor was never measured.

The model reads the admitted Measurements only (evidence/trust.py: a client's report counts once
corroborated or accepted) and takes the median time per configuration and frame size. Tiers 1, 3 and 4
are also SPARQL-answerable (``expected_cost_query``, a documentation aid over *every* stored
Measurement, means); tier 2 is the fit. Timings compare only on one machine: the model uses every
admitted Measurement, whatever machine ran it.
"""
from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..kg.terms import py
from ..kg.vocab import ExtractorSpec, Value
from . import Aggregate, Observation, admitted, read_observations, robust
from .groups import cost_group
from .index import read_settings

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

MEASURED_CONFIGURATIONS = "SELECT DISTINCT ?cfg WHERE { ?m a nfex:Measurement ; sosa:usedProcedure ?cfg }"


def measured_settings(kg: KnowledgeGraph) -> dict[str, dict[str, Value]]:
    """Configuration IRI → {OpenCV name: value} for every configuration a Measurement used (that has settings)."""
    found = read_settings(kg, [str(r["cfg"]) for r in kg.select(MEASURED_CONFIGURATIONS).rows])
    return {c: s for c, s in found.items() if s}


def expected_cost_query(configuration: str, extractor: str, width: int, height: int) -> str:
    """SPARQL for tiers 1, 3 and 4: the configuration's time at W×H, else its (or its extractor's) ms/MP × W·H.

    Configuration IRIs are content-derived (``identity.configuration_iri``), so a client can
    name one that was never measured and get the extractor's fallback.
    """
    return f"""PREFIX nfex: <https://w3id.org/nfex#>
PREFIX sosa: <http://www.w3.org/ns/sosa/>
SELECT ?expectedMs ?source ?measurements WHERE {{
  {{ SELECT (AVG(?ms0) AS ?sizeMs) (COUNT(?m0) AS ?sizeN) WHERE {{
      ?m0 sosa:usedProcedure <{configuration}> ; nfex:extractionMs ?ms0 ; nfex:frameWidth {int(width)} ; nfex:frameHeight {int(height)} . }} }}
  {{ SELECT (AVG(?ms * 1000000 / (?w * ?h)) AS ?cfgRate) (COUNT(?m) AS ?cfgN) WHERE {{
      ?m sosa:usedProcedure <{configuration}> ; nfex:extractionMs ?ms ; nfex:frameWidth ?w ; nfex:frameHeight ?h . }} }}
  {{ SELECT (AVG(?ms2 * 1000000 / (?w2 * ?h2)) AS ?xRate) (COUNT(?m2) AS ?xN) WHERE {{
      ?m2 sosa:usedProcedure/nfex:ofExtractor/nfex:token "{extractor}" ;
          nfex:extractionMs ?ms2 ; nfex:frameWidth ?w2 ; nfex:frameHeight ?h2 . }} }}
  FILTER (?cfgN > 0 || ?xN > 0)
  BIND (IF(?sizeN > 0, ?sizeMs, IF(?cfgN > 0, ?cfgRate, ?xRate) * {int(width) * int(height)} / 1000000) AS ?expectedMs)
  BIND (IF(?sizeN > 0, "measured", IF(?cfgN > 0, "scaled", "fallback")) AS ?source)
  BIND (IF(?sizeN > 0, ?sizeN, IF(?cfgN > 0, ?cfgN, ?xN)) AS ?measurements)
}}"""


@dataclass(frozen=True)
class Estimate:
    """An expected extraction time per frame and where it came from."""

    ms: float | None
    source: str  # "measured" | "model" | "fallback" | "unknown"
    measurements: int = 0

    def describe(self) -> str:
        if self.ms is None:
            return "no extraction time measured for this extractor"
        how = {
            "measured": "this configuration's measured time at this frame size",
            "model": "the extractor's cost model (pixels, features, levels)",
            "scaled": "this configuration's measured time per megapixel at other frame sizes",
            "fallback": "the extractor's mean time per megapixel (this configuration was never measured)",
        }[self.source]
        return f"{self.ms:.1f} ms from {how}, {self.measurements} measurements"


@dataclass(frozen=True)
class ExtractorCost:
    """t = P·(a + c·NL) + b·NF/1000 for one extractor; b or c are 0 where the data shows no term."""

    extractor: str
    per_mp: float  # a
    per_kfeature: float = 0.0  # b
    per_mp_level: float = 0.0  # c
    mean_per_mp: float = 0.0  # the fallback rate: mean ms per megapixel over all measurements
    nf: str | None = None
    nl: str | None = None
    scale: str | None = None  # the input-scale parameter (nfex:scalesInput): P counts s²·W·H
    groups: int = 0
    measurements: int = 0
    rmse_ms: float = 0.0  # in-sample fit error of the model
    fallback_rmse_ms: float = 0.0  # the same for the mean-rate fallback, for comparison
    mean_rel_error: float = 0.0

    @property
    def has_terms(self) -> bool:
        return self.per_kfeature > 0 or self.per_mp_level > 0

    def predict(self, params: Mapping[str, Value], pixels: int) -> float:
        mp = processed(params, self.scale, pixels) / 1e6
        nl = float(params[self.nl]) if self.nl and self.per_mp_level else 0.0
        nf = float(params[self.nf]) if self.nf and self.per_kfeature else 0.0
        return mp * (self.per_mp + self.per_mp_level * nl) + self.per_kfeature * nf / 1000


def input_scale(spec: ExtractorSpec) -> str | None:
    """The extractor's input-scale parameter (nfex:scalesInput), if it has one."""
    return next((n for n, p in spec.parameters.items() if p.scales_input), None)


def processed(params: Mapping[str, Value], scale: str | None, pixels: int) -> float:
    """The pixels an extractor processes: s²·W·H with s its input scale, else W·H."""
    return pixels * float(params[scale]) ** 2 if scale is not None and scale in params else float(pixels)


def config_key(extractor: str, params: Mapping[str, Value]) -> str:
    return extractor + " " + json.dumps({k: params[k] for k in sorted(params)}, sort_keys=True, separators=(",", ":"))


@dataclass
class CostModel:
    """Per-graph-version expected costs (see the module docstring for the tiers)."""

    configurations: dict[str, tuple[float, int]] = field(default_factory=dict)  # key → (ms per MP, n)
    at_size: dict[tuple[str, int, int], tuple[float, int]] = field(default_factory=dict)  # (key, W, H) → (ms, n)
    extractors: dict[str, ExtractorCost] = field(default_factory=dict)
    typical_size: tuple[int, int] | None = None  # the (W, H) most measurements were made at

    def expected(self, spec: ExtractorSpec, params: Mapping[str, Value], width: int, height: int) -> Estimate:
        pixels = int(width) * int(height)
        full = spec.resolve(params)
        key = config_key(spec.name, full)
        exact = self.at_size.get((key, int(width), int(height)))
        if exact is not None:
            return Estimate(exact[0], "measured", exact[1])
        model = self.extractors.get(spec.name)
        if model is None:
            return Estimate(None, "unknown")
        if model.has_terms:
            return Estimate(model.predict(full, pixels), "model", model.measurements)
        hit = self.configurations.get(key)
        if hit is not None:
            return Estimate(hit[0] * pixels / 1e6, "scaled", hit[1])
        return Estimate(model.mean_per_mp * processed(full, model.scale, pixels) / 1e6, "fallback", model.measurements)

    def as_dict(self) -> dict[str, Any]:
        return {
            "typical_size": self.typical_size,
            "measured_configurations": len(self.configurations),
            "extractors": {x: {k: v for k, v in m.__dict__.items()} for x, m in sorted(self.extractors.items())},
        }


@dataclass(frozen=True)
class BudgetTerms:
    """What the graph says about budgets: agents' defaults, compute classes, the budget rules' labels."""

    agent_defaults: Mapping[str, float] = field(default_factory=dict)
    compute: Mapping[str, float] = field(default_factory=dict)
    labels: Mapping[str, str] = field(default_factory=dict)
    relative_rules: frozenset[str] = frozenset()  # rules with nfex:relativeToBest true
    max_relative_ate: float | None = None  # nfex:maxRelativeAte
    verification_cap: float = 1.0  # nfex:verificationCap: a verified frame may spend this many budgets
    window: int = 1  # nfex:budgetWindow: frames over which the budget is a mean

    @classmethod
    def load(cls, kg: KnowledgeGraph) -> BudgetTerms:
        agents = {
            str(r["tok"]): float(py(r["ms"]))
            for r in kg.select("SELECT ?tok ?ms WHERE { ?v a nfex:ConditionValue ; nfex:token ?tok ; nfex:defaultBudgetMs ?ms }").rows
        }
        compute = {
            str(r["tok"]): float(py(r["f"]))
            for r in kg.select("SELECT ?tok ?f WHERE { ?c a nfex:ComputeClass ; nfex:token ?tok ; nfex:costFactor ?f }").rows
        }
        labels = {
            str(r["r"]): str(r["label"])
            for r in kg.select("SELECT ?r ?label WHERE { ?r a nfex:BudgetRule ; rdfs:label ?label }").rows
        }
        relative = frozenset(str(r["r"]) for r in kg.select("SELECT ?r WHERE { ?r nfex:relativeToBest true }").rows)
        def value(name: str) -> float | None:
            rows = kg.select(f"SELECT ?v WHERE {{ nfex:{name} nfex:value ?v }}").rows
            return float(py(rows[0]["v"])) if rows else None

        cap, window = value("verificationCap"), value("budgetWindow")
        return cls(agents, compute, labels, relative, value("maxRelativeAte"),
                   max(1.0, cap) if cap is not None else 1.0, max(1, int(window)) if window is not None else 1)


def _role(spec: ExtractorSpec, role: str) -> str | None:
    return next((n for n, p in spec.parameters.items() if p.role == role and p.grid_role is None), None)


def fit_extractor(spec: ExtractorSpec, rows: list[tuple[dict[str, Value], int, float, int]]) -> ExtractorCost:
    """Least squares over (full Θ, pixels, mean ms, n) groups, weighted by n; see the module docstring."""
    scale = input_scale(spec)
    mp = np.array([processed(r[0], scale, r[1]) / 1e6 for r in rows])
    y = np.array([r[2] for r in rows])
    w = np.sqrt(np.array([r[3] for r in rows], dtype=float))
    n = int(sum(r[3] for r in rows))
    mean_rate = float(np.average(y / mp, weights=w**2))
    nf, nl = _role(spec, "NF"), _role(spec, "NL")
    cols: dict[str, np.ndarray] = {"a": mp}
    if nf is not None:
        v = np.array([float(r[0][nf]) for r in rows])
        if len(set(v)) > 1 and v.min() > 0:
            cols["b"] = v / 1000
    if nl is not None:
        v = np.array([float(r[0][nl]) for r in rows])
        if len(set(v)) > 1:
            cols["c"] = mp * v
    while True:
        names = list(cols)
        x = np.stack([cols[k] for k in names], axis=1)
        coef, *_ = np.linalg.lstsq(x * w[:, None], y * w, rcond=None)
        bad = [k for k, c in zip(names, coef, strict=True) if k != "a" and c <= 0]
        if not bad:
            break
        del cols[bad[0]]
    fitted = dict(zip(names, (float(c) for c in coef), strict=True))
    pred = x @ coef
    fb = mean_rate * mp
    return ExtractorCost(
        extractor=spec.name,
        per_mp=fitted["a"],
        per_kfeature=fitted.get("b", 0.0),
        per_mp_level=fitted.get("c", 0.0),
        mean_per_mp=mean_rate,
        nf=nf,
        nl=nl,
        scale=scale,
        groups=len(rows),
        measurements=n,
        rmse_ms=float(np.sqrt(np.average((pred - y) ** 2, weights=w**2))),
        fallback_rmse_ms=float(np.sqrt(np.average((fb - y) ** 2, weights=w**2))),
        mean_rel_error=float(np.average(np.abs(pred - y) / y, weights=w**2)),
    )


def fit_cost_model(
    kg: KnowledgeGraph,
    extractors: Mapping[str, ExtractorSpec],
    settings: Mapping[str, Mapping[str, Value]] | None = None,
    observations: Iterable[Observation] | None = None,
) -> CostModel:
    """The cost model for the graph's admitted Measurements (evidence/trust.py): per configuration and frame
    size the median extraction time (evidence/aggregate.py), then least squares. ``settings``:
    ``measured_settings(kg)``, and ``observations``: the admitted ones, when the caller has read them."""
    if settings is None:
        settings = measured_settings(kg)
    if observations is None:
        observations = admitted(kg, read_observations(kg))
    groups: dict[tuple[str, str, int, int], list[float]] = {}
    for o in observations:
        group = cost_group(o)
        if group is not None and o.extraction_ms is not None:
            groups.setdefault(group, []).append(o.extraction_ms)
    return fit_groups(extractors, settings, {k: robust(times) for k, times in groups.items()})


def fit_groups(extractors: Mapping[str, ExtractorSpec], settings: Mapping[str, Mapping[str, Value]],
               groups: Mapping[tuple[str, str, int, int], Aggregate]) -> CostModel:
    """``fit_cost_model`` from the robust aggregate of each (configuration, extractor, W, H) group's extraction
    times (the rule engine keeps them from one version to the next: evidence/groups.py)."""
    model = CostModel()
    per_x: dict[str, list[tuple[dict[str, Value], int, float, int]]] = {}
    sizes: dict[tuple[int, int], int] = {}
    per_cfg: dict[str, list[tuple[float, int]]] = {}
    for (cfg, x, w, h), agg in sorted(groups.items()):
        spec = extractors.get(x)
        if spec is None:
            continue
        mean, n = agg.value, agg.windows
        if mean <= 0:
            continue
        try:
            full = spec.resolve(settings.get(cfg, {}))
        except Exception:  # a configuration the current vocabulary no longer accepts: not comparable
            continue
        per_x.setdefault(x, []).append((full, w * h, mean, n))
        old = model.at_size.get((config_key(x, full), w, h))
        if old is not None:  # one configuration from several IRIs (e.g. settings listed differently)
            mean, n = (old[0] * old[1] + mean * n) / (old[1] + n), old[1] + n
        model.at_size[(config_key(x, full), w, h)] = (mean, n)
        per_cfg.setdefault(config_key(x, full), []).append((mean * 1e6 / (w * h), n))
        sizes[(w, h)] = sizes.get((w, h), 0) + n
    for key, items in per_cfg.items():
        n = sum(k for _, k in items)
        model.configurations[key] = (sum(rate * k for rate, k in items) / n, n)
    for x, rows in per_x.items():
        model.extractors[x] = fit_extractor(extractors[x], rows)
    if sizes:
        model.typical_size = max(sizes, key=lambda s: sizes[s])
    return model
