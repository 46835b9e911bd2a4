"""Corruptions: deterministic, labelled, monotone in severity, blurring along the true motion."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nfex_slam.datasets import open_sequence
from nfex_slam.datasets.corruptions import LABELS, NAMES, corrupt, line_kernel
from nfex_slam.datasets.synthetic import make_sequence

from nfex_core.errors import ParameterError, UnknownName


@pytest.fixture(scope="module")
def seq():  # type: ignore[no-untyped-def]
    return make_sequence(4, 160, 120, direction=(1.0, 0.0, 0.0), yaw_deg=0.0, step=0.08, context={"scene": "indoor"})


def _grad_energy(img: np.ndarray) -> tuple[float, float]:
    g = img.astype(np.float64)
    return float(np.mean(np.diff(g, axis=1) ** 2)), float(np.mean(np.diff(g, axis=0) ** 2))


@pytest.mark.parametrize("name", NAMES)
def test_labels_determinism_and_identity(seq, name: str) -> None:  # type: ignore[no-untyped-def]
    c = corrupt(seq, name, 0.6, seed=5)
    f = c[1]
    assert f.context == {"scene": "indoor"} | LABELS[name]
    assert c.context == {"scene": "indoor"} | LABELS[name]
    assert f.image.shape == seq[1].image.shape and f.image.dtype == np.uint8
    assert not np.array_equal(f.image, seq[1].image)
    assert np.array_equal(f.image, corrupt(seq, name, 0.6, seed=5)[1].image)  # same seed, same frame
    assert np.array_equal(c[2].image, c[1:3][1].image)  # order and slicing do not matter
    assert c[1:3][1].index == 2
    if name != "motion_blur":  # (its flow at a slice's end comes from the frame before)
        assert np.array_equal(c[2].image, corrupt(seq[1:3], name, 0.6, seed=5)[1].image)
    assert np.array_equal(f.pose, seq[1].pose) and np.array_equal(c.timestamps, seq.timestamps)
    zero = corrupt(seq, name, 0.0)
    assert np.array_equal(zero[1].image, seq[1].image) and zero[1].context == {"scene": "indoor"}


def test_noise_depends_on_the_seed(seq) -> None:  # type: ignore[no-untyped-def]
    assert not np.array_equal(corrupt(seq, "dark", 0.5, seed=1)[0].image, corrupt(seq, "dark", 0.5, seed=2)[0].image)


def test_brightness_is_monotone_in_severity(seq) -> None:  # type: ignore[no-untyped-def]
    img = seq[0].image
    dark = [corrupt(seq, "dark", s)[0].image.mean() for s in (0.0, 0.3, 0.6, 1.0)]
    bright = [corrupt(seq, "overexposed", s)[0].image.mean() for s in (0.0, 0.3, 0.6, 1.0)]
    assert all(a > b for a, b in zip(dark, dark[1:], strict=False)) and dark[-1] < 0.2 * img.mean()
    assert all(a < b for a, b in zip(bright, bright[1:], strict=False))
    assert (corrupt(seq, "overexposed", 1.0)[0].image == 255).mean() > 0.5


def test_low_texture_removes_detail(seq) -> None:  # type: ignore[no-untyped-def]
    lap = [cv2.Laplacian(corrupt(seq, "low_texture", s)[0].image, cv2.CV_64F).var() for s in (0.0, 0.3, 1.0)]
    assert lap[0] > 5 * lap[1] > 5 * lap[2]


def test_glare_adds_saturated_blobs_that_stay_put(seq) -> None:  # type: ignore[no-untyped-def]
    c = corrupt(seq, "glare", 0.8, seed=2)
    sat = [(c[i].image >= 250).mean() for i in (0, 1)]
    assert min(sat) > (seq[0].image >= 250).mean() + 0.02
    moved = np.abs(c.blobs(1)[:, :2] - c.blobs(0)[:, :2]).max()
    assert moved < 5.0


@pytest.mark.parametrize("direction, blurred_axis", [((1.0, 0.0, 0.0), 0), ((0.0, 1.0, 0.0), 1)])
def test_motion_blur_follows_the_true_motion(direction, blurred_axis: int) -> None:  # type: ignore[no-untyped-def]
    seq = make_sequence(3, 160, 120, direction=direction, yaw_deg=0.0, step=0.08)
    c = corrupt(seq, "motion_blur", 0.5)
    flow = c.flow(1)
    assert abs(flow[blurred_axis]) > 3 * abs(flow[1 - blurred_axis])  # the flow is along the motion
    before = _grad_energy(seq[1].image)
    after = _grad_energy(c[1].image)
    kept = [after[k] / before[k] for k in (0, 1)]
    # gradients across the motion survive much better than those along it
    assert kept[1 - blurred_axis] > 2.0 * kept[blurred_axis]


def test_motion_blur_falls_back_to_the_poses() -> None:
    seq = make_sequence(3, 160, 120, direction=(1.0, 0.0, 0.0), yaw_deg=0.0)
    flat = type(seq)(seq.dataset, seq.name, seq.intrinsics, [np.full((120, 160), 90, np.uint8)] * 3, seq.timestamps, seq.poses)
    f = corrupt(flat, "motion_blur", 0.5).flow(0)
    # the camera moves +x, so the scene moves −x in the image
    assert f[0] < 0 and abs(f[1]) < 1e-9


def test_line_kernel() -> None:
    k = line_kernel(9, 0.0)
    assert k.sum() == pytest.approx(1.0) and k.shape == (9, 9)
    assert k[4].sum() > 0.9  # all of it on the middle row
    assert line_kernel(9, np.pi / 2)[:, 4].sum() > 0.9


def test_bad_arguments(seq) -> None:  # type: ignore[no-untyped-def]
    assert corrupt(seq, "none", 0.5) is seq
    with pytest.raises(UnknownName, match="fog"):
        corrupt(seq, "fog", 0.5)
    with pytest.raises(ParameterError):
        corrupt(seq, "dark", 1.5)


@settings(max_examples=25, deadline=None)
@given(name=st.sampled_from(NAMES), severity=st.floats(0.0, 1.0), seed=st.integers(0, 2**31))
def test_any_severity_gives_a_valid_frame(seq, name: str, severity: float, seed: int) -> None:  # type: ignore[no-untyped-def]
    f = corrupt(seq, name, severity, seed)[0]
    assert f.image.shape == (120, 160) and f.image.dtype == np.uint8
    assert set(LABELS[name].items()) <= set(f.context.items()) or severity == 0


def test_on_real_kitti_frames(data_dir: Path) -> None:
    kitti = open_sequence(data_dir / "kitti", "kitti", "00")[:3]
    for name in NAMES:
        c = corrupt(kitti, name, 0.5, seed=0)
        f = c[2]
        assert f.image.shape == (376, 1241)
        assert f.context == {"agent": "car", "scene": "outdoor"} | LABELS[name]
    # KITTI 00 drives forward: the median flow of the first frames is small but measured, not the fallback
    assert corrupt(kitti, "motion_blur", 0.5).flow(0) is not None


def test_forward_motion_blurs_radially() -> None:
    """Driving forward the image expands from the centre: the left and right thirds move sideways
    and outwards, so their blur is horizontal; the uniform kernel of a single median could not do this."""
    seq = make_sequence(3, 240, 160, direction=(0.0, 0.0, 1.0), yaw_deg=0.0, step=0.15, planes=("wall",))
    c = corrupt(seq, "motion_blur", 0.6)
    field = c.flow_field(1)
    assert field.shape == (2, 3, 2)
    assert field[:, 0, 0].max() < -1.0 and field[:, 2, 0].min() > 1.0  # left moves left, right moves right
    assert field[0, 1, 1] < 0 < field[1, 1, 1]  # top moves up, bottom moves down
    before, after = seq[1].image, c[1].image
    for cols in (slice(0, 60), slice(180, 240)):
        b = _grad_energy(before[:, cols])
        a = _grad_energy(after[:, cols])
        assert a[1] / b[1] > 1.5 * (a[0] / b[0])  # horizontal detail lost more than vertical


def test_pose_field_matches_the_measured_field() -> None:
    from nfex_slam.datasets.corruptions import FALLBACK_DEPTH_M, pose_motion

    seq = make_sequence(3, 240, 160, direction=(1.0, 0.0, 0.0), yaw_deg=0.0, step=0.08, planes=("wall",))
    measured = corrupt(seq, "motion_blur", 0.5).flow_field(0)
    predicted = pose_motion(seq, 0, 1, (2, 3))
    # the wall is ~3 m away, the fallback assumes FALLBACK_DEPTH_M: same direction, shorter length
    assert np.all(np.sign(measured[..., 0]) == np.sign(predicted[..., 0]))
    ratio = np.median(measured[..., 0] / predicted[..., 0])
    assert 0.5 * FALLBACK_DEPTH_M / 3.0 < ratio < 1.5 * FALLBACK_DEPTH_M / 3.0
