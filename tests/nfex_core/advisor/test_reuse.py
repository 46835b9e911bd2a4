"""A stream's decision reused while the context and the frame statistics do not move (advisor/reuse.py)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from nfex_core.advisor.advisor import Advisor
from nfex_core.advisor.reuse import ReuseTerms, moved
from nfex_core.kg import KnowledgeGraph

FRAMES = "kitti/sequences/00/image_0"


def allow_reuse(kg: KnowledgeGraph, frames: int, change: float = 0.05) -> None:
    kg.update(f"""PREFIX nfex: <https://w3id.org/nfex#>
        PREFIX xsd: <http://www.w3.org/2001/XMLSchema#>
        DELETE {{ nfex:decisionReuseFrames nfex:value ?f . nfex:decisionReuseChange nfex:value ?c }}
        INSERT {{ nfex:decisionReuseFrames nfex:value {frames} . nfex:decisionReuseChange nfex:value "{change}"^^xsd:double }}
        WHERE {{ nfex:decisionReuseFrames nfex:value ?f . nfex:decisionReuseChange nfex:value ?c }}""", author="test")


def stream(advisor: Advisor, images: list[np.ndarray], context: dict[str, str]) -> list:  # type: ignore[type-arg]
    out, state = [], None
    for image in images:
        sel = advisor.select(context, image, state)
        out.append(sel)
        state = sel.state
    return out


def test_the_shipped_graph_scores_every_frame(kg: KnowledgeGraph, data_dir: Path) -> None:
    assert ReuseTerms.load(kg).frames == 0
    image = cv2.imread(str(sorted((data_dir / FRAMES).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    assert [s.reused for s in stream(Advisor(kg), [image] * 3, {"agent": "car"})] == [0, 0, 0]


def test_a_still_frame_reuses_the_decision_at_most_n_frames(kg: KnowledgeGraph, data_dir: Path) -> None:
    allow_reuse(kg, 2)
    assert ReuseTerms.load(kg) == ReuseTerms(2, 0.05)
    image = cv2.imread(str(sorted((data_dir / FRAMES).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    out = stream(Advisor(kg), [image] * 5, {"agent": "drone"})
    assert [s.reused for s in out] == [0, 1, 2, 0, 1]
    first = out[0]
    for s in out[1:3]:
        assert (s.extractor, s.params, s.mode, s.candidates) == (first.extractor, first.params, first.mode, first.candidates)
        assert "reused" in s.timings_ms and "selection" not in s.timings_ms  # nothing was scored
        assert s.as_dict()["reused"] == s.reused
    assert "selection" in out[3].timings_ms


def test_a_frame_that_moved_or_a_new_context_is_scored(kg: KnowledgeGraph, data_dir: Path) -> None:
    allow_reuse(kg, 10)
    image = cv2.imread(str(sorted((data_dir / FRAMES).glob("*.png"))[40]), cv2.IMREAD_GRAYSCALE)
    darker = (image * 0.5).astype(np.uint8)  # brightness halves: a statistic moves by far more than 5 %
    advisor = Advisor(kg)
    first = advisor.select({"agent": "drone"}, image)
    assert advisor.select({"agent": "drone"}, darker, first.state).reused == 0
    assert advisor.select({"agent": "drone", "scene": "indoor"}, image, first.state).reused == 0
    assert advisor.select({"agent": "drone"}, image, first.state).reused == 1


def test_moved_is_the_largest_relative_change() -> None:
    before, after = {"a": 1.0, "b": 10.0, "c": 0.0}, {"a": 1.1, "b": 10.0, "c": 0.0}
    assert moved(before, after, ("a", "b", "c")) == pytest.approx(0.1 / 1.1)
    assert moved({"f": 0.001}, {"f": 0.002}, ("f",)) == pytest.approx(0.001)  # a fraction near 0: absolute
    assert moved(before, before, ("a", "b", "c")) == 0.0
    assert moved(before, after, ()) == 0.0
