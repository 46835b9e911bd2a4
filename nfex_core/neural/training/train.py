"""Training ParamNet and SelectorNet on the sweep table (§IV-B); torch is imported here, lazily.

ParamNet minimises the MSE of the paper, L = 1/N Σ (y − ŷ)², between its outputs and the best Θ of
each extractor in the window (in [0, 1] of each range; extractors without a successful row are masked).
SelectorNet minimises the cross-entropy between its softmax and the window's best extractor.
Optimiser: Adam, learning rate 1e-4, batch 8 — the paper's. The inputs are augmented so the networks
meet at training what they meet when served: each context dimension is hidden (→ "unknown") with
probability 0.2, each extractor's metrics with 0.3, the image with 0.1.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...kg.vocab import Vocabulary
from ..artifacts import NeuralModel, code_version, new_version, sha256_file
from ..encoding import InputVocabulary, Scaler
from ..paramnet import ParamNet
from ..selectornet import IMAGE_HW, SelectorNet, numeric_input
from . import torch_nets
from .dataset import ImageSource, Window, default_image_source, folds, read_table
from .validation import Validation

P_HIDE_CONTEXT, P_HIDE_METRICS, P_HIDE_IMAGE = 0.2, 0.3, 0.1


@dataclass
class TrainReport:
    path: Path
    split: str
    windows: dict[str, int]
    metrics: dict[str, Any] = field(default_factory=dict)


@dataclass
class Arrays:
    ctx: np.ndarray
    stats: np.ndarray
    y: np.ndarray  # ParamNet targets
    ymask: np.ndarray
    images: np.ndarray
    numeric: np.ndarray
    labels: np.ndarray  # −1: no label


def encode(windows: Sequence[Window], inputs: InputVocabulary, scaler: Scaler) -> Arrays:
    n, p = len(windows), len(inputs.params)
    y, ym = np.zeros((n, p), np.float32), np.zeros((n, p), np.float32)
    ctx = np.stack([inputs.context_onehot(w.context) for w in windows]) if n else np.zeros((0, inputs.context_size), np.float32)
    stats = np.stack([scaler.transform(w.stats) for w in windows]) if n else np.zeros((0, len(scaler.keys)), np.float32)
    images = np.zeros((n, *IMAGE_HW), np.float32)
    numeric, labels = [], np.full(n, -1, np.int64)
    for i, w in enumerate(windows):
        for x, theta in w.best_params.items():
            for j, u in inputs.encode_params(x, theta, w.pixels or None).items():
                y[i, j], ym[i, j] = u, 1.0
        if w.image is not None:
            images[i] = w.image
        numeric.append(numeric_input(ctx[i], stats[i], w.image is not None, w.metrics, inputs.extractors, inputs.metrics))
        if w.label in inputs.extractors:
            labels[i] = inputs.extractors.index(w.label)
    num = np.stack(numeric) if numeric else np.zeros((0, 0), np.float32)
    return Arrays(ctx, stats, y, ym, images, num, labels)


def _hide_context(torch: Any, x: Any, inputs: InputVocabulary, gen: Any) -> Any:
    x = x.clone()
    i = 0
    for _, values in inputs.dimensions:
        k = len(values) + 1
        hide = torch.rand(x.shape[0], generator=gen) < P_HIDE_CONTEXT
        x[hide, i : i + k] = 0.0
        x[hide, i + k - 1] = 1.0
        i += k
    return x


def auto_epochs(n_windows: int, batch: int, steps: int = 4000, minimum: int = 300) -> int:
    """Epochs for at least ``steps`` Adam steps: at lr 1e-4 a table of a few dozen windows needs them."""
    per_epoch = max(1, -(-n_windows // batch))
    return max(minimum, -(-steps // per_epoch))


def fit(A: Arrays, inputs: InputVocabulary, n_stats: int, *, epochs: int, lr: float, batch: int, gen: Any) -> tuple[ParamNet, SelectorNet]:
    """Adam on the masked MSE (ParamNet) and on the cross-entropy (SelectorNet); returns the NumPy models."""
    import torch

    # ---------------------------------------------------------------- ParamNet
    pnet = torch_nets.paramnet_module((inputs.context_size + n_stats, 64, 64, len(inputs.params)))
    popt = torch.optim.Adam(pnet.parameters(), lr=lr)
    px = torch.from_numpy(np.concatenate([A.ctx, A.stats], 1))
    py, pm = torch.from_numpy(A.y), torch.from_numpy(A.ymask)
    keep = (pm.sum(1) > 0).nonzero().flatten()
    for _ in range(epochs):
        for b in keep[torch.randperm(len(keep), generator=gen)].split(batch):
            x = px[b].clone()
            x[:, : inputs.context_size] = _hide_context(torch, x[:, : inputs.context_size], inputs, gen)
            popt.zero_grad()
            ((((pnet(x) - py[b]) ** 2) * pm[b]).sum() / pm[b].sum().clamp(min=1.0)).backward()
            popt.step()

    # ---------------------------------------------------------------- SelectorNet
    snet = torch_nets.selectornet_module(A.numeric.shape[1], len(inputs.extractors))
    sopt = torch.optim.Adam(snet.parameters(), lr=lr)
    sim, snum, slab = torch.from_numpy(A.images), torch.from_numpy(A.numeric), torch.from_numpy(A.labels)
    labelled = (slab >= 0).nonzero().flatten()
    c, s, e, m = inputs.context_size, n_stats, len(inputs.extractors), len(inputs.metrics)
    a0, a1 = c + s + 1, c + s + 1 + e * m
    for _ in range(epochs):
        for b in labelled[torch.randperm(len(labelled), generator=gen)].split(batch):
            im, nu = sim[b].clone(), snum[b].clone()
            nu[:, :c] = _hide_context(torch, nu[:, :c], inputs, gen)
            no_img = torch.rand(len(b), generator=gen) < P_HIDE_IMAGE
            im[no_img] = 0.0
            nu[no_img, c + s] = 0.0
            hide = torch.rand(len(b), e, generator=gen) < P_HIDE_METRICS
            mt = nu[:, a0:a1].reshape(len(b), e, m).clone()
            mt[hide] = 0.0
            bits = nu[:, a1:].clone()
            bits[hide] = 0.0
            nu[:, a0:a1], nu[:, a1:] = mt.reshape(len(b), -1), bits
            sopt.zero_grad()
            torch.nn.functional.cross_entropy(snet(im, nu), slab[b]).backward()
            sopt.step()
    return ParamNet(torch_nets.export(pnet)), SelectorNet(torch_nets.export(snet))


def train(
    table: Path | Sequence[Path],
    out: Path,
    vocab: Vocabulary,
    *,
    epochs: int | None = None,
    lr: float = 1e-4,
    batch: int = 8,
    val_sequences: Sequence[str] | None = None,
    refit_all: bool = False,
    images: ImageSource | None = None,
    data_dir: Path | None = None,
    seed: int = 0,
    log: Callable[[str], None] = print,
) -> TrainReport:
    """Validate both networks on the folds of ``table`` (one table or several, concatenated; see
    ``dataset.folds``: leave-one-sequence-out by default) against the baselines of ``validation``, then write
    the artifact to ``out``. The shipped weights are trained again, from scratch with the same settings, on
    every window where validation had several folds or ``refit_all`` asks; otherwise they are the split's."""
    import torch

    torch.manual_seed(seed)
    torch.set_num_threads(1)
    gen = torch.Generator().manual_seed(seed)
    inputs = InputVocabulary.from_vocabulary(vocab)
    tables = [table] if isinstance(table, Path) else list(table)
    windows = read_table(tables)
    source = images if images is not None else (default_image_source(data_dir) if data_dir is not None else None)
    if source is not None:
        for w in windows:
            w.image = source(w)
    keys = tuple(sorted({k for w in windows for k in w.stats}))

    def scaler_of(ws: Sequence[Window]) -> Scaler:
        return Scaler.fit(keys, np.array([[w.stats.get(k, np.nan) for k in keys] for w in ws], np.float64))

    fold_list, note = folds(windows, val_sequences)
    log(note)
    validation = Validation(inputs)
    t0 = time.perf_counter()
    for tr, va in fold_list:
        scaler = scaler_of(tr)
        A, V = encode(tr, inputs, scaler), encode(va, inputs, scaler)
        n_epochs = epochs or auto_epochs(len(tr), batch)
        log(f"training on {len(tr)} windows, validating on {len(va)}: Adam lr {lr}, batch {batch}, {n_epochs} epochs")
        pnet, snet = fit(A, inputs, len(keys), epochs=n_epochs, lr=lr, batch=batch, gen=gen)
        validation.add(pnet, snet, tr, va, A, V)
    metrics: dict[str, Any] = {"validation": note, **validation.metrics(), "train_seconds": round(time.perf_counter() - t0, 2)}
    refit = refit_all or len(fold_list) > 1  # leave-one-sequence-out has no one training split to ship
    weights_windows, trained_on = tr, A
    if refit:
        weights_windows = windows
        scaler = scaler_of(windows)
        trained_on = encode(windows, inputs, scaler)
        n_epochs = epochs or auto_epochs(len(windows), batch)
        log(f"training the shipped weights on all {len(windows)} windows, {n_epochs} epochs")
        pnet, snet = fit(trained_on, inputs, len(keys), epochs=n_epochs, lr=lr, batch=batch, gen=gen)
    sha = sha256_tables(tables)
    model = NeuralModel(
        inputs=inputs,
        scaler=scaler,
        paramnet=pnet,
        selectornet=snet,
        manifest={
            "version": new_version(sha),
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "code": code_version(),
            "data": {
                "table": ", ".join(str(t) for t in tables),
                "sha256": sha,
                "windows": {"folds": [[len(t), len(v)] for t, v in fold_list], "all": len(windows)},
                "sequences": sorted({w.seq_key for w in windows}),
                "split": note,
                "weights_trained_on": "all windows (refit after validation)" if refit else "the training split",
                "with_image": sum(w.image is not None for w in windows),
            },
            "training": {"optimizer": "Adam", "lr": lr, "batch": batch, "epochs": n_epochs, "seed": seed, "torch": torch.__version__},
            "metrics": metrics,
            # ParamNet outputs that had a target in training; the advisor uses g(Θ, E) for the others
            "paramnet_trained": [p.qualified for p, n in zip(inputs.params, trained_on.ymask.sum(0), strict=True) if n > 0],
            # the normalised values measured per parameter: served outputs snap to the nearest
            "paramnet_grid": measured_grid(weights_windows, inputs),
            # what the inputs covered: unseen context values are served as unknown, unmeasured extractors masked
            "context_seen": {
                d: sorted({v for w in (weights_windows) if (v := w.context.get(d))})
                for d, _ in inputs.dimensions
            },
            "selectornet_extractors": sorted({x for w in (weights_windows) for x in w.best_params}),
        },
    )
    model.save(out)
    return TrainReport(out, note, {"folds": len(fold_list), "validated": sum(len(v) for _, v in fold_list), "all": len(windows)}, metrics)


def sha256_tables(tables: Sequence[Path]) -> str:
    """The data's fingerprint: one table's sha256, or the sha256 of the tables' sha256s in order."""
    if len(tables) == 1:
        return sha256_file(tables[0])
    import hashlib

    return hashlib.sha256("".join(sha256_file(t) for t in tables).encode()).hexdigest()


def measured_grid(windows: Sequence[Window], inputs: InputVocabulary) -> dict[str, list[float]]:
    """Per parameter, the values among the best configurations (count parameters at 640×480)."""
    grid: dict[str, set[float]] = {}
    for w in windows:
        for x, theta in w.best_params.items():
            for i, v in inputs.reference_params(x, theta, w.pixels or None).items():
                grid.setdefault(inputs.params[i].qualified, set()).add(round(v, 9))
    return {q: sorted(vs) for q, vs in sorted(grid.items())}
