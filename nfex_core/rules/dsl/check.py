"""Check a parsed program against the graph's vocabulary: every name must be one the graph knows.

Extractors, parameters, metrics, condition dimensions and values come from ``Vocabulary`` (read from
the graph), so adding a value to the ontology makes it usable in programs without code. Each problem
is an UnknownName (with the names the graph knows), a ParameterError or a ParseError, and carries the
line and column of the offending name.
"""
from __future__ import annotations

from ...errors import NfexError, ParameterError, UnknownName
from ...kg.vocabulary.vocab import Vocabulary
from ..types import MAX_ESCALATIONS, PAIR_COMPARATORS, PAIR_SIGNALS
from .parser import Pos, Program, Statement


def _where(program: Program, pos: Pos) -> str:
    src = f"{program.source}:" if program.source else ""
    return f"{src}{pos.line}:{pos.column}"


def _unknown(program: Program, pos: Pos, kind: str, name: str, known: object) -> UnknownName:
    return UnknownName(kind, name, known, where=_where(program, pos), line=pos.line, column=pos.column)  # type: ignore[arg-type]


def _bad(program: Program, pos: Pos, message: str, parameter: str | None = None) -> ParameterError:
    extra = {"parameter": parameter} if parameter else {}
    return ParameterError(f"{_where(program, pos)}: {message}", line=pos.line, column=pos.column, **extra)


def _check_statement(program: Program, s: Statement, vocab: Vocabulary) -> list[NfexError]:
    out: list[NfexError] = []
    at = s.at
    if s.extractor is not None and s.extractor not in vocab.extractors:
        out.append(_unknown(program, at.get("extractor", s.pos), "extractor", s.extractor, vocab.extractors))
    elif s.parameter is not None and s.extractor is not None:
        spec = vocab.extractors[s.extractor]
        qualified = f"{s.extractor}.{s.parameter}"
        if s.parameter not in spec.parameters:
            known = [f"{s.extractor}.{p}" for p in spec.parameters]
            out.append(_unknown(program, at.get("parameter", s.pos), "parameter", qualified, known))
        else:
            p = spec.parameters[s.parameter]
            vpos = at.get("value", s.pos)
            if s.kind == "adjust":
                if not p.tunable or p.datatype == "boolean":
                    tunable = sorted(f"{s.extractor}.{n}" for n, q in spec.parameters.items() if q.tunable and q.datatype != "boolean")
                    out.append(_bad(program, at.get("parameter", s.pos), f"{qualified} is not a tunable number; tunable: {', '.join(tunable)}", qualified))
            elif s.kind == "require":
                if p.datatype == "boolean" and s.comparator != "=":
                    out.append(_bad(program, at.get("comparator", s.pos), f"{qualified} is a boolean: require it with '=', not {s.comparator!r}", qualified))
                try:
                    p.validate(s.value)
                except ParameterError as e:
                    out.append(_bad(program, vpos, e.detail, qualified))
    if s.kind == "adjust" and isinstance(s.value, int | float) and not s.value > 0:
        out.append(_bad(program, at.get("value", s.pos), f"a factor must be greater than 0, not {s.value}"))
    if s.kind == "weight":
        assert s.metric is not None
        if s.metric not in vocab.metrics:
            out.append(_unknown(program, at.get("metric", s.pos), "metric", s.metric, vocab.metrics))
        if isinstance(s.value, int | float) and s.value < 0:
            out.append(_bad(program, at.get("value", s.pos), f"a metric weight must be 0 or more, not {s.value}"))
    for t in s.tests:
        if t.signal not in PAIR_SIGNALS:
            out.append(_unknown(program, t.at.get("signal", s.pos), "pair signal", t.signal, sorted(PAIR_SIGNALS)))
        if t.comparator not in PAIR_COMPARATORS:
            out.append(_bad(program, t.at.get("comparator", s.pos), f"a pair test compares with one of {', '.join(PAIR_COMPARATORS)}, not {t.comparator!r}"))
    if s.kind == "escalate" and not (isinstance(s.value, int) and 0 <= s.value <= MAX_ESCALATIONS):
        out.append(_bad(program, at.get("value", s.pos), f"escalate at most takes a whole number from 0 to {MAX_ESCALATIONS}, not {s.value}"))
    for atom in s.when:
        if atom.dimension not in vocab.dimensions:
            out.append(_unknown(program, atom.at.get("dimension", s.pos), "condition dimension", atom.dimension, vocab.dimensions))
            continue
        values = vocab.dimensions[atom.dimension].values
        for v in atom.values:
            if v not in values:
                out.append(_unknown(program, atom.at.get(f"value:{v}", s.pos), f"value of {atom.dimension}", v, values))
    return out


def problems(program: Program, vocab: Vocabulary) -> list[NfexError]:
    """Every problem of ``program`` under ``vocab``, in source order."""
    out: list[NfexError] = []
    for s in program.statements:
        out.extend(_check_statement(program, s, vocab))
    out.sort(key=lambda e: (e.extra.get("line", 0), e.extra.get("column", 0)))
    return out


def check(program: Program, vocab: Vocabulary) -> Program:
    """``program`` if every name is known and every number allowed; else raise the first problem.

    The error's ``extra["problems"]`` lists every problem's one-line detail.
    """
    found = problems(program, vocab)
    if found:
        first = found[0]
        first.extra["problems"] = [e.detail for e in found]
        if len(found) > 1:
            first.detail += f" (and {len(found) - 1} more problem{'s' if len(found) > 2 else ''})"
            first.args = (first.detail,)
        raise first
    return program
