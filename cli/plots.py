"""Plots of an evaluation, drawn by ``nfex evaluate --plots`` (matplotlib, imported here only; nfex_core never
imports it): trajectories against the ground truth, the front-end figures (pose AUC@5/10/20° with 95 % intervals
per method and condition; the cumulative pair-error curves of run 0), mean ATE with its 95 % interval per method
and condition, the configuration nFEX ran per frame against the schedule, and accuracy against cost."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from nfex_core.evaluation.methods import NFEX, ORACLES
from nfex_core.evaluation.report import display
from nfex_core.evaluation.run import SCHEDULE, Evaluation
from nfex_core.evaluation.stats import summary


def _aligned(ev: Evaluation, poses: np.ndarray) -> np.ndarray:
    from nfex_slam.trajectory import umeyama

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
    cond = SCHEDULE if SCHEDULE in ev.conditions else ev.conditions[0]
    # trajectories (ground plane x–z for cameras looking along z), run 0
    fig, ax = plt.subplots(figsize=(7, 6))
    if ev.ground_truth is not None:
        g = ev.ground_truth[:, :3, 3]
        ax.plot(g[:, 0], g[:, 2], "k-", lw=2, label="ground truth")
    for key in ev.keys():
        recs = [r for r in ev.by_key(key, cond) if r.result is not None]
        if recs:
            p = _aligned(ev, recs[0].result.poses)  # type: ignore[union-attr]
            ax.plot(p[:, 0], p[:, 2], "-", lw=2 if key.startswith(NFEX) else 1,
                    label=display(key) + (" (fail)" if recs[0].failed else ""))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"{ev.dataset} {ev.sequence} ({cond}), run 0: trajectories, Sim(3)-aligned")
    ax.legend(fontsize=7)
    written.append(_save(fig, out / "trajectories.png"))
    keys = ev.keys()
    written += _frontend_plots(ev, out, cond)
    # mean ATE with 95 % intervals per method and condition
    fig, ax = plt.subplots(figsize=(max(8, 0.6 * len(keys)), 4))
    width = 0.8 / max(len(ev.conditions), 1)
    for j, c in enumerate(ev.conditions):
        sums = [summary(ev.ates(k, c)) for k in keys]
        xs = np.arange(len(keys)) + j * width
        means = [s.mean if s.mean is not None else 0.0 for s in sums]
        err = np.array([[s.mean - s.ci95[0], s.ci95[1] - s.mean] if s.ci95 and s.mean is not None else [0, 0] for s in sums]).T
        ax.bar(xs, means, width, yerr=err, capsize=2, label=c)
    ax.set_xticks(np.arange(len(keys)) + 0.4 - width / 2)
    ax.set_xticklabels([display(k) for k in keys], fontsize=7, rotation=45, ha="right")
    ax.set_ylabel("Mean ATE (m), 95 % CI")
    ax.legend(fontsize=8)
    written.append(_save(fig, out / "ate.png"))
    # configuration per frame for nFEX and the oracles, against the schedule
    runs = [r for r in ev.by_key(NFEX, cond) if r.result is not None][:1] + \
        [r for k in ORACLES for r in ev.by_key(k, cond)[:1] if r.result is not None] + \
        [r for k in ev.keys() if k.startswith(NFEX + "@") for r in ev.by_key(k, cond)[:1] if r.result is not None]
    if runs:
        kinds = sorted({f.extractor for r in runs for f in r.result.frames})  # type: ignore[union-attr]
        fig, ax = plt.subplots(figsize=(9, 1.2 + 0.5 * len(kinds)))
        if cond == SCHEDULE and ev.schedule is not None:
            for i, s in enumerate(ev.schedule.segments):
                ax.axvspan(s.start - 0.5, s.end + 0.5, color=("#eeeeee", "#dddddd")[i % 2], zorder=0)
                ax.text((s.start + s.end) / 2, len(kinds) - 0.4, s.corruption, ha="center", fontsize=8)
        for i, r in enumerate(runs):
            frames = r.result.frames  # type: ignore[union-attr]
            ys = [kinds.index(f.extractor) + 0.12 * (i - len(runs) / 2) for f in frames]
            ax.scatter([f.index for f in frames], ys, s=10, label=display(r.key), zorder=2)
            lost = [f for f in frames if f.lost]
            ax.scatter([f.index for f in lost], [kinds.index(f.extractor) + 0.12 * (i - len(runs) / 2) for f in lost],
                       s=40, marker="x", color="red", zorder=3)
        ax.set_yticks(range(len(kinds)))
        ax.set_yticklabels(kinds)
        ax.set_ylim(-0.7, len(kinds))
        ax.set_xlabel("frame (× = pair lost or rejected)")
        ax.set_title("configuration run per frame (run 0)")
        ax.legend(fontsize=7, loc="lower right")
        written.append(_save(fig, out / "extractor_per_frame.png"))
    # accuracy against cost
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for key in keys:
        recs = ev.by_key(key, cond)
        ate = Evaluation.mean_ate(recs)
        if ate is None or not recs:
            continue
        ms = float(np.mean([r.extraction_ms for r in recs]))
        star = key.startswith(NFEX)
        ax.scatter([ms], [ate], marker="*" if star else "o", s=80 if star else 30)
        ax.annotate(display(key), (ms, ate), fontsize=7, xytext=(4, 4), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_xlabel("extraction ms/frame (log)")
    ax.set_ylabel("Mean ATE (m)")
    ax.set_title(f"accuracy against cost ({cond})")
    written.append(_save(fig, out / "accuracy_vs_cost.png"))
    return written


def _frontend_plots(ev: Evaluation, out: Path, cond: str) -> list[Path]:
    import matplotlib.pyplot as plt

    from nfex_core.evaluation.figures import BY_NAME

    keys = ev.keys()
    fig, axes = plt.subplots(1, 3, figsize=(max(12, 1.2 * len(keys)), 4), sharey=True)
    width = 0.8 / max(len(ev.conditions), 1)
    for ax, name in zip(axes, ("auc5", "auc10", "auc20"), strict=True):
        for j, c in enumerate(ev.conditions):
            sums = [summary(ev.values(k, c, BY_NAME[name])) for k in keys]
            means = [s.mean if s.mean is not None else 0.0 for s in sums]
            err = np.array([[s.mean - s.ci95[0], s.ci95[1] - s.mean] if s.ci95 and s.mean is not None else [0, 0]
                            for s in sums]).T
            ax.bar(np.arange(len(keys)) + j * width, means, width, yerr=err, capsize=2, label=c)
        ax.set_xticks(np.arange(len(keys)) + 0.4 - width / 2)
        ax.set_xticklabels([display(k) for k in keys], fontsize=7, rotation=45, ha="right")
        ax.set_title(BY_NAME[name].title)
    axes[0].set_ylabel("pose AUC (mean over runs, 95 % CI)")
    axes[0].legend(fontsize=8)
    paths = [_save(fig, out / "pose_auc.png")]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for key in keys:
        recs = [r for r in ev.by_key(key, cond) if r.front is not None]
        if recs:
            e = np.sort(recs[0].front.error_deg)  # type: ignore[union-attr]
            ax.step(e, np.arange(1, e.size + 1) / e.size, where="post", label=display(key),
                    lw=2 if key.startswith(NFEX) else 1)
    ax.set_xlim(0, 30)
    ax.set_ylim(0, 1)
    ax.set_xlabel("pair error max(rotation, direction) (°); lost or coasted pairs at 180°")
    ax.set_ylabel("share of pairs")
    ax.set_title(f"cumulative pair error ({cond}, run 0)")
    ax.legend(fontsize=7)
    paths.append(_save(fig, out / "pair_errors.png"))
    return paths


def _save(fig: object, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()  # type: ignore[attr-defined]
    fig.savefig(path, dpi=110)  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return path
