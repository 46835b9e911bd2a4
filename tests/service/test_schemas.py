"""service/schemas/selection.py describes exactly what ``Selection.as_dict()`` produces: real selections
(no frame, a frame, a stream's second frame; with a budget and without) validate against it and
serialise back to the same dict; a member the schema lacks is refused rather than passed through."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import pydantic
import pytest

from nfex_core.advisor import Advisor
from nfex_core.kg import KnowledgeGraph
from service.schemas import Selection


def roundtrip(out: dict[str, Any]) -> dict[str, Any]:
    return Selection.model_validate(out).model_dump(mode="json", by_alias=True, exclude_unset=True)


@pytest.fixture(scope="module")
def frames(data_dir: Path) -> list[Any]:
    folder = data_dir / "kitti" / "sequences" / "01" / "image_0"
    images = [cv2.imread(str(folder / f"{i:06d}.png"), cv2.IMREAD_GRAYSCALE) for i in (0, 1)]
    if any(i is None for i in images):
        pytest.skip(f"{folder} lacks frames 0 and 1")
    return images


def test_selections_roundtrip_through_the_schema(kg: KnowledgeGraph, frames: list[Any]) -> None:
    advisor = Advisor(kg)
    first = advisor.select({"agent": "car"}, frames[0])
    second = advisor.select({"agent": "car"}, frames[1], first.state)
    selections = [
        advisor.select({"agent": "car", "motion": "fast"}),           # prior, no budget
        advisor.select({"agent": "drone", "light": "dark"}),          # prior, the drone's default budget
        advisor.select({"agent": "car"}, budget_ms=5.0),              # a budget that fits Θ′
        first, second,                                                # scored on frames, temporal metrics
    ]
    seen: set[str] = set()
    for sel in selections:
        out = sel.as_dict()
        assert roundtrip(out) == out
        seen |= {k for c in out["candidates"] for k in c["evidence"]} | {"budget" if out["budget"] else ""}
    assert {"f_metrics", "measured_accuracy", "budget"} <= seen  # the optional members were exercised


def _typed(value: Any) -> Any:
    """``value`` with each number's type kept in the comparison (1 and 1.0 differ on the wire; == does not tell)."""
    if isinstance(value, dict):
        return {k: _typed(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_typed(v) for v in value]
    return (type(value).__name__, value)


def test_the_answer_written_unvalidated_is_the_models_json(kg: KnowledgeGraph, frames: list[Any]) -> None:
    """``answer_json`` (what ``POST /v1/select`` writes, without validating through the model) gives the JSON the
    model gives, value for value and type for type, on real selections with and without frames and budgets; NaN and
    the infinities are null, as the model writes them."""
    import json
    import math

    from service.schemas.selection import answer_json

    advisor = Advisor(kg)
    first = advisor.select({"agent": "car"}, frames[0])
    for sel in [advisor.select({"agent": "car", "motion": "fast"}), advisor.select({"agent": "drone", "light": "dark"}),
                advisor.select({"agent": "car"}, budget_ms=5.0), first, advisor.select({"agent": "car"}, frames[1], first.state)]:
        out = sel.as_dict()
        model = json.loads(Selection.model_validate(out).model_dump_json(by_alias=True, exclude_unset=True))
        assert _typed(json.loads(answer_json(out))) == _typed(model)
    out = advisor.select({"agent": "car"}).as_dict()
    out["candidates"][0]["score"], out["candidates"][-1]["score"] = math.nan, math.inf
    model = json.loads(Selection.model_validate(out).model_dump_json(by_alias=True, exclude_unset=True))
    written = json.loads(answer_json(out))
    assert written["candidates"][0]["score"] is None and written["candidates"][-1]["score"] is None
    assert _typed(written) == _typed(model)


def test_a_member_the_schema_lacks_is_refused(kg: KnowledgeGraph) -> None:
    out = Advisor(kg).select({"agent": "car"}).as_dict()
    with pytest.raises(pydantic.ValidationError):
        Selection.model_validate({**out, "verification": []})
    out["candidates"][0]["evidence"]["surprise"] = 1
    with pytest.raises(pydantic.ValidationError):
        Selection.model_validate(out)


def test_the_timings_are_keyed_by_the_advisor_stages_and_their_total(kg: KnowledgeGraph) -> None:
    from nfex_core.advisor.pipeline import STAGES
    from service.schemas.selection import Timings

    assert tuple(Timings.model_fields) == (*STAGES, "total")
    out = Advisor(kg).select({"agent": "car"}).as_dict()
    assert tuple(out["timings_ms"]) == (*STAGES, "total")
    assert out["timings_ms"]["total"] == pytest.approx(sum(out["timings_ms"][s] for s in STAGES), abs=0.01)
