"""Build the OpenCV objects a selection names (needs opencv; imported lazily)."""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def extractor_from_selection(selection: Mapping[str, Any]) -> Any:
    """``cv2.<constructor>(**params)`` for a selection (``opencv.constructor`` may be dotted, e.g.
    ``xfeatures2d.AKAZE_create``); the parameters are OpenCV's own argument names."""
    import cv2

    target: Any = cv2
    for part in selection["opencv"]["constructor"].split("."):
        target = getattr(target, part)
    return target(**selection["params"])


def matcher_from_selection(selection: Mapping[str, Any], cross_check: bool = True) -> Any:
    """A brute-force matcher with the norm the selection's descriptor needs."""
    import cv2

    return cv2.BFMatcher(getattr(cv2, selection["opencv"]["norm"]), crossCheck=cross_check)


def encode_png(image: Any) -> bytes:
    import cv2

    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise ValueError("cv2.imencode could not encode the frame as PNG")
    return bytes(buf)
