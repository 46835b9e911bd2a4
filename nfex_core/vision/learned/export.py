"""Export XFeat's network to ONNX: ``python -m nfex_core.vision.learned.export [WEIGHTS DEST]``.

Without arguments: the configured weights into the configured cache (``NFEX_XFEAT_WEIGHTS``,
``NFEX_LEARNED_CACHE``), the ahead-of-time step (``make learned``).

Run by ``model.export_onnx`` in a child process on first use (torch stays out of the serving process),
or ahead of time. Opset 17, TorchScript-based exporter (``dynamo=False``: it needs the ``onnx`` package, not
onnxscript), dynamic height and width; written to a temporary file in DEST's folder, then renamed.
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

OPSET = 17


def export(weights: Path, dest: Path) -> Path:
    import torch

    from .network import load

    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=dest.name + ".", suffix=".tmp", dir=dest.parent)
    os.close(fd)
    try:
        net = load(weights, threads=1)
        dims, out_dims = {2: "height", 3: "width"}, {2: "height8", 3: "width8"}
        torch.onnx.export(
            net, (torch.zeros(1, 1, 64, 96),), tmp, dynamo=False, opset_version=OPSET,
            input_names=["image"], output_names=["descriptors", "keypoint_logits", "reliability"],
            dynamic_axes={"image": dims, "descriptors": out_dims, "keypoint_logits": out_dims, "reliability": out_dims},
        )
        os.replace(tmp, dest)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return dest


def main(argv: list[str]) -> int:
    if len(argv) not in (0, 2):
        print("usage: python -m nfex_core.vision.learned.export [WEIGHTS DEST]", file=sys.stderr)
        return 2
    if not argv:
        from ...config import Settings
        from .model import availability, onnx_path, weights_path

        settings = Settings.from_env()
        weights = weights_path(settings)
        if weights is None or not weights.is_file():
            print(f"nfex: {availability(settings).detail}", file=sys.stderr)
            return 2
        argv = [str(weights), str(onnx_path(settings, weights))]
    try:
        print(export(Path(argv[0]), Path(argv[1])))
    except Exception as e:  # one line for the parent's error message
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
