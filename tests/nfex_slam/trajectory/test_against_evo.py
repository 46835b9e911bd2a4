"""Cross-check against evo itself (a test-only dependency) on 100 random trajectories: a random
similarity transform of a random walk plus noise, with jittered and partly missing timestamps."""
from __future__ import annotations

import numpy as np
import pytest
from nfex_slam.trajectory import Trajectory, ate, rpe

evo_metrics = pytest.importorskip("evo.core.metrics")
evo_sync = pytest.importorskip("evo.core.sync")
evo_trajectory = pytest.importorskip("evo.core.trajectory")

N_TRAJECTORIES = 100


def _rotation(rng: np.random.Generator, scale: float = np.pi) -> np.ndarray:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = rng.uniform(-scale, scale)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def random_pair(seed: int) -> tuple[Trajectory, Trajectory]:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(20, 150))
    ts = np.cumsum(rng.uniform(0.05, 0.15, size=n)) + rng.uniform(0, 1e4)
    poses = np.tile(np.eye(4), (n, 1, 1))
    r = np.eye(3)
    p = np.zeros(3)
    for i in range(n):
        r = r @ _rotation(rng, 0.1)
        p = p + r @ np.array([rng.uniform(0.2, 1.0), rng.normal(0, 0.1), rng.normal(0, 0.05)])
        poses[i, :3, :3] = r
        poses[i, :3, 3] = p
    ref = Trajectory(ts, poses)
    # estimate: a random Sim(3) of the reference, with pose noise, jittered stamps, some poses dropped
    s = rng.uniform(0.2, 5.0)
    rt = _rotation(rng)
    tt = rng.normal(0, 20, size=3)
    est_poses = poses.copy()
    for i in range(n):
        est_poses[i, :3, :3] = rt @ poses[i, :3, :3] @ _rotation(rng, 0.02)
        est_poses[i, :3, 3] = s * (rt @ (poses[i, :3, 3] + rng.normal(0, 0.05, size=3))) + tt
    keep = rng.random(n) > 0.1
    est_ts = ts + rng.uniform(-0.012, 0.012, size=n)
    return ref, Trajectory(est_ts[keep], est_poses[keep])


def _evo(traj: Trajectory):  # type: ignore[no-untyped-def]
    return evo_trajectory.PoseTrajectory3D(poses_se3=list(traj.poses), timestamps=traj.timestamps.copy())


def evo_ape(ref: Trajectory, est: Trajectory, align: str) -> dict[str, float]:
    r, e = evo_sync.associate_trajectories(_evo(ref), _evo(est), max_diff=0.01)
    if align != "none":
        e.align(r, correct_scale=align == "sim3")
    metric = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    metric.process_data((r, e))
    return metric.get_all_statistics() | {"pairs": r.num_poses}


def evo_rpe(ref: Trajectory, est: Trajectory, delta: float, unit: str, all_pairs: bool) -> dict[str, float]:
    r, e = evo_sync.associate_trajectories(_evo(ref), _evo(est), max_diff=0.01)
    metric = evo_metrics.RPE(
        evo_metrics.PoseRelation.translation_part,
        delta=delta,
        delta_unit=evo_metrics.Unit.frames if unit == "f" else evo_metrics.Unit.meters,
        all_pairs=all_pairs,
    )
    metric.process_data((r, e))
    return metric.get_all_statistics() | {"pairs": len(metric.error)}


def _compare(ours, theirs) -> None:  # type: ignore[no-untyped-def]
    assert ours.pairs == theirs["pairs"]
    for key in ("rmse", "mean", "median", "std", "min", "max", "sse"):
        assert getattr(ours, key) == pytest.approx(theirs[key], rel=1e-9, abs=1e-9), key


@pytest.mark.parametrize("align", ["se3", "sim3", "none"])
def test_ape_matches_evo_on_random_trajectories(align: str) -> None:
    for seed in range(N_TRAJECTORIES):
        ref, est = random_pair(seed)
        _compare(ate(ref, est, align=align, t_max_diff=0.01), evo_ape(ref, est, align))


@pytest.mark.parametrize(
    "delta, unit, all_pairs", [(1, "f", False), (4, "f", True), (5.0, "m", False), (3.0, "m", True)]
)
def test_rpe_matches_evo_on_random_trajectories(delta: float, unit: str, all_pairs: bool) -> None:
    for seed in range(0, N_TRAJECTORIES, 4):
        ref, est = random_pair(seed)
        _compare(rpe(ref, est, delta=delta, delta_unit=unit, all_pairs=all_pairs), evo_rpe(ref, est, delta, unit, all_pairs))


def test_sim3_recovers_the_scale() -> None:
    ref, est = random_pair(7)
    stats = ate(ref, est, align="sim3")
    # the estimate is s·R·(p + noise) + t, so the recovered scale is ≈ 1/s; evo's is the same
    r, e = evo_sync.associate_trajectories(_evo(ref), _evo(est), max_diff=0.01)
    _, _, c = e.align(r, correct_scale=True)
    assert stats.scale == pytest.approx(c, rel=1e-9)


@pytest.mark.parametrize(
    "kind, args",
    [("ape", {"align": "sim3"}), ("ape", {"align": "none"}), ("rpe", {"delta": 10, "delta_unit": "m"}),
     ("rpe", {"delta": 5, "delta_unit": "f", "all_pairs": True}), ("rpe", {"delta": 20.0, "delta_unit": "m", "all_pairs": True})],
)
def test_real_kitti_00_files_match_evo(data_dir, kind: str, args: dict) -> None:  # type: ignore[no-untyped-def, type-arg]
    """The KITTI files round their rotations to 7 digits: evo's conventions (Rᵀ as the inverse)
    matter at 1e-7 here, unlike on the exact random trajectories."""
    from nfex_slam.trajectory import read_trajectory

    d = data_dir / "trajectories" / "evo"
    ref = read_trajectory(d / "KITTI_00_gt.txt", "kitti")
    est = read_trajectory(d / "KITTI_00_ORB.txt", "kitti")
    if kind == "ape":
        _compare(ate(ref, est, **args), evo_ape(ref, est, args["align"]))
    else:
        ours = rpe(ref, est, **args)
        _compare(ours, evo_rpe(ref, est, args["delta"], args["delta_unit"], args.get("all_pairs", False)))
