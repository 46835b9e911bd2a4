"""Response bodies of the service's other JSON routes (the Selection has its own module)."""
from __future__ import annotations

from typing import Any

from fastapi.responses import JSONResponse
from pydantic import Field

from nfex_core.kg import CommitResult

from .selection import Out, Value


class WriteResult(Out):
    version: int = Field(..., description="The graph version at head after the write (the new ETag).")
    changed: bool
    added: int = 0
    removed: int = 0
    iri: str | None = None

    @classmethod
    def of(cls, result: CommitResult, iri: str | None = None) -> WriteResult:
        return cls(version=result.version, changed=result.changed, added=result.added, removed=result.removed, iri=iri)

    def response(self, status: int = 200) -> JSONResponse:
        return JSONResponse(self.model_dump(), status_code=status, headers={"ETag": f'"{self.version}"'})


# -- client reports (/v1/feedback)
class Report(Out):
    id: str = Field(..., description="measurement_<32 hex digits>: what POST /v1/feedback/{id}/accept takes.")
    iri: str
    extractor: str | None
    configuration: str | None
    conditions: dict[str, str]
    reporter: str
    ate_m: float | None
    status: str = Field(..., description="admitted (steers selections) | quarantined (kept, not counted yet)")
    because: str | None = Field(None, description="Why it is admitted or quarantined.")


class ReportList(Out):
    min_sources: int = Field(..., description="Distinct reporters needed to admit a configuration's reports (nfex:minSources).")
    reports: list[Report]


# -- operations
class Health(Out):
    status: str


class RuleTable(Out):
    version: int
    rules: int
    contexts: int
    compile_ms: float = Field(..., description="How long its compile took (in the process that compiled it, when kept).")
    kept: bool = Field(False, description="Read from the table kept on disk at the previous shutdown (NFEX_COMPILED_CACHE), not compiled here.")


class BackendStatus(Out):
    extractors: list[str]
    available: bool
    detail: str = Field(..., description="What runs it, or what to install or set to make it run.")
    setting: str | None = Field(None, description="The setting that would change it (e.g. NFEX_XFEAT_WEIGHTS).")


class ShaclProcessStatus(Out):
    running: bool = Field(..., description="A worker process is up.")
    starts: int = Field(..., description="Workers started so far (one more after each that died).")
    fallbacks: int = Field(..., description="Validations that ran in the service's process because the worker died during them.")


class Ready(Out):
    status: str = Field(..., description="ready | starting | failed")
    graph_version: int = Field(..., description="The head the store reports, or (store unreachable) the snapshot's")
    store: str
    writes: str = Field("available", description="available | unavailable: the store cannot be reached, selects answer "
                        "from the last snapshot (GET /readyz/writes answers 503 meanwhile)")
    torch_loaded: bool
    detail: str | None = None
    rule_table: RuleTable | None = None
    backends: dict[str, BackendStatus] | None = Field(
        None, description="Per extractor backend the graph uses: whether it can run here and, if not, why.")
    shacl_process: ShaclProcessStatus | None = Field(
        None, description="Where writes run pySHACL: a worker process (NFEX_SHACL_PROCESS), absent when in this one.")


# -- vocabulary
class DimensionValues(Out):
    values: list[str]
    estimable: bool


class ParameterBrief(Out):
    role: str
    datatype: str
    default: Value
    range: str


class ExtractorBrief(Out):
    constructor: str
    norm: str
    parameters: dict[str, ParameterBrief]


class MetricBrief(Out):
    symbol: str
    temporal: bool


class Vocabulary(Out):
    graph_version: int
    context: dict[str, DimensionValues]
    extractors: dict[str, ExtractorBrief]
    metrics: dict[str, MetricBrief]


# -- extractors and conditions
class Parameter(Out):
    iri: str
    role: str
    datatype: str
    default: Value
    min: Value | None
    max: Value | None
    allowed: list[Value] | None
    tunable: bool
    label: str


class Extractor(Out):
    name: str
    iri: str
    label: str
    constructor: str
    norm: str
    descriptor_kind: str
    operations: list[str]
    parameters: dict[str, Parameter]


class ExtractorList(Out):
    graph_version: int
    extractors: list[Extractor]


class ConditionValue(Out):
    iri: str
    label: str


class Dimension(Out):
    iri: str
    estimable: bool
    values: dict[str, ConditionValue]


class Conditions(Out):
    graph_version: int
    dimensions: dict[str, Dimension]


# -- rules and programs
class Rule(Out):
    id: str
    iri: str
    label: str
    comment: str | None
    enabled: bool
    source: str | None
    query: str


class RuleList(Out):
    graph_version: int
    rules: list[Rule]


class ProgramInfo(Out):
    name: str
    iri: str
    statements: int
    source: str | None


class Program(ProgramInfo):
    text: str = Field(..., description="The program read back from the graph, as DSL text.")


class ProgramList(Out):
    graph_version: int
    programs: list[ProgramInfo]


# -- versions
class Head(Out):
    version: int
    store: str
    triples: int


class VersionInfo(Out):
    version: int
    author: str
    time: str | None
    message: str
    added: int
    removed: int


class VersionList(Out):
    versions: list[VersionInfo]


class ChangeSet(Out):
    added: list[str] = Field(..., description="Triples in N-Triples syntax (at most 5000).")
    removed: list[str]
    added_count: int
    removed_count: int
    truncated: bool


class VersionChanges(ChangeSet):
    """A version and the change set it committed (``added``/``removed`` are its triples here)."""

    version: int
    author: str
    time: str | None
    message: str


class Diff(ChangeSet):
    since: int
    until: int


# -- sessions
class Session(Out):
    id: str
    context: dict[str, str | None]
    client: str | None
    frames: int
    has_previous: bool
    state_bytes: int
    expires_in_s: float


# -- SPARQL (application/sparql-results+json, https://www.w3.org/TR/sparql11-results-json/)
class SparqlHead(Out):
    vars: list[str] | None = None
    link: list[str] | None = None


class SparqlBindings(Out):
    bindings: list[dict[str, dict[str, Any]]] = Field(
        ..., description="Variable → RDF term {type: uri | literal | bnode, value, xml:lang?, datatype?}."
    )


class SparqlResults(Out):
    """SPARQL 1.1 Query Results JSON: a SELECT's ``results`` or an ASK's ``boolean``."""

    head: SparqlHead
    results: SparqlBindings | None = None
    boolean: bool | None = None
