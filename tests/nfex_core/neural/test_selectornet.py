from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nfex_core.neural.selectornet import IMAGE_HW, SelectorNet, conv2d_hwc, init_weights, masked_probabilities
from nfex_core.neural.training import torch_nets


def torch_logits(weights: dict[str, np.ndarray], images: np.ndarray, numeric: np.ndarray) -> np.ndarray:
    import torch

    n_out = weights["fc3.weight"].shape[0]
    n_num = weights["fc1.weight"].shape[1] - weights["conv2.weight"].shape[0]
    m = torch_nets.load(torch_nets.selectornet_module(n_num, n_out), weights)
    with torch.no_grad():
        return m(torch.from_numpy(images), torch.from_numpy(numeric)).numpy()


def test_conv_equals_torch() -> None:
    import torch

    rng = np.random.default_rng(0)
    x = rng.normal(size=(13, 22, 5)).astype(np.float32)
    w = rng.normal(size=(7, 5, 3, 3)).astype(np.float32)
    b = rng.normal(size=7).astype(np.float32)
    ref = torch.nn.functional.conv2d(torch.from_numpy(x).permute(2, 0, 1)[None], torch.from_numpy(w), torch.from_numpy(b), stride=2, padding=1)
    np.testing.assert_allclose(conv2d_hwc(x, w, b), ref[0].permute(1, 2, 0).numpy(), atol=1e-5, rtol=0)


def test_numpy_equals_torch_random_weights() -> None:
    w = init_weights(n_numeric=55, n_outputs=4, seed=5)
    rng = np.random.default_rng(1)
    images = rng.uniform(size=(6, *IMAGE_HW)).astype(np.float32)
    numeric = rng.normal(size=(6, 55)).astype(np.float32)
    np.testing.assert_allclose(SelectorNet(w).forward(images, numeric), torch_logits(w, images, numeric), atol=1e-5, rtol=0)


def test_numpy_equals_torch_trained(trained) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    net = model.selectornet
    rng = np.random.default_rng(2)
    images = rng.uniform(size=(4, *IMAGE_HW)).astype(np.float32)
    numeric = rng.normal(size=(4, net.n_numeric)).astype(np.float32)
    np.testing.assert_allclose(net.forward(images, numeric), torch_logits(dict(net.weights), images, numeric), atol=1e-5, rtol=0)


NAMES = ("AKAZE", "BRISK", "ORB", "SIFT")


@settings(max_examples=100)
@given(st.lists(st.floats(-50, 50), min_size=4, max_size=4), st.sets(st.sampled_from(NAMES), min_size=1))
def test_a_pruned_extractor_is_never_chosen(logits: list[float], allowed: set[str]) -> None:
    p = masked_probabilities(np.array(logits), NAMES, sorted(allowed))
    assert set(p) == allowed
    assert abs(sum(p.values()) - 1.0) < 1e-9
    assert max(p, key=p.__getitem__) in allowed


def test_the_blank_image_embedding_is_cached_and_equal_to_computing_it() -> None:
    net = SelectorNet(init_weights(5, 3, seed=3))
    blank = np.zeros((48, 160), np.float32)
    first = net.embed(blank)
    assert net.embed(blank) is first  # computed once per shape
    np.testing.assert_array_equal(first, net._embed(blank))
    other = net.embed(np.zeros((24, 80), np.float32))
    np.testing.assert_array_equal(other, net._embed(np.zeros((24, 80), np.float32)))
    image = np.random.default_rng(0).random((48, 160)).astype(np.float32)
    assert not np.array_equal(net.embed(image), first)  # a real frame is not taken for the blank one


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), width=st.floats(0.0, 3.0))
def test_logit_bounds_hold_every_point_of_the_box(seed: int, width: float) -> None:
    """Interval bound propagation is sound: the logits of any numeric input inside the box (corners included)
    lie within the bounds, and a box of width 0 gives the network's own logits."""
    n_numeric = 12
    net = SelectorNet(init_weights(n_numeric=n_numeric, n_outputs=5, seed=seed % 97))
    rng = np.random.default_rng(seed)
    image = rng.uniform(size=IMAGE_HW).astype(np.float32)
    low = rng.normal(size=n_numeric).astype(np.float32)
    high = low + np.float32(width) * rng.uniform(size=n_numeric).astype(np.float32)
    lo, hi = net.logit_bounds(image, low, high)
    assert np.all(lo <= hi)
    points = [low, high, *(low + (high - low) * rng.uniform(size=n_numeric).astype(np.float32) for _ in range(30))]
    points += [np.where(rng.uniform(size=n_numeric) < 0.5, low, high) for _ in range(10)]  # corners
    for x in points:
        z = net.logits(image, x)
        assert np.all(z >= lo - 1e-4) and np.all(z <= hi + 1e-4)
    lo0, hi0 = net.logit_bounds(image, low, low)
    np.testing.assert_allclose(lo0, net.logits(image, low), atol=1e-4)
    np.testing.assert_allclose(hi0, lo0, atol=1e-9)


def test_numeric_box_spans_the_unknown_metrics_only() -> None:
    from nfex_core.neural.selectornet import numeric_box, numeric_input

    ctx, stats = np.array([1.0, 0.0], np.float32), np.array([0.5], np.float32)
    names, extractors = ("a", "b", "c"), ("ORB", "SIFT")
    known = {"ORB": {"a": 0.2, "b": 0.4, "c": 0.6}}
    low, high = numeric_box(ctx, stats, known, {"SIFT": ("a", "b")}, extractors, names)
    every = numeric_input(ctx, stats, True, {**known, "SIFT": {"a": 1.0, "b": 1.0}}, extractors, names)
    none = numeric_input(ctx, stats, True, {**known, "SIFT": {"a": 0.0, "b": 0.0, "c": 0.0}}, extractors, names)
    np.testing.assert_array_equal(high, every)  # SIFT's a and b at 1, c absent (0), its bit set
    np.testing.assert_array_equal(low, none)
