"""The advisor's neural step: Θ′ = ParamNet(E, s) and α* = SelectorNet masked to C(E), without torch.

Modes (the paper's ablations): ``symbolic`` (g(Θ, E) and F_metrics only), ``paramnet``, ``selectornet``,
``both`` (default; the settings' ``neural``, NFEX_NEURAL). The model folder (NFEX_MODELS, default ``models/``; the
``default`` model in it) is loaded on first use, once, and checked against each graph version's
vocabulary; a missing model or a changed vocabulary falls back to symbolic and the Selection says why.

In ``both``, a network that did not beat every baseline of its validation (``validation``: the best
constant predictor and the lookup by condition labels, leave-one-sequence-out) is not used, and the
Selection says so (``versions.model.skipped``) and which source decided (``versions.model.used``);
``paramnet`` and ``selectornet`` force their network, for the ablations.

Θ′ is the network's, as in the paper (rules' factors are not multiplied on top: the network learned
from the sweep's best configurations in that context, so the context would count twice); the graph
still bounds it: each θ′ is clamped to its range and rounded to its datatype, and the rules still
prune C(E).
"""
from __future__ import annotations

import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..kg.identity import model_iri
from ..kg.vocab import ExtractorSpec, Value, Vocabulary
from ..rules.types import Adjustment, Citation
from .artifacts import NeuralModel, find_model
from .paramnet import decode
from .selectornet import masked_probabilities, numeric_box, numeric_input, prepare_image

MODES = ("symbolic", "paramnet", "selectornet", "both")
LOGIT_MARGIN = 1e-3  # a bound decides only with this much to spare: the served network computes in float32


def check_mode(mode: str) -> str:
    if mode not in MODES:
        from ..errors import UnknownName

        raise UnknownName("advisor mode", mode, MODES)
    return mode


@dataclass
class NeuralStep:
    """What one selection uses: the model (or None) and, for the Selection, what was used and why."""

    model: NeuralModel | None
    paramnet: bool
    selectornet: bool
    info: dict[str, Any] = field(default_factory=dict)
    _u: np.ndarray | None = None
    _ctx: np.ndarray | None = None
    _stats: np.ndarray | None = None
    _embedded: tuple[np.ndarray | None, np.ndarray, np.ndarray] | None = None  # (frame, its network input, g)

    @property
    def selector_extractors(self) -> frozenset[str]:
        """The extractors SelectorNet was trained on (its probabilities cover only these)."""
        return frozenset(self.model.selector_extractors) if self.model is not None else frozenset()

    @property
    def active(self) -> bool:
        return self.paramnet or self.selectornet

    def prepare(self, values: Mapping[str, str | None], stats: Mapping[str, float] | None) -> None:
        """Encode E and the frame statistics once, and run ParamNet once for every extractor's Θ′."""
        assert self.model is not None
        seen = self.model.context_seen
        if seen is not None:  # a value never seen in training enters as "unknown", its weights are untrained
            values = {d: (v if v in seen.get(d, ()) else None) for d, v in values.items()}
        ctx = self.model.inputs.context_onehot(values)
        self._stats = self.model.scaler.transform(stats)
        self._ctx = ctx
        if self.paramnet and self.model.paramnet is not None:
            self._u = self.model.paramnet.forward(np.concatenate([ctx, self._stats]))

    def covers(self, extractor: str) -> bool:
        """Whether ParamNet learned any of this extractor's parameters (the sweep may not have measured it)."""
        return self.paramnet and self.model is not None and any(q.startswith(extractor + ".") for q in self.model.trained_params)

    def params(self, spec: ExtractorSpec, pixels: int | None) -> tuple[dict[str, Value], list[Adjustment]]:
        """Θ′ for one candidate: the graph's defaults with ParamNet's outputs, clamped to the graph."""
        assert self.model is not None and self._u is not None
        theta = spec.defaults()
        cite = Citation(
            rule=str(model_iri(self.model.version, "paramnet")),
            label=f"ParamNet {self.model.version}",
            reason="Θ′ predicted from the context and frame statistics, clamped to the graph's range",
            kind="adjust",
        )
        adjustments = []
        trained = self.model.trained_params
        for name, (value, raw) in decode(self.model.inputs, self._u, spec, pixels, self.model.grid).items():
            if f"{spec.name}.{name}" not in trained:
                continue
            before = theta[name]
            theta[name] = value
            factor = raw / float(before) if float(before) else 0.0
            adjustments.append(Adjustment(name, before, value, factor, (cite,)))
        return theta, adjustments

    def probabilities(
        self, image: np.ndarray | None, metrics: Mapping[str, Mapping[str, float]], candidates: Sequence[str]
    ) -> dict[str, float]:
        """P(α | frame, E, metrics) over the candidates C(E) that the sweep measured; pruned extractors
        (and extractors absent from the training data, whose outputs are untrained) are masked out.
        Empty (and ``info["declined"]`` says why) when the network's own first choice over everything it
        knows is not a candidate: the caller's F_metrics decides then."""
        assert self.model is not None and self.model.selectornet is not None
        assert self._ctx is not None and self._stats is not None
        inp = self.model.inputs
        known = self.model.selector_extractors
        net = self.model.selectornet
        img, g = self._embedding(image)
        metrics = {x: m for x, m in metrics.items() if x in known}
        num = numeric_input(self._ctx, self._stats, image is not None, metrics, inp.extractors, inp.metrics)
        logits = net.logits(img, num, g)
        allowed = [x for x in candidates if x in known]
        full = masked_probabilities(logits, inp.extractors, sorted(known))
        top = max(full, key=full.__getitem__) if full else None
        if top is not None and allowed and top not in allowed:
            # trained to name each window's best extractor, its ranking of the rest is not what it learned
            self.info["declined"] = (
                f"SelectorNet names {top} (p = {full[top]:.2f}), which the rules or the budget removed; it was "
                "trained on each window's best extractor, not on a ranking of the others, so F_metrics and "
                "the measured accuracy decide among the candidates"
            )
            return {}
        return masked_probabilities(logits, inp.extractors, allowed)


    def _embedding(self, image: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The network's image input and its CNN embedding, computed once per frame of this request."""
        assert self.model is not None and self.model.selectornet is not None
        if self._embedded is None or self._embedded[0] is not image:
            img = prepare_image(image) if image is not None else np.zeros((48, 160), np.float32)
            self._embedded = (image, img, self.model.selectornet.embed(img))
        return self._embedded[1], self._embedded[2]

    def bounded_choice(
        self, image: np.ndarray, metrics: Mapping[str, Mapping[str, float]], unknown: Mapping[str, Sequence[str]],
        candidates: Sequence[str],
    ) -> BoundedChoice | None:
        """SelectorNet's first choice over what it knows, if the metrics still ``unknown`` (extractor → the metric
        names it will have) cannot change it: its logit's lower bound beats every other logit's upper bound by
        ``LOGIT_MARGIN`` over the whole box of those metrics (SelectorNet.logit_bounds). None: not decided yet."""
        assert self.model is not None and self.model.selectornet is not None
        assert self._ctx is not None and self._stats is not None
        inp = self.model.inputs
        known = sorted(self.model.selector_extractors)
        metrics = {x: m for x, m in metrics.items() if x in known}
        low, high = numeric_box(self._ctx, self._stats, metrics, unknown, inp.extractors, inp.metrics)
        img, g = self._embedding(image)
        lo, hi = self.model.selectornet.logit_bounds(img, low, high, g)
        at = {x: inp.extractors.index(x) for x in known}
        top = max(known, key=lambda x: lo[at[x]])
        if any(lo[at[top]] - hi[at[x]] <= LOGIT_MARGIN for x in known if x != top):
            return None
        rivals = [x for x in candidates if x in at and x != top]
        # P(top) over the candidates ≥ 1 / (1 + Σ exp(hi_j − lo_top)): the softmax's least value over the box
        p_low = 1.0 / (1.0 + sum(float(np.exp(hi[at[x]] - lo[at[top]])) for x in rivals))
        rival_high = max((float(hi[at[x]]) for x in known if x != top), default=float("-inf"))
        return BoundedChoice(top, top in candidates, p_low, float(lo[at[top]]), rival_high)


@dataclass(frozen=True)
class BoundedChoice:
    """SelectorNet's choice settled by bounds: ``extractor`` whatever the unmeasured metrics, whether it is a
    candidate (if not, the network declines as in ``probabilities``), its probability's lower bound over the
    candidates, its logit's lower bound and the highest upper bound of any other logit."""

    extractor: str
    allowed: bool
    p_low: float
    logit_low: float
    rival_high: float


class ModelHolder:
    """Loads the model once (lazily) and answers, per graph vocabulary, which neural steps apply."""

    def __init__(self, models: Path | str, mode: str = "both", name: str = "default",
                 held_out: frozenset[str] = frozenset()) -> None:
        self.models = Path(models)
        self.mode = check_mode(mode)
        self.held_out = held_out  # sequence IRIs the evidence scope holds out: a model trained on one is not used
        self.name = name
        self._model: NeuralModel | None = None
        self._loaded = False
        self._error: str | None = None
        self._checked: tuple[int, str | None] | None = None
        self._lock = threading.Lock()
        self.load_ms: float | None = None

    def model(self) -> NeuralModel | None:
        if not self._loaded:
            with self._lock:
                if not self._loaded:
                    t = time.perf_counter()
                    path = find_model(self.models, self.name)
                    if path is None:
                        self._error = f"no model at {self.models / self.name}"
                    else:
                        try:
                            self._model = NeuralModel.load(path)
                        except (OSError, ValueError, KeyError) as e:
                            self._error = f"model at {path} unreadable: {e}"
                    self.load_ms = (time.perf_counter() - t) * 1000
                    self._loaded = True
        return self._model

    def _leak(self, model: NeuralModel) -> str | None:
        seen = _trained_on(model) & set(self.held_out)
        if seen:
            return f"the model was trained on {', '.join(sorted(seen))}, which the evidence scope holds out"
        return None

    def step(self, vocab: Vocabulary) -> NeuralStep:
        info: dict[str, Any] = {"mode": self.mode}
        if self.mode == "symbolic":
            return NeuralStep(None, False, False, {**info, "used": "symbolic"})
        model = self.model()
        if model is None:
            return NeuralStep(None, False, False, {**info, "used": "symbolic", "fallback": self._error})
        if self._checked is None or self._checked[0] != vocab.version:
            self._checked = (vocab.version, model.check(vocab) or self._leak(model))
        info.update(model.info())
        if self._checked[1] is not None:
            return NeuralStep(None, False, False, {**info, "used": "symbolic", "fallback": self._checked[1]})
        p = self.mode in ("paramnet", "both") and model.paramnet is not None
        s = self.mode in ("selectornet", "both") and model.selectornet is not None
        if self.mode == "both":  # the default uses a network only where validation shows it earns its place
            gates = model.validation_gates()
            p, s = p and "paramnet" not in gates, s and "selectornet" not in gates
            if gates:
                info["skipped"] = gates
        used = "+".join(n for n, on in (("paramnet", p), ("selectornet", s)) if on) or "symbolic"
        return NeuralStep(model, p, s, {**info, "used": used, "load_ms": round(self.load_ms or 0.0, 3)})


def _trained_on(model: NeuralModel) -> set[str]:
    """The sequence IRIs of the model's training table (its manifest's ``dataset/sequence`` keys)."""
    from ..kg.identity import sequence_iri

    keys = model.manifest.get("data", {}).get("sequences", [])
    return {str(sequence_iri(*k.split("/", 1))) if "/" in k else str(sequence_iri(None, k)) for k in keys}


def frame_stats(stats: Mapping[str, float] | None) -> dict[str, float] | None:
    """The frame statistics as ParamNet was trained on them: those of the frame alone (the sweep's rows
    have no previous frame), so the motion keys read as without one."""
    if stats is None:
        return None
    from ..vision.statistics import FLOW_KEYS

    return {**stats, **dict.fromkeys(FLOW_KEYS, 0.0)}
