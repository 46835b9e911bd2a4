"""Pydantic models at the HTTP edge: request bodies, response bodies (the Selection in ``selection``),
and RFC 9457 problems."""
from __future__ import annotations

from .problems import PROBLEM_JSON, PROBLEM_RESPONSES, Problem, problem_response, problems
from .requests import (
    CONTEXT_EXAMPLE,
    ConditionValueIn,
    FeedbackRequest,
    ParameterPatch,
    RollbackIn,
    RuleIn,
    SelectRequest,
    SessionCreate,
)
from .resources import (
    Conditions,
    Diff,
    Extractor,
    ExtractorList,
    Head,
    Health,
    Parameter,
    Program,
    ProgramList,
    Ready,
    Report,
    ReportList,
    Rule,
    RuleList,
    Session,
    SparqlResults,
    VersionChanges,
    VersionList,
    Vocabulary,
    WriteResult,
)
from .selection import Selection, SessionSelection

__all__ = [
    "CONTEXT_EXAMPLE", "PROBLEM_JSON", "PROBLEM_RESPONSES", "ConditionValueIn", "Conditions", "Diff", "Extractor",
    "ExtractorList", "FeedbackRequest", "Head", "Health", "Parameter", "ParameterPatch", "Problem", "Program",
    "ProgramList", "Ready", "Report", "ReportList", "RollbackIn", "Rule", "RuleIn", "RuleList", "SelectRequest", "Selection", "Session",
    "SessionCreate", "SessionSelection", "SparqlResults", "VersionChanges", "VersionList", "Vocabulary", "WriteResult",
    "problem_response", "problems",
]
