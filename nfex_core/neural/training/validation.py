"""Whether a network earns its place: validation against the predictors that need no network (issue 24).

Each fold (``dataset.folds``: leave-one-sequence-out where the table has two or more sequences) trains
on the other sequences and predicts the held-out one; the folds' predictions are pooled.

SelectorNet, per validation window w with label y_w (the extractor of the best_overall row) and
a_w(x), the lowest ATE of extractor x in w:

- accuracy = mean [ŷ_w = y_w]
- regret = mean [a_w(ŷ_w) / min_x a_w(x) − 1], the relative ATE lost by the choice; an extractor
  without a successful row in w costs the window's worst ATE.

Its baselines:

- the **best constant**: the one extractor that, answered for every window, scores best on the pooled
  validation windows. It is chosen in hindsight, so it is the strongest constant there is.
- the **lookup**: the label most frequent among the training windows with the same condition labels,
  or the training's most frequent label where no training window shares them. This is what a measured
  rule in the graph does.
- the training majority, reported for reference.

ParamNet, by MSE over the targets in [0, 1]: the best constant is the pooled validation mean of each
target (hindsight again), and the lookup is the mean target of the training windows with the same labels.

A network is used by default only where it beats every baseline: ParamNet with a lower MSE, SelectorNet
with a higher accuracy *and* a lower regret (``NeuralModel.validation_gates``).
"""
from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from ..encoding import InputVocabulary
from ..paramnet import ParamNet
from ..selectornet import SelectorNet
from .dataset import Window


def context_key(w: Window) -> tuple[tuple[str, str | None], ...]:
    return tuple(sorted(w.context.items()))


def regret(w: Window, x: str | None) -> float:
    """a_w(x) / min a_w − 1; an extractor without a successful row in ``w`` costs the window's worst ATE."""
    if not w.ate:
        return 0.0
    best, worst = max(min(w.ate.values()), 1e-12), max(w.ate.values())
    return float(w.ate.get(x, worst) if x is not None else worst) / best - 1.0


def lookup_selector(train: Sequence[Window]) -> Any:
    """The label most frequent among the training windows with ``w``'s condition labels (else overall)."""
    votes: dict[tuple[tuple[str, str | None], ...], Counter[str]] = {}
    overall: Counter[str] = Counter()
    for w in train:
        if w.label is not None:
            votes.setdefault(context_key(w), Counter())[w.label] += 1
            overall[w.label] += 1

    def choose(w: Window) -> str | None:
        c = votes.get(context_key(w)) or overall
        return c.most_common(1)[0][0] if c else None

    return choose


def lookup_params(train: Sequence[Window], y: np.ndarray, mask: np.ndarray, val: Sequence[Window]) -> np.ndarray:
    """Per validation window, the mean target of the training windows with its labels (else the training mean)."""
    overall = (y * mask).sum(0) / np.maximum(mask.sum(0), 1)
    groups: dict[tuple[tuple[str, str | None], ...], list[int]] = {}
    for i, w in enumerate(train):
        groups.setdefault(context_key(w), []).append(i)
    out = np.tile(overall, (len(val), 1))
    for j, w in enumerate(val):
        rows = groups.get(context_key(w))
        if rows:
            n = mask[rows].sum(0)
            mean = (y[rows] * mask[rows]).sum(0) / np.maximum(n, 1)
            out[j] = np.where(n > 0, mean, overall)
    return out


class Answer(NamedTuple):
    """What each predictor answered for one validation window."""

    window: Window
    net: str
    lookup: str | None
    majority: str | None
    fold: str


@dataclass
class Validation:
    """The pooled predictions of every fold; ``metrics()`` compares them with the baselines."""

    inputs: InputVocabulary
    choices: list[Answer] = field(default_factory=list)
    log_p: list[float] = field(default_factory=list)
    params: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)

    def add(self, pnet: ParamNet, snet: SelectorNet, train: Sequence[Window], val: Sequence[Window], A: Any, V: Any) -> None:
        """One fold: the networks trained on ``train`` (arrays A) predict ``val`` (arrays V)."""
        fold = ", ".join(sorted({w.seq_key for w in val}))
        names = self.inputs.extractors
        known = [i for i, x in enumerate(names) if any(x in w.best_params for w in train)]  # served: masked to these
        idx = [i for i in range(len(val)) if V.labels[i] >= 0]
        if idx and known:
            logits = snet.forward(V.images[idx], V.numeric[idx]).astype(np.float64)
            z = logits - logits.max(1, keepdims=True)
            logp = z - np.log(np.exp(z).sum(1, keepdims=True))
            masked = np.full_like(logits, -np.inf)
            masked[:, known] = logits[:, known]
            look = lookup_selector(train)
            majority = Counter(w.label for w in train if w.label).most_common(1)
            for j, i in enumerate(idx):
                self.choices.append(Answer(val[i], names[int(masked[j].argmax())], look(val[i]), majority[0][0] if majority else None, fold))
                self.log_p.append(float(logp[j, V.labels[i]]))
        if V.ymask.sum() > 0:
            pred = pnet.forward(np.concatenate([V.ctx, V.stats], 1))
            train_mean = np.tile((A.y * A.ymask).sum(0) / np.maximum(A.ymask.sum(0), 1), (len(val), 1))
            self.params.append((pred, lookup_params(train, A.y, A.ymask, val), train_mean, V.y, V.ymask))

    def metrics(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.params:
            pred, by_labels, mean, y, m = (np.concatenate(a) for a in zip(*self.params, strict=True))
            hindsight = (y * m).sum(0) / np.maximum(m.sum(0), 1)

            def mse(p: np.ndarray) -> float:
                return round(float((((p - y) ** 2) * m).sum() / m.sum()), 6)

            out["paramnet"] = {
                "val_mse": mse(pred),
                "val_mse_best_constant": mse(np.broadcast_to(hindsight, y.shape)),
                "val_mse_lookup": mse(by_labels),
                "val_mse_train_mean": mse(mean),
                "val_targets": int(m.sum()),
            }
        if self.choices:
            ws = [c.window for c in self.choices]
            labels = [w.label for w in ws]

            def acc(xs: Sequence[str | None]) -> float:
                return round(float(np.mean([x == y for x, y in zip(xs, labels, strict=True)])), 4)

            def reg(xs: Sequence[str | None]) -> float:
                return round(float(np.mean([regret(w, x) for w, x in zip(ws, xs, strict=True)])), 4)

            constants = sorted({x for w in ws for x in w.ate} | {y for y in labels if y})
            by_acc = max(constants, key=lambda x: (acc([x] * len(ws)), -reg([x] * len(ws))))
            by_reg = min(constants, key=lambda x: (reg([x] * len(ws)), -acc([x] * len(ws))))
            net: list[str | None] = [c.net for c in self.choices]
            look = [c.lookup for c in self.choices]
            major = [c.majority for c in self.choices]
            folds = sorted({c.fold for c in self.choices})
            out["selectornet"] = {
                "val_windows": len(ws),
                "val_accuracy": acc(net),
                "val_regret": reg(net),
                "val_cross_entropy": round(-float(np.mean(self.log_p)), 6),
                "best_constant": by_acc,
                "val_accuracy_best_constant": acc([by_acc] * len(ws)),
                "best_constant_by_regret": by_reg,
                "val_regret_best_constant": reg([by_reg] * len(ws)),
                "val_accuracy_lookup": acc(look),
                "val_regret_lookup": reg(look),
                "val_accuracy_majority": acc(major),
                "val_regret_majority": reg(major),
                "val_label_counts": dict(sorted(Counter(y for y in labels if y).items())),
                "folds": {
                    f: {"windows": len(sel := [i for i, c in enumerate(self.choices) if c.fold == f]),
                        "accuracy": round(float(np.mean([net[i] == labels[i] for i in sel])), 4),
                        "accuracy_lookup": round(float(np.mean([look[i] == labels[i] for i in sel])), 4),
                        "net_answers": dict(sorted(Counter(net[i] for i in sel).items()))}
                    for f in folds
                },  # fmt: skip
            }
        return out
