"""The Selection as the service returns it: the one schema of ``POST /v1/select`` and of a stream's frames.

These models describe exactly what ``nfex_core.advisor.selection.Selection.as_dict()`` produces; the
routes name them as ``response_model``, the OpenAPI document publishes them, and the Python client's types
are generated from that document (``clients/python/generate_types.py``, checked by
``tests/clients/test_client_types.py``). ``POST /v1/select`` writes ``as_dict()`` as it is (``answer_json``):
validating each answer through the model was ~40% of a select's time on the event loop (py-spy), and
``tests/service/test_schemas.py`` holds real selections to the model and ``answer_json`` to the model's JSON.

**Extending the Selection** (e.g. the verification stage's "tried + what each showed") is one change
here: add the member to ``Selection`` (with its own model below if it is an object), then regenerate the
client's types with ``python clients/python/generate_types.py``. Every member is ``extra="forbid"``: a key
``as_dict()`` emits that this schema lacks fails test_schemas.py and the real answers of test_openapi.py, so the
two cannot drift.
"""
from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field
from pydantic_core import to_json

Value = int | float | bool  # a parameter value, as nfex_core.kg.vocabulary.vocab.Value


class Out(BaseModel):
    """A response body: exactly these members, nothing else."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class Citation(Out):
    """A rule (SPARQL rule, DSL statement, context shape, budget, model, measurement) that shaped a decision."""

    rule: str = Field(..., description="The rule's IRI.")
    label: str
    reason: str
    kind: str = Field(..., description="sparql | prune | adjust | weight | prefer | require | accept | escalate | shape | budget | measured")
    source: str | None = Field(None, description="The file or program the rule came from.")


class Adjustment(Out):
    """One parameter changed from the base Θ, and why: Θ′ = Θ·Πf_kj(e_j), clamped to the graph's range."""

    parameter: str
    from_: Value = Field(..., alias="from")
    to: Value
    factor: float
    clamped: bool
    because: list[Citation]


class MeasuredConfiguration(Out):
    """The measured configuration Θ′ was taken from."""

    iri: str
    ate_m: float = Field(..., description="The robust aggregate (see aggregate) of its admitted measurements' ATE, metres.")
    aggregate: str = Field(..., description="How the windows' ATEs are combined: median.")
    windows: int
    outliers: int = Field(..., description="Windows flagged as outliers (kept, shown, not counted).")
    sources: int = Field(..., description="Independent sources (reporters or runs) behind the windows.")
    because: Citation | None


class Evidence(Out):
    """What the graph has measured for a candidate under the context, and how it was scored."""

    ate_m: float | None = Field(None, description="Median ATE measured under the context's known conditions, metres.")
    aggregate: str | None = Field(None, description="How the windows' ATEs are combined: median.")
    windows: int | None = None
    outliers: int | None = Field(None, description="Windows flagged as outliers: shown, not counted.")
    sources: int | None = Field(None, description="Independent sources (reporters or runs) behind the windows.")
    source_iris: list[str] | None = Field(None, description="Up to ten of those sources.")
    extraction_ms: float | None = None
    params_source: str | None = Field(None, description="Which source of the Θ′ chain set Θ′: measured | paramnet | rules.")
    configuration: MeasuredConfiguration | None = None
    expected_ms: float | None = Field(None, description="The cost model's extraction time at this frame size and compute class.")
    cost_source: str | None = None
    f_metrics: float | None = Field(None, description="F_metrics = Σ h_x(E)·m_x on the frame.")
    measured_accuracy: float | None = Field(None, description="A(α): best mean ATE / α's mean ATE under E.")
    not_scored: str | None = None
    score_without_net: float | None = None


class Candidate(Out):
    extractor: str
    score: float | None
    bonus: float
    metrics: dict[str, float] = Field(..., description="m1–m7 on the frame, each in [0, 1]; empty without a frame.")
    params: dict[str, Value] = Field(..., description="Θ′ under OpenCV's argument names.")
    adjustments: list[Adjustment]
    keypoints: int | None
    extraction_ms: float | None
    evidence: Evidence


class Pruned(Out):
    extractor: str
    because: list[Citation]


class ContextEntry(Out):
    dimension: str
    value: str | None
    source: str = Field(..., description="given | estimated | unknown")
    confidence: float | None = None
    evidence: str | None = Field(None, description="What an estimate was based on.")


class Weight(Out):
    """h_x(E): a quality metric's weight under the context."""

    value: float
    because: list[Citation]


class Budget(Out):
    ms: float
    source: str = Field(..., description="given | agent default (…)")
    compute: str
    factor: float
    width: int
    height: int
    size_source: str = Field(..., description="frame | given | assumed: …")


class ModelInfo(Out):
    """Which neural model served the request, or why none did."""

    mode: str = Field(..., description="NFEX_NEURAL: symbolic | paramnet | selectornet | both")
    used: str = Field(..., description="What was used: symbolic, paramnet, selectornet or paramnet+selectornet.")
    fallback: str | None = None
    name: str | None = None
    version: str | None = None
    data_sha256: str | None = None
    git_commit: str | None = None
    skipped: dict[str, str] | None = Field(None, description="Networks left out because validation did not beat a baseline.")
    load_ms: float | None = None
    declined: str | None = None


class Versions(Out):
    graph: int = Field(..., description="The graph version whose compiled snapshot answered.")
    graph_head: int = Field(..., description="The newest graph version this process knows of (commits through it are "
                            "known at once, a shared store's at the next poll).")
    stale_ms: float = Field(..., description="How long a version newer than `graph` has been waiting for its compile, ms; "
                            "0 when fresh. Bounded by one compile time after the last commit (plus the poll interval for "
                            "a shared store); `?consistency=latest` waits for the head instead.")
    programs: dict[str, int] = Field(..., description="DSL program → statements in force.")
    rules: int
    model: ModelInfo


class Timings(Out):
    """Milliseconds per stage of the flow, in order, and their total.

    The stages are nfex_core/advisor/pipeline.py's ``STAGES``. When a stream's decision is carried (``reused`` > 0)
    params, budget and verification do not run: 0."""

    conditions: float
    symbolic: float
    params: float
    budget: float
    scoring: float
    verification: float
    answer: float
    total: float


class Grid(Out):
    cell_size: int = Field(..., description="Square cell side in pixels over which detections are spread.")
    keep: int = Field(..., description="How many keypoints to keep after spreading (Θ′'s feature count).")


class OpenCV(Out):
    """How a client builds α with Θ′ itself (``ExtractorSpec.opencv``)."""

    constructor: str = Field(..., description="e.g. ORB_create: cv2.<constructor>(**args); empty for a learned model.")
    norm: str = Field(..., description="The matcher's norm, e.g. NORM_HAMMING.")
    args: dict[str, Value] = Field(default_factory=dict, description="The constructor's arguments: Θ′ without grid "
                                   "settings, the feature count oversampled under a grid.")
    grid: Grid | None = Field(None, description="Spread detections over square cells before computing descriptors "
                              "(ORB_GRID), or null.")
    matcher: str = Field("ratio", description="How descriptors are matched: ratio (Lowe's test) | mutual-ratio (and "
                         "mutual nearest neighbours).")
    descriptor_kind: str = Field("", description="binary (Hamming norms) | real (L2).")


class Keypoints(Out):
    """The keypoints α* with Θ′ finds on the full frame (``?keypoints=true``, for drawing), strongest first."""

    extractor: str
    count: int = Field(..., description="All keypoints found; at most the first few hundred are listed.")
    width: int
    height: int
    xy: list[list[float]] = Field(..., description="Pixel positions [x, y] (x right, y down).")
    size: list[float] = Field(..., description="Keypoint diameters in pixels.")
    extraction_ms: float


class AcceptRule(Out):
    tests: list[str] = Field(..., description="`signal comparator threshold`; the rule accepts when all hold.")
    because: Citation


class Proposal(Out):
    extractor: str
    params: dict[str, Value]
    expected_ms: float | None = Field(None, description="The cost model's expected extraction ms (under a budget).")
    opencv: OpenCV | None = Field(None, description="How to build this proposal's extractor (as the selection's `opencv`).")


class Verification(Out):
    """How the frame pair is verified (docs/service.md, "Verified selection"): try ``proposals`` in order, report
    each estimate to ``POST /v1/sessions/{id}/verdict``; ``accept`` empty: the first estimate that passes the
    front-end checks is taken."""

    max_tries: int = Field(..., description="1 + the escalations allowed.")
    accept: list[AcceptRule]
    escalation: Citation | None
    proposals: list[Proposal] = Field(..., description="The candidates to try, in order (one per extractor).")


class Scoring(Out):
    """How α* was reached on this request and the extraction work it took (nfex_core/advisor/bounds.py)."""

    outcome: str = Field(..., description="scored (α* extracted and scored on the frame) | settled (bounds settled α* "
                         "without extracting it) | unscored (no frame, or a stream's decision reused)")
    reason: str
    extractions: int = Field(..., description="Feature extractions run for this answer (a stream's owed ones included).")
    pixels: int = Field(..., description="Pixels those extractions processed.")


class Selection(Out):
    """α*, Θ′ and why."""

    extractor: str = Field(..., description="α*: the extractor to run.")
    params: dict[str, Value] = Field(..., description="Θ′ under OpenCV's argument names: cv2.<constructor>(**params).")
    opencv: OpenCV
    mode: str = Field(..., description="prior (no frame) | metrics (F_metrics on the frame) | selectornet")
    candidates: list[Candidate] = Field(..., description="C(E), best first.")
    pruned: list[Pruned]
    context: list[ContextEntry]
    weights: dict[str, Weight]
    budget: Budget | None
    verification: Verification
    warnings: list[str]
    versions: Versions
    timings_ms: Timings
    reused: int = Field(0, description="In a stream: how many frames in a row this answer has been reused because its "
                                       "evidence did not move (a session: nfex:sessionDecisionFrames; other streams: "
                                       "nfex:decisionReuseFrames); 0: decided on this frame.")
    scoring: Scoring | None = Field(None, description="How α* was reached and the extractions it took.")
    keypoints: Keypoints | None = Field(None, description="Only with ?keypoints=true and a frame.")


class StreamPosition(Out):
    id: str
    frame: int
    temporal: bool = Field(..., description="Whether temporal metrics and motion had a previous frame.")
    reused: bool = Field(False, description="Whether this frame kept the session's last decision because its evidence "
                         "(the condition estimate, the last verification verdict) had not moved (nfex:sessionDecisionFrames).")


class Verdict(Out):
    """The decision on a frame pair after the candidates tried so far."""

    action: str = Field(..., description="accept | next (try `next`) | fallback (use the motion prior: the last accepted motion)")
    reason: str
    accepted: int | None = Field(None, description="Index into `tried` of the estimate to use (action accept).")
    because: Citation | None = Field(None, description="The accept statement that held, or the escalate statement in force.")
    next: Proposal | None = Field(None, description="The next candidate to try (action next).")
    signals: list[dict[str, float | None]] = Field(..., description="Each try's signals (docs/dsl.md, Verification); null: undefined.")
    tries: int = Field(..., description="Candidates tried on this pair so far.")


class SessionSelection(Selection):
    """A stream's frame: the Selection and where the stream stands."""

    session: StreamPosition


def answer_json(out: dict[str, Any]) -> bytes:
    """A Selection's ``as_dict()`` as the service writes it, unvalidated: the JSON the model would write (NaN and the
    infinities as null), members in ``as_dict()``'s order."""
    return to_json(out, inf_nan_mode="null")
