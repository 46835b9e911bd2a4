"""The flow's ``conditions`` stage: the context E the rest of the flow decides under.

What the client gives always wins; the dimensions the graph marks estimable (light, texture, motion,
reflectance) and the client left open are estimated from the frame (``vision.context``), with a
confidence and what the estimate rests on; everything else stays unknown. Without a frame, E is what was
given. The frame statistics are computed once here: context estimation and ParamNet both read them.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..context import ContextEntry
from ..errors import BadInput
from ..kg.vocabulary.vocab import Vocabulary

if TYPE_CHECKING:
    from .scoring import FrameState


MIN_FRAME_SIDE = 8


@dataclass(frozen=True)
class Conditions:
    entries: tuple[ContextEntry, ...]  # one per dimension: value, given | estimated | unknown, confidence
    values: dict[str, str | None]  # E: dimension → value (None: unknown)
    image: np.ndarray | None  # the frame as 8-bit grey, full size
    stats: Mapping[str, float] | None  # frame statistics (vision.statistics), None without a frame
    analysis: np.ndarray | None = None  # the frame's copy the statistics were computed on (a stream keeps it)


def read_conditions(
    vocab: Vocabulary, given: Mapping[str, str], frame: np.ndarray | None, previous: FrameState | None
) -> Conditions:
    """E from the checked client context ``given`` and, where it is open, from the frame."""
    if frame is None:
        entries = tuple(ContextEntry(d, given[d], "given", 1.0) if d in given else ContextEntry(d, None, "unknown")
                        for d in vocab.dimensions)
        return Conditions(entries, {e.dimension: e.value for e in entries}, None, None)
    from nfex_slam.features import as_grey_u8

    from ..vision.context import estimate_context  # imports cv2: only when a frame comes
    from ..vision.statistics import analysis_image, frame_statistics

    image = as_grey_u8(frame)
    if min(image.shape[:2]) < MIN_FRAME_SIDE:  # a 1-pixel frame broke OpenCV's pyramids (a 500, bench/bench_fuzz.py)
        raise BadInput(f"the frame is {image.shape[1]}×{image.shape[0]} pixels; features need at least "
                       f"{MIN_FRAME_SIDE}×{MIN_FRAME_SIDE}")
    prev = previous.image if previous is not None else None
    analysis = analysis_image(image)
    stats = frame_statistics(image, prev, analysis=analysis,
                             previous_analysis=previous.analysis if previous is not None else None)
    entries = tuple(estimate_context(vocab, given, image, prev, stats=stats).entries())
    return Conditions(entries, {e.dimension: e.value for e in entries}, image, stats, analysis)
