"""Response types of the nFEX service: generated from its OpenAPI document by ``python -m nfex_client.generate``.

Do not edit: change the service's schemas (service/schemas/) and regenerate.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypedDict

if TYPE_CHECKING:
    from typing_extensions import NotRequired  # noqa: UP035 - the client runs on Python 3.10 too


class AcceptRule(TypedDict):
    tests: list[str]
    because: Citation


# One parameter changed from the base Θ, and why: Θ′ = Θ·Πf_kj(e_j), clamped to the graph's range.
Adjustment = TypedDict('Adjustment', {'parameter': 'str', 'from': 'int | float | bool', 'to': 'int | float | bool', 'factor': 'float', 'clamped': 'bool', 'because': 'list[Citation]'})


class BackendStatus(TypedDict):
    extractors: list[str]
    available: bool
    detail: str
    setting: NotRequired[str | None]


class Budget(TypedDict):
    ms: float
    source: str
    compute: str
    factor: float
    width: int
    height: int
    size_source: str


class Candidate(TypedDict):
    extractor: str
    score: float | None
    bonus: float
    metrics: dict[str, float]
    params: dict[str, int | float | bool]
    adjustments: list[Adjustment]
    keypoints: int | None
    extraction_ms: float | None
    evidence: Evidence


class Citation(TypedDict):
    """A rule (SPARQL rule, DSL statement, context shape, budget, model, measurement) that shaped a decision."""

    rule: str
    label: str
    reason: str
    kind: str
    source: NotRequired[str | None]


class ConditionValue(TypedDict):
    iri: str
    label: str


class Conditions(TypedDict):
    graph_version: int
    dimensions: dict[str, Dimension]


class ContextEntry(TypedDict):
    dimension: str
    value: str | None
    source: str
    confidence: NotRequired[float | None]
    evidence: NotRequired[str | None]


class Diff(TypedDict):
    added: list[str]
    removed: list[str]
    added_count: int
    removed_count: int
    truncated: bool
    since: int
    until: int


class Dimension(TypedDict):
    iri: str
    estimable: bool
    values: dict[str, ConditionValue]


class DimensionValues(TypedDict):
    values: list[str]
    estimable: bool


class Evidence(TypedDict):
    """What the graph has measured for a candidate under the context, and how it was scored."""

    ate_m: NotRequired[float | None]
    aggregate: NotRequired[str | None]
    windows: NotRequired[int | None]
    outliers: NotRequired[int | None]
    sources: NotRequired[int | None]
    source_iris: NotRequired[list[str] | None]
    extraction_ms: NotRequired[float | None]
    params_source: NotRequired[str | None]
    configuration: NotRequired[MeasuredConfiguration | None]
    expected_ms: NotRequired[float | None]
    cost_source: NotRequired[str | None]
    f_metrics: NotRequired[float | None]
    measured_accuracy: NotRequired[float | None]
    not_scored: NotRequired[str | None]
    score_without_net: NotRequired[float | None]


class Extractor(TypedDict):
    name: str
    iri: str
    label: str
    constructor: str
    norm: str
    descriptor_kind: str
    operations: list[str]
    parameters: dict[str, Parameter]


class ExtractorBrief(TypedDict):
    constructor: str
    norm: str
    parameters: dict[str, ParameterBrief]


class ExtractorList(TypedDict):
    graph_version: int
    extractors: list[Extractor]


class Grid(TypedDict):
    cell_size: int
    keep: int


class Head(TypedDict):
    version: int
    store: str
    triples: int


class Health(TypedDict):
    status: str


class Keypoints(TypedDict):
    """The keypoints α* with Θ′ finds on the full frame (``?keypoints=true``, for drawing), strongest first."""

    extractor: str
    count: int
    width: int
    height: int
    xy: list[list[float]]
    size: list[float]
    extraction_ms: float


class MeasuredConfiguration(TypedDict):
    """The measured configuration Θ′ was taken from."""

    iri: str
    ate_m: float
    aggregate: str
    windows: int
    outliers: int
    sources: int
    because: Citation | None


class MetricBrief(TypedDict):
    symbol: str
    temporal: bool


class ModelInfo(TypedDict):
    """Which neural model served the request, or why none did."""

    mode: str
    used: str
    fallback: NotRequired[str | None]
    name: NotRequired[str | None]
    version: NotRequired[str | None]
    data_sha256: NotRequired[str | None]
    git_commit: NotRequired[str | None]
    skipped: NotRequired[dict[str, str] | None]
    load_ms: NotRequired[float | None]
    declined: NotRequired[str | None]


class OpenCV(TypedDict):
    """How a client builds α with Θ′ itself (``ExtractorSpec.opencv``)."""

    constructor: str
    norm: str
    args: NotRequired[dict[str, int | float | bool]]
    grid: NotRequired[Grid | None]
    matcher: NotRequired[str]
    descriptor_kind: NotRequired[str]


class Parameter(TypedDict):
    iri: str
    role: str
    datatype: str
    default: int | float | bool
    min: int | float | bool | None
    max: int | float | bool | None
    allowed: list[int | float | bool] | None
    tunable: bool
    label: str


class ParameterBrief(TypedDict):
    role: str
    datatype: str
    default: int | float | bool
    range: str


class Problem(TypedDict):
    """RFC 9457 problem details; extra members (allowed, violations, limit, current_version…) depend on the type."""

    type: str
    title: str
    status: int
    detail: str


class Program(TypedDict):
    name: str
    iri: str
    statements: int
    source: str | None
    text: str


class ProgramInfo(TypedDict):
    name: str
    iri: str
    statements: int
    source: str | None


class ProgramList(TypedDict):
    graph_version: int
    programs: list[ProgramInfo]


class Proposal(TypedDict):
    extractor: str
    params: dict[str, int | float | bool]
    expected_ms: NotRequired[float | None]
    opencv: NotRequired[OpenCV | None]


class Pruned(TypedDict):
    extractor: str
    because: list[Citation]


class Ready(TypedDict):
    status: str
    graph_version: int
    store: str
    writes: NotRequired[str]
    torch_loaded: bool
    detail: NotRequired[str | None]
    rule_table: NotRequired[RuleTable | None]
    backends: NotRequired[dict[str, BackendStatus] | None]
    shacl_process: NotRequired[ShaclProcessStatus | None]


class Report(TypedDict):
    id: str
    iri: str
    extractor: str | None
    configuration: str | None
    conditions: dict[str, str]
    reporter: str
    ate_m: float | None
    status: str
    because: NotRequired[str | None]


class ReportList(TypedDict):
    min_sources: int
    reports: list[Report]


class Rule(TypedDict):
    id: str
    iri: str
    label: str
    comment: str | None
    enabled: bool
    source: str | None
    query: str


class RuleList(TypedDict):
    graph_version: int
    rules: list[Rule]


class RuleTable(TypedDict):
    version: int
    rules: int
    contexts: int
    compile_ms: float
    kept: NotRequired[bool]


class Scoring(TypedDict):
    """How α* was reached on this request and the extraction work it took (nfex_core/advisor/bounds.py)."""

    outcome: str
    reason: str
    extractions: int
    pixels: int


class Selection(TypedDict):
    """α*, Θ′ and why."""

    extractor: str
    params: dict[str, int | float | bool]
    opencv: OpenCV
    mode: str
    candidates: list[Candidate]
    pruned: list[Pruned]
    context: list[ContextEntry]
    weights: dict[str, Weight]
    budget: Budget | None
    verification: Verification
    warnings: list[str]
    versions: Versions
    timings_ms: Timings
    reused: NotRequired[int]
    scoring: NotRequired[Scoring | None]
    keypoints: NotRequired[Keypoints | None]


class Session(TypedDict):
    id: str
    context: dict[str, str | None]
    client: str | None
    frames: int
    has_previous: bool
    state_bytes: int
    expires_in_s: float


class SessionSelection(TypedDict):
    """A stream's frame: the Selection and where the stream stands."""

    extractor: str
    params: dict[str, int | float | bool]
    opencv: OpenCV
    mode: str
    candidates: list[Candidate]
    pruned: list[Pruned]
    context: list[ContextEntry]
    weights: dict[str, Weight]
    budget: Budget | None
    verification: Verification
    warnings: list[str]
    versions: Versions
    timings_ms: Timings
    reused: NotRequired[int]
    scoring: NotRequired[Scoring | None]
    keypoints: NotRequired[Keypoints | None]
    session: StreamPosition


class ShaclProcessStatus(TypedDict):
    running: bool
    starts: int
    fallbacks: int


class SparqlBindings(TypedDict):
    bindings: list[dict[str, dict[str, Any]]]


class SparqlHead(TypedDict):
    vars: NotRequired[list[str] | None]
    link: NotRequired[list[str] | None]


class SparqlResults(TypedDict):
    """SPARQL 1.1 Query Results JSON: a SELECT's ``results`` or an ASK's ``boolean``."""

    head: SparqlHead
    results: NotRequired[SparqlBindings | None]
    boolean: NotRequired[bool | None]


class StreamPosition(TypedDict):
    id: str
    frame: int
    temporal: bool
    reused: NotRequired[bool]


class Timings(TypedDict):
    """Milliseconds per stage of the flow, in order, and their total."""

    conditions: float
    symbolic: float
    params: float
    budget: float
    scoring: float
    verification: float
    answer: float
    total: float


class Verdict(TypedDict):
    """The decision on a frame pair after the candidates tried so far."""

    action: str
    reason: str
    accepted: NotRequired[int | None]
    because: NotRequired[Citation | None]
    next: NotRequired[Proposal | None]
    signals: list[dict[str, float | None]]
    tries: int


class Verification(TypedDict):
    """How the frame pair is verified (docs/service.md, "Verified selection"): try ``proposals`` in order, report"""

    max_tries: int
    accept: list[AcceptRule]
    escalation: Citation | None
    proposals: list[Proposal]


class VersionChanges(TypedDict):
    """A version and the change set it committed (``added``/``removed`` are its triples here)."""

    added: list[str]
    removed: list[str]
    added_count: int
    removed_count: int
    truncated: bool
    version: int
    author: str
    time: str | None
    message: str


class VersionInfo(TypedDict):
    version: int
    author: str
    time: str | None
    message: str
    added: int
    removed: int


class VersionList(TypedDict):
    versions: list[VersionInfo]


class Versions(TypedDict):
    graph: int
    graph_head: int
    stale_ms: float
    programs: dict[str, int]
    rules: int
    model: ModelInfo


class Vocabulary(TypedDict):
    graph_version: int
    context: dict[str, DimensionValues]
    extractors: dict[str, ExtractorBrief]
    metrics: dict[str, MetricBrief]


class Weight(TypedDict):
    """h_x(E): a quality metric's weight under the context."""

    value: float
    because: list[Citation]


class WriteResult(TypedDict):
    version: int
    changed: bool
    added: NotRequired[int]
    removed: NotRequired[int]
    iri: NotRequired[str | None]


__all__ = ['AcceptRule', 'Adjustment', 'BackendStatus', 'Budget', 'Candidate', 'Citation', 'ConditionValue', 'Conditions', 'ContextEntry', 'Diff', 'Dimension', 'DimensionValues', 'Evidence', 'Extractor', 'ExtractorBrief', 'ExtractorList', 'Grid', 'Head', 'Health', 'Keypoints', 'MeasuredConfiguration', 'MetricBrief', 'ModelInfo', 'OpenCV', 'Parameter', 'ParameterBrief', 'Problem', 'Program', 'ProgramInfo', 'ProgramList', 'Proposal', 'Pruned', 'Ready', 'Report', 'ReportList', 'Rule', 'RuleList', 'RuleTable', 'Scoring', 'Selection', 'Session', 'SessionSelection', 'ShaclProcessStatus', 'SparqlBindings', 'SparqlHead', 'SparqlResults', 'StreamPosition', 'Timings', 'Verdict', 'Verification', 'VersionChanges', 'VersionInfo', 'VersionList', 'Versions', 'Vocabulary', 'Weight', 'WriteResult']
