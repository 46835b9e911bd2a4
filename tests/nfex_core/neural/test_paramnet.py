from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nfex_core.neural.encoding import InputVocabulary, ParamScale
from nfex_core.neural.paramnet import ParamNet, decode, init_weights
from nfex_core.neural.training import torch_nets


def torch_forward(weights: dict[str, np.ndarray], x: np.ndarray) -> np.ndarray:
    import torch

    sizes = (weights["fc1.weight"].shape[1], weights["fc1.weight"].shape[0], weights["fc2.weight"].shape[0], weights["fc3.weight"].shape[0])
    m = torch_nets.load(torch_nets.paramnet_module(sizes), weights)
    with torch.no_grad():
        return m(torch.from_numpy(x)).numpy()


def test_numpy_equals_torch_random_weights() -> None:
    w = init_weights((26, 64, 64, 20), seed=3)
    x = np.random.default_rng(1).normal(size=(32, 26)).astype(np.float32)
    np.testing.assert_allclose(ParamNet(w).forward(x), torch_forward(w, x), atol=1e-5, rtol=0)
    np.testing.assert_allclose(ParamNet(w).forward(x[0]), torch_forward(w, x[:1])[0], atol=1e-5, rtol=0)


def test_numpy_equals_torch_trained(trained) -> None:  # type: ignore[no-untyped-def]
    _, model = trained
    net = model.paramnet
    x = np.random.default_rng(2).normal(size=(16, net.n_inputs)).astype(np.float32)
    np.testing.assert_allclose(net.forward(x), torch_forward(dict(net.weights), x), atol=1e-5, rtol=0)


@given(st.floats(0.0, 1.0), st.sampled_from(["linear", "log", "log1p"]))
def test_unit_scale_round_trip(u: float, scale: str) -> None:
    p = ParamScale("X", "p", "double", 1e-3 if scale == "log" else 0.0, 20000.0, scale)
    assert abs(p.to_unit(p.from_unit(u)) - u) < 1e-9
    assert p.lo <= p.from_unit(u) <= p.hi * (1 + 1e-12)


@settings(deadline=None, max_examples=50)
@given(st.lists(st.floats(-5.0, 5.0, allow_nan=False), min_size=64, max_size=64), st.sampled_from([None, 1241 * 376, 1920 * 1080, 100]))
def test_decoded_params_are_valid_in_the_graph(vocab, u: list[float], pixels: int | None) -> None:  # type: ignore[no-untyped-def]
    """Whatever the network outputs, Θ′ is in each parameter's range and of its datatype."""
    inputs = InputVocabulary.from_vocabulary(vocab)
    arr = np.array(u[: len(inputs.params)], np.float32)
    for x, spec in vocab.extractors.items():
        out = decode(inputs, arr, spec, pixels)
        assert set(out) == {p.name for _, p in inputs.params_of(x)}
        for name, (value, _raw) in out.items():
            assert spec.parameter(name).validate(value) == value


@settings(deadline=None, max_examples=50)
@given(st.lists(st.floats(-1.0, 2.0, allow_nan=False), min_size=64, max_size=64))
def test_grid_snaps_to_measured_values(vocab, u: list[float]) -> None:  # type: ignore[no-untyped-def]
    """With a grid, every θ′ is one of the values the sweep measured (here: two per parameter)."""
    inputs = InputVocabulary.from_vocabulary(vocab)
    grid = {i: (np.array([0.0, 0.5]), np.array([p.from_unit(0.0), p.from_unit(0.5)])) for i, p in enumerate(inputs.params)}
    arr = np.array(u[: len(inputs.params)], np.float32)
    for x, spec in vocab.extractors.items():
        for name, (value, _raw) in decode(inputs, arr, spec, None, grid).items():
            p = next(q for _, q in inputs.params_of(x) if q.name == name)
            assert value in {spec.parameter(name).clamp(p.from_unit(g)) for g in (0.0, 0.5)}
