"""A SLAM replay client: the nFEX visual odometry over a dataset sequence, asking the service per frame."""
from __future__ import annotations

from .replay import ReplayResult, ServiceChooser, replay

__all__ = ["ReplayResult", "ServiceChooser", "replay"]
