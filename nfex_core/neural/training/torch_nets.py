"""The torch twins of ParamNet and SelectorNet, for training only (torch is imported when called).

Parameter names equal the NumPy models' weight keys (``fc1.weight``…, ``conv1.weight``…), so export is
``{k: v.numpy()}`` and the NumPy forward pass reproduces torch's to float32 precision (tested to 1e-5).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np


def paramnet_module(sizes: tuple[int, int, int, int]) -> Any:
    """MLP: 3 linear layers, 2 ReLU (§IV-B)."""
    import torch
    from torch import nn

    class ParamNetTorch(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.fc1 = nn.Linear(sizes[0], sizes[1])
            self.fc2 = nn.Linear(sizes[1], sizes[2])
            self.fc3 = nn.Linear(sizes[2], sizes[3])

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            return self.fc3(torch.relu(self.fc2(torch.relu(self.fc1(x)))))

    return ParamNetTorch()


def selectornet_module(n_numeric: int, n_outputs: int, channels: tuple[int, int] = (8, 16), hidden: tuple[int, int] = (64, 32)) -> Any:
    """Two strided 3×3 convolutions + global average pooling, concatenated with the numbers, then 3 FC layers."""
    import torch
    from torch import nn

    class SelectorNetTorch(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.conv1 = nn.Conv2d(1, channels[0], 3, stride=2, padding=1)
            self.conv2 = nn.Conv2d(channels[0], channels[1], 3, stride=2, padding=1)
            self.fc1 = nn.Linear(channels[1] + n_numeric, hidden[0])
            self.fc2 = nn.Linear(hidden[0], hidden[1])
            self.fc3 = nn.Linear(hidden[1], n_outputs)

        def forward(self, image: torch.Tensor, numeric: torch.Tensor) -> torch.Tensor:
            h = torch.relu(self.conv2(torch.relu(self.conv1(image.unsqueeze(1)))))
            z = torch.cat([h.mean(dim=(2, 3)), numeric], dim=1)
            return self.fc3(torch.relu(self.fc2(torch.relu(self.fc1(z)))))

    return SelectorNetTorch()


def export(module: Any) -> dict[str, np.ndarray]:
    return {k: v.detach().cpu().numpy().astype(np.float32) for k, v in module.state_dict().items()}


def load(module: Any, weights: Mapping[str, np.ndarray]) -> Any:
    import torch

    module.load_state_dict({k: torch.from_numpy(np.asarray(v, np.float32)) for k, v in weights.items()})
    return module
