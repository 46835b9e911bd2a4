"""Every Measurement as the readers of evidence see it, read with one query per graph version.

An ``Observation`` is one ``nfex:Measurement`` (a window of a run, DESIGN.md "Evidence and trust"):
what it measured (extractor, configuration, conditions, ATE, failure, tracking loss, extraction time,
frame size), where (its sequence) and who stands behind it (its run, the reporter it is attributed to,
the editor who accepted it). The rule engine, the cost model and the dynamic baselines all start from
``read_observations`` and select from it with ``trust.admitted`` (and the evidence scope).
"""
from __future__ import annotations

import concurrent.futures
import operator
import os
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..kg.storage.history import prefix_block

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

# The attributes of a Measurement, in branches that each scan one predicate (joined here): Oxigraph evaluates an
# OPTIONAL group on its own and joins afterwards, so one query with an OPTIONAL per attribute took 21.6 s at 3M
# statements in a probe (tests/nfex_core/evidence/test_observations.py holds that plain form as the oracle). ?m is
# the Measurement, except in the branches about configurations (``cfg``: ?m a configuration, ?a its extractor's
# token) and condition values (``value``: ?m a value, ?a its dimension's token, ?b its own). Where a Measurement has
# two values of an attribute, the first seen is kept.
_BRANCHES = {
    "type": "?m a nfex:Measurement .", "proc": "?m sosa:usedProcedure ?a . FILTER (!isLiteral(?a))",
    "cond": "?m nfex:underCondition ?a . FILTER (!isLiteral(?a))",
    "ate": "?m nfex:ateRmse ?a .", "ms": "?m nfex:extractionMs ?a .",
    "size": "?m nfex:frameWidth ?a ; nfex:frameHeight ?b .",
    "failed": "?m nfex:trackingFailed ?a .", "lost": "?m nfex:trackingLost ?a .", "frames": "?m nfex:frameCount ?a .",
    "seq": "?m nfex:sequence ?a OPTIONAL { ?a rdfs:label ?b }",
    "run": "?m prov:wasGeneratedBy ?a .", "reporter": "?m prov:wasAttributedTo ?a .", "accepted": "?m nfex:acceptedBy ?a .",
}
_SHARED = {"cfg": ("sosa:usedProcedure", "?m nfex:ofExtractor/nfex:token ?a ."),
           "value": ("nfex:underCondition", "?m nfex:token ?b ; nfex:inDimension/nfex:token ?a .")}
KEYS = (*_BRANCHES, *_SHARED)


def _pattern(key: str, iris: str | None) -> str:
    """Branch ``key``'s graph pattern; ``iris``: the Measurements it is restricted to, written out (a VALUES block,
    so that it is a lookup, not a scan; for ``cfg`` and ``value``, the configurations and condition values of
    these Measurements)."""
    if key in _SHARED:
        link, pattern = _SHARED[key]
        return pattern if iris is None else f"VALUES ?of {{ {iris} }} ?of {link} ?m . {pattern}"
    return _BRANCHES[key] if iris is None else f"VALUES ?m {{ {iris} }} {_BRANCHES[key]}"


def _written(only: Collection[str] | None) -> str | None:
    return None if only is None else " ".join(f"<{i}>" for i in sorted(only))


def branch_query(key: str, only: Collection[str] | None = None) -> str:
    """Branch ``key`` as a query of ``?m ?a ?b`` (what a full read sends, one per branch)."""
    return f"SELECT ?m ?a ?b WHERE {{ {_pattern(key, _written(only))} }}"


def observation_query(only: Collection[str] | None = None) -> str:
    """Every branch in one query, ``?k`` naming the branch: what a restricted read sends, and the footprint of
    the rows (evidence/index.py)."""
    iris = _written(only)
    branches = [f'{{ {_pattern(k, iris)} BIND ("{k}" AS ?k) }}' for k in KEYS]
    return "SELECT ?m ?k ?a ?b WHERE {\n" + "\n  UNION ".join(branches) + "\n}"


OBSERVATIONS = observation_query()


@dataclass(frozen=True, slots=True)
class Observation:
    """One Measurement: what it measured, under which conditions, and who stands behind it."""

    iri: str
    extractor: str
    configuration: str
    conditions: frozenset[tuple[str, str]]  # (dimension, value) of every condition it was measured under
    ate: float | None = None  # None: no ATE (the window failed, or it was not reported)
    extraction_ms: float | None = None
    width: int | None = None
    height: int | None = None
    failed: bool = False
    lost: int | None = None
    frames: int | None = None
    sequence: str | None = None
    sequence_label: str | None = None
    run: str | None = None
    reporter: str | None = None  # prov:wasAttributedTo: a client's report (trust.py)
    accepted_by: str | None = None  # nfex:acceptedBy: the editor who admitted the report

    def __reduce__(self) -> tuple[type[Observation], tuple[object, ...]]:
        """Pickled as its fields in order: the kept rule table (rules/persisted.py) holds every Observation, and a
        dataclass's own state is about four times slower to write (0.6 s for 60k in a probe)."""
        return Observation, _FIELDS(self)

    @property
    def source(self) -> str:
        """Who stands behind it: the reporter of a report, else the run that measured it."""
        return self.reporter or self.run or "unattributed"

    def counts_under(self, known: dict[str, str]) -> bool:
        """It speaks to a context with the ``known`` values when it shares one and contradicts none (a window
        measured under light = dark says nothing about a bright frame)."""
        return any(known.get(d) == v for d, v in self.conditions) and all(known.get(d, v) == v for d, v in self.conditions)


_FIELDS = operator.attrgetter(*Observation.__slots__)


def read_observations(kg: KnowledgeGraph, only: Collection[str] | None = None) -> list[Observation]:
    """Every Measurement of the graph (a row per attribute, folded here); ``only``: just these IRIs (those that are
    Measurements), for evidence/index.py's incremental reading.

    A restricted read is one query. A full read sends each branch as a query of its own, side by side on threads:
    the store evaluates and serialises a query without the interpreter lock (``Backend.values``), so on two cores
    a full read takes about half as long (4.0 → 1.8 s for the queries at 3M statements in a probe). A commit that
    lands between two of them may show in some rows of a Measurement and not in others, as a commit landing
    during one query may show in the index at an earlier version: its nodes are in the next advance's change,
    and read again then."""
    if only is not None and not only:
        return []
    if only is not None:
        parts: dict[str, list[list[str]]] = {k: [] for k in KEYS}  # branch → its rows (?m ?a ?b)
        for m, k, a, b in kg.backend.values(prefix_block() + observation_query(only)):
            parts[k].append([m, a, b])
        return _fold({k: _column(k, rows) for k, rows in parts.items()})
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1),
                                               thread_name_prefix="nfex-observations") as pool:
        # each branch is made the fold's column on the thread that read it, beside the queries still running
        return _fold(dict(zip(KEYS, pool.map(lambda k: _column(k, kg.backend.values(prefix_block() + branch_query(k))), KEYS),
                              strict=True)))


Column = dict[str, Any] | list[str]


def _column(key: str, rows: list[list[str]]) -> Column:
    """Branch ``key``'s rows as the fold reads them: ``type``, the Measurements in the order read, once each;
    ``proc`` and ``cond``, a node's values in order; ``value``, a condition value's (dimension, value) tokens;
    any other, a node's first value (its first row; reversed, the first row of a node is written last), converted
    to the field's type. A value is as the CSV results format writes it (``Backend.values``), so an empty sequence
    label reads as none, like an absent one."""
    if key == "type":
        return list(dict.fromkeys(r[0] for r in rows))
    if key in ("proc", "cond"):
        many: dict[str, list[str]] = {}
        for m, a, _ in rows:
            many.setdefault(m, []).append(a)
        return many
    if key == "value":
        tokens: dict[str, set[tuple[str, str]]] = {}
        for value, dimension, token in rows:
            tokens.setdefault(value, set()).add((dimension, token))
        return tokens
    if key == "size":
        return {m: (_int(a), _int(b)) for m, a, b in reversed(rows)}
    if key == "seq":
        return {m: (a, b or None) for m, a, b in reversed(rows)}
    convert = _CONVERT.get(key)
    if convert is None:
        return {m: a for m, a, _ in reversed(rows)}
    return {m: convert(a) for m, a, _ in reversed(rows)}


def _fold(columns: dict[str, Any]) -> list[Observation]:
    """The Observations of the branches' columns (``_column``): a Measurement of a configuration of an extractor,
    with its attributes where present."""
    extractor: dict[str, str] = columns["cfg"]  # configuration → its extractor's token
    tokens: dict[str, set[tuple[str, str]]] = columns["value"]
    procedures: dict[str, list[str]] = columns["proc"]
    within: dict[str, list[str]] = columns["cond"]  # Measurement → condition values
    ate, ms, size, failed, lost, frames, seq, run, reporter, accepted = (columns[k] for k in (
        "ate", "ms", "size", "failed", "lost", "frames", "seq", "run", "reporter", "accepted"))
    out = []
    for m in columns["type"]:
        cfg = next((c for c in procedures.get(m, ()) if c in extractor), None)
        if cfg is None:
            continue
        wh, sq = size.get(m), seq.get(m)
        out.append(Observation(
            iri=m, extractor=extractor[cfg], configuration=cfg,
            conditions=frozenset(t for c in within.get(m, ()) for t in tokens.get(c, ())),
            ate=ate.get(m), extraction_ms=ms.get(m), width=wh[0] if wh else None, height=wh[1] if wh else None,
            failed=failed.get(m, False), lost=lost.get(m), frames=frames.get(m),
            sequence=sq[0] if sq else None, sequence_label=sq[1] if sq else None,
            run=run.get(m), reporter=reporter.get(m), accepted_by=accepted.get(m),
        ))
    return out


def _float(lex: str | None) -> float | None:
    return float(lex) if lex is not None else None


def _int(lex: str | None) -> int | None:
    if lex is None:
        return None
    try:
        return int(lex)
    except ValueError:  # a decimal or double lexical form
        return int(float(lex))


def _bool(lex: str | None) -> bool:
    """``nfex:trackingFailed``: absent, ``false``/``0`` (any case, as xsd:boolean reads them) or a zero number is
    False; ``true``/``1``, another number or any other text is True."""
    if lex is None:
        return False
    word = lex.strip().lower()
    if word in ("true", "1", "false", "0"):
        return word in ("true", "1")
    try:
        return float(word) != 0
    except ValueError:
        return bool(word)


_CONVERT: dict[str, Callable[[str], object]] = {"ate": _float, "ms": _float, "failed": _bool, "lost": _int, "frames": _int}


def restricted(query: str, variable: str, iris: Collection[str]) -> str:
    """``query`` (a SELECT with one top-level ``WHERE {``) with ``?variable`` bound to ``iris``: a VALUES block
    opens the WHERE and every ``OPTIONAL {`` group.

    The repetition changes no answer (the outer block already binds ``?variable`` to these IRIs, so an
    optional row with another value could never join), but it changes the plan: Oxigraph evaluates an
    OPTIONAL's group on its own and then joins, so without it reading one Measurement scans every
    Measurement's ATE, conditions, … (about 250 ms on 300k statements, 2 ms with it)."""
    values = f"VALUES ?{variable} {{ {' '.join(f'<{i}>' for i in sorted(iris))} }} "
    head, sep, rest = query.partition("WHERE {")
    if not sep:
        raise ValueError("the query has no WHERE {")
    return f"{head}WHERE {{ {values}{rest.replace('OPTIONAL {', 'OPTIONAL { ' + values)}"
