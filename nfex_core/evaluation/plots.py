"""Plots of an evaluation (matplotlib, imported here only): trajectories against the ground truth,
Mean ATE per method, the extractor nFEX chose per frame, and accuracy against cost (issue 8)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .report import NAMES, rows
from .run import Evaluation


def _aligned(ev: Evaluation, poses: np.ndarray) -> np.ndarray:
    from ..trajectory import umeyama

    gt = ev.ground_truth
    if gt is None or len(gt) != len(poses):
        return poses[:, :3, 3]
    try:
        a = umeyama(poses[:, :3, 3], gt[:, :3, 3], with_scale=True)
    except Exception:  # a degenerate estimate: draw it unaligned
        return poses[:, :3, 3]
    return (a.scale * (a.rotation @ poses[:, :3, 3].T)).T + a.translation


def draw(ev: Evaluation, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    corr = ev.corruptions()[0]
    # trajectories (ground plane x–z for cameras looking along z), first run, first condition
    fig, ax = plt.subplots(figsize=(7, 6))
    if ev.ground_truth is not None:
        g = ev.ground_truth[:, :3, 3]
        ax.plot(g[:, 0], g[:, 2], "k-", lw=2, label="ground truth")
    for m in ev.methods():
        recs = [r for r in ev.cell(m, corr) if r.result is not None]
        if recs:
            p = _aligned(ev, recs[0].result.poses)  # type: ignore[union-attr]
            ax.plot(p[:, 0], p[:, 2], "-", lw=1, label=NAMES.get(m, m) + (" (fail)" if recs[0].failed else ""))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"{ev.dataset} {ev.sequence} ({corr}): trajectories, Sim(3)-aligned")
    ax.legend(fontsize=8)
    written.append(_save(fig, out / "trajectories.png"))
    # ATE bars per method and condition
    fig, ax = plt.subplots(figsize=(8, 4))
    table = rows(ev)
    conds = ev.corruptions()
    width = 0.8 / max(len(conds), 1)
    for j, c in enumerate(conds):
        vals = [ev.mean_ate([r for r in recs if r.corruption == c]) for _, _, recs in table]
        xs = np.arange(len(table)) + j * width
        ax.bar(xs, [v if v is not None else 0 for v in vals], width, label=c)
        for x, v in zip(xs, vals, strict=True):
            if v is None:
                ax.text(x, 0, "fail", ha="center", va="bottom", fontsize=7, rotation=90)
    ax.set_xticks(np.arange(len(table)) + 0.4 - width / 2)
    ax.set_xticklabels([NAMES.get(m, m) + (f"\n@{b:g} ms" if b is not None else "") for m, b, _ in table], fontsize=8)
    ax.set_ylabel("Mean ATE (m)")
    ax.legend(fontsize=8)
    written.append(_save(fig, out / "ate.png"))
    # extractor chosen per frame by nFEX
    sel = [r for r in ev.records if r.method == "nfex" and r.budget_ms is None and r.result is not None]
    if sel:
        fig, ax = plt.subplots(figsize=(8, 2.5))
        kinds = sorted({f.extractor for r in sel for f in r.result.frames})  # type: ignore[union-attr]
        for i, r in enumerate(sel[: len(conds)]):
            names = [f.extractor for f in r.result.frames]  # type: ignore[union-attr]
            ax.scatter([f.index for f in r.result.frames], [kinds.index(n) + i * 0.1 for n in names], s=8,  # type: ignore[union-attr]
                       label=r.corruption)
            ax.set_yticks(range(len(kinds)))
            ax.set_yticklabels(kinds)
        ax.set_xlabel("frame")
        ax.set_title("extractor chosen by nFEX per frame")
        ax.legend(fontsize=8)
        written.append(_save(fig, out / "extractor_per_frame.png"))
    # accuracy against cost
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for m, b, recs in table:
        ate = ev.mean_ate(recs)
        if ate is None or not recs:
            continue
        ms = float(np.mean([r.ms_per_frame for r in recs]))
        ax.scatter([ms], [ate], marker="*" if m == "nfex" else "o", s=80 if m == "nfex" else 40)
        ax.annotate(NAMES.get(m, m) + (f" @{b:g}" if b is not None else ""), (ms, ate), fontsize=8,
                    xytext=(4, 4), textcoords="offset points")
    ax.set_xlabel("extraction + matching (ms/frame)")
    ax.set_ylabel("Mean ATE (m)")
    ax.set_title("accuracy against cost")
    written.append(_save(fig, out / "accuracy_vs_cost.png"))
    return written


def _save(fig: object, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()  # type: ignore[attr-defined]
    fig.savefig(path, dpi=110)  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return path
