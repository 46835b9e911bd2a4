"""Request bodies at the HTTP edge, with their OpenAPI examples."""
from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

CONTEXT_EXAMPLE: dict[str, Any] = {"agent": "car", "motion": "fast", "scene": "outdoor", "light": "bright"}


class In(BaseModel):
    """A request body: numbers are finite (``NaN``/``Infinity`` are not JSON, and ``"NaN"`` is no number here)."""

    model_config = ConfigDict(allow_inf_nan=False)


def _numbers_as_text(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: str(v) if isinstance(v, int | float) and not isinstance(v, bool) else v for k, v in value.items()}
    return value


# condition dimension → value; a number (budget_ms) is taken as its text
Context = Annotated[dict[str, str | None], BeforeValidator(_numbers_as_text)]


class SelectRequest(In):
    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [{"context": CONTEXT_EXAMPLE}]})

    context: Context = Field(
        default_factory=dict, description="Condition dimension → value; names and values come from GET /v1/vocabulary."
    )


class SessionCreate(In):
    model_config = ConfigDict(
        extra="forbid", json_schema_extra={"examples": [{"context": {"agent": "car", "scene": "outdoor"}, "client": "kitti-replay"}]}
    )

    context: Context = Field(default_factory=dict, description="Context that holds for the whole stream.")
    client: str | None = Field(None, max_length=200, description="Who streams (recorded as the feedback's agent).")


class FeedbackRequest(In):
    """What a client measured with a selection over a window of frames; becomes a nfex:Measurement."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [
                {
                    "extractor": "ORB",
                    "params": {"nfeatures": 2000},
                    "context": {"agent": "car", "light": "bright"},
                    "sequence": "kitti/01",
                    "window_start": 0,
                    "window_end": 100,
                    "ate_rmse": 1.7,
                    "tracking_lost": 3,
                    "mean_inliers": 180.5,
                }
            ]
        },
    )

    extractor: str = Field(..., description="α the client ran (usually the selection's extractor).")
    params: dict[str, Any] = Field(default_factory=dict, description="Θ it ran with (OpenCV names); defaults fill the rest.")
    context: Context = Field(default_factory=dict)
    session_id: str | None = Field(None, description="The session the frames came from; its context fills gaps.")
    sequence: str = Field("client-stream", min_length=1, max_length=200, description="Sequence name, e.g. kitti/01.")
    dataset: str | None = Field(None, max_length=200)
    client: str | None = Field(None, max_length=200, description="The device or program that measured (a label on the run; "
                               "the report is attributed to the token's holder).")
    window_start: int | None = Field(None, ge=0)
    window_end: int | None = Field(None, ge=1)
    frames: int | None = Field(None, ge=1, description="Frames in the window (default window_end - window_start).")
    ate_rmse: float | None = Field(None, ge=0, description="ATE RMSE over the window, metres.")
    rpe_rmse: float | None = Field(None, ge=0)
    tracking_lost: int | None = Field(None, ge=0, description="Frames on which tracking was lost.")
    tracking_failed: bool | None = None
    mean_inliers: float | None = Field(None, ge=0)
    mean_matches: float | None = Field(None, ge=0)
    mean_keypoints: float | None = Field(None, ge=0)
    extraction_ms: float | None = Field(None, ge=0)
    matching_ms: float | None = Field(None, ge=0)
    width: int | None = Field(None, ge=1)
    height: int | None = Field(None, ge=1)


class ConditionValueIn(In):
    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [{"name": "dusk", "label": "dusk", "comment": "Low sun."}]})

    name: str = Field(..., description="The token clients send (lower case).")
    label: str | None = None
    comment: str | None = None


class ParameterPatch(In):
    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [{"default": 1500, "max": 8000}]})

    default: float | int | bool | None = None
    min: float | int | None = None
    max: float | int | None = None
    tunable: bool | None = None
    label: str | None = None
    comment: str | None = None


class RuleIn(In):
    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [
                {
                    "label": "No SIFT in the dark",
                    "query": "SELECT ?extractor ?reason WHERE { FILTER (?light = nfex:light_dark) "
                    "BIND (nfex:SIFT AS ?extractor) BIND (\"too slow in the dark\" AS ?reason) }",
                }
            ]
        },
    )

    label: str = Field(..., min_length=1)
    query: str = Field(..., min_length=1, description="SELECT ?extractor ?reason; context variables ?agent ?light …")
    comment: str | None = None
    enabled: bool = True


class RollbackIn(In):
    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [{"to": 1}]})

    to: int = Field(..., ge=0)


class TriedCandidate(In):
    """What one candidate's estimate of the frame pair showed (nfex_core.verification.PairEvidence)."""

    model_config = ConfigDict(extra="forbid")

    extractor: str
    params: dict[str, int | float | bool] = Field(default_factory=dict)
    keypoints: int = Field(0, ge=0)
    matches: int = Field(0, ge=0)
    inliers: int = Field(0, ge=0)
    parallax_px: float = Field(0.0, ge=0)
    extraction_ms: float = Field(0.0, ge=0)
    R: list[list[float]] | None = Field(None, description="The estimated rotation (3×3, X_k = R·X_k−1 + t); null: the pair was lost.")
    t: list[float] | None = Field(None, description="The estimated translation (3, any scale).")
    rejected: str = Field("", description="Why the client's front-end checks or its geometry lost the pair (empty: they did not).")


class VerdictRequest(In):
    """The estimates of the frame pair tried so far, in the order of the proposals (send them one at a time or all at once)."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={"examples": [{"tried": [{"extractor": "ORB", "keypoints": 2000, "matches": 400, "inliers": 310,
                                                    "parallax_px": 6.5, "extraction_ms": 4.8,
                                                    "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [0, 0, -1]}]}]},
    )

    tried: list[TriedCandidate] = Field(..., min_length=1, max_length=8)
