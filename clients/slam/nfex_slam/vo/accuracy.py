"""How far a VO run is from the ground truth: ATE and RPE as ``nfex evaluate`` and the sweeps report them."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..datasets.base import Sequence
from ..errors import NfexError
from ..trajectory import Trajectory, ate, rpe


def window_errors(seq: Sequence, res: Any) -> tuple[float | None, float | None]:
    """ATE RMSE (Sim(3), as evo ``-as``) and RPE RMSE (consecutive frames, after the same Sim(3)
    scale) of a VO result against the ground truth; (None, None) without ground truth or when the
    alignment is degenerate (e.g. the estimate does not move)."""
    gt = np.array([seq[f.index].pose for f in res.frames], dtype=object)
    if any(p is None for p in gt):
        return None, None
    ref = Trajectory(res.timestamps.copy(), np.stack(list(gt)).astype(float))
    est = Trajectory(res.timestamps.copy(), res.poses.copy())
    try:
        a = ate(ref, est, align="sim3")
        r = rpe(ref, est, align="sim3")
    except (NfexError, np.linalg.LinAlgError):
        return None, None
    if not np.isfinite(a.rmse):
        return None, None
    return float(a.rmse), float(r.rmse)
