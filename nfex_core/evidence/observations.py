"""Every Measurement as the readers of evidence see it, read with one query per graph version.

An ``Observation`` is one ``nfex:Measurement`` (a window of a run, DESIGN.md "Evidence and trust"):
what it measured (extractor, configuration, conditions, ATE, failure, tracking loss, extraction time,
frame size), where (its sequence) and who stands behind it (its run, the reporter it is attributed to,
the editor who accepted it). The rule engine, the cost model and the dynamic baselines all start from
``read_observations`` and select from it with ``trust.admitted`` (and the evidence scope).
"""
from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..kg.backends import EmbeddedBackend
from ..kg.history import prefix_block

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph

# One query, so that it reads one state of the store, in branches that each scan one predicate (joined here):
# Oxigraph evaluates an OPTIONAL group on its own and joins afterwards, so the form with an OPTIONAL per attribute
# took 21.6 s at 3M statements in a probe, these branches 8.6 s (tests/nfex_core/evidence/test_observations.py holds the
# plain form as the oracle). ?k names the branch; ?m is the Measurement, except
# in the branches about configurations (``cfg``: ?m a configuration, ?a its extractor's token) and condition
# values (``value``: ?m a value, ?a its dimension's token, ?b its own). Where a Measurement has two values of an
# attribute, the first seen is kept.
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


def observation_query(only: Collection[str] | None = None) -> str:
    """The query ``read_observations`` sends; ``only``: the Measurements it is restricted to (a VALUES block in
    each of their branches, so each is a lookup, not a scan; the configurations and condition values are then
    those of these Measurements)."""
    iris = None if only is None else " ".join(f"<{i}>" for i in sorted(only))
    values = "" if iris is None else f"VALUES ?m {{ {iris} }} "
    branches = [f'{{ {values}{pattern} BIND ("{k}" AS ?k) }}' for k, pattern in _BRANCHES.items()]
    branches += [f'{{ {"" if iris is None else f"VALUES ?of {{ {iris} }} ?of {link} ?m . "}{pattern} BIND ("{k}" AS ?k) }}'
                 for k, (link, pattern) in _SHARED.items()]
    return "SELECT ?m ?k ?a ?b WHERE {\n" + "\n  UNION ".join(branches) + "\n}"


OBSERVATIONS = observation_query()


@dataclass(frozen=True)
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

    @property
    def source(self) -> str:
        """Who stands behind it: the reporter of a report, else the run that measured it."""
        return self.reporter or self.run or "unattributed"

    def counts_under(self, known: dict[str, str]) -> bool:
        """It speaks to a context with the ``known`` values when it shares one and contradicts none (a window
        measured under light = dark says nothing about a bright frame)."""
        return any(known.get(d) == v for d, v in self.conditions) and all(known.get(d, v) == v for d, v in self.conditions)


def read_observations(kg: KnowledgeGraph, only: Collection[str] | None = None) -> list[Observation]:
    """Every Measurement of the graph (one query: a row per attribute, folded here); ``only``: just these IRIs
    (those that are Measurements), for evidence/index.py's incremental reading."""
    if only is not None and not only:
        return []
    query = observation_query(only)
    rows: list[tuple[str, str, str | None, str | None]] = []
    if isinstance(kg.backend, EmbeddedBackend):  # Oxigraph's terms, lexical forms read directly: no rdflib terms
        for sol in kg.backend.solutions(prefix_block() + query):
            a, b = sol["a"], sol["b"]
            rows.append((sol["m"].value, sol["k"].value, a.value if a is not None else None, b.value if b is not None else None))
    else:
        for r in kg.select(query).rows:
            rows.append((str(r["m"]), str(r["k"]), str(r["a"]) if "a" in r else None, str(r["b"]) if "b" in r else None))
    measurements: dict[str, None] = {}  # in the order read
    extractor: dict[str, str] = {}  # configuration → its extractor's token
    tokens: dict[str, set[tuple[str, str]]] = {}  # condition value → (dimension, value) tokens
    procedures: dict[str, list[str]] = {}
    values: dict[str, dict[str, tuple[str | None, str | None]]] = {}
    within: dict[str, list[str]] = {}  # Measurement → condition values
    for m, k, a, b in rows:
        if k == "type":
            measurements[m] = None
        elif k == "proc":
            procedures.setdefault(m, []).append(a or "")
        elif k == "cond":
            within.setdefault(m, []).append(a or "")
        elif k == "cfg":
            extractor.setdefault(m, a or "")
        elif k == "value":
            tokens.setdefault(m, set()).add((a or "", b or ""))
        else:
            values.setdefault(m, {}).setdefault(k, (a, b))
    base: dict[str, tuple[str, str]] = {}
    for m in measurements:
        cfg = next((c for c in procedures.get(m, ()) if c in extractor), None)
        if cfg is not None:
            base[m] = (cfg, extractor[cfg])
    conditions = {m: {t for c in cs for t in tokens.get(c, ())} for m, cs in within.items()}
    out = []
    for m, (cfg, xname) in base.items():
        v = values.get(m, {})

        def lex(key: str, v: dict[str, tuple[str | None, str | None]] = v) -> str | None:
            return v[key][0] if key in v else None

        size = v.get("size")
        seq = v.get("seq")
        out.append(Observation(
            iri=m, extractor=xname, configuration=cfg, conditions=frozenset(conditions.get(m, ())),
            ate=_float(lex("ate")), extraction_ms=_float(lex("ms")),
            width=_int(size[0]) if size else None, height=_int(size[1]) if size else None,
            failed=_bool(lex("failed")), lost=_int(lex("lost")), frames=_int(lex("frames")),
            sequence=seq[0] if seq else None, sequence_label=seq[1] if seq else None,
            run=lex("run"), reporter=lex("reporter"), accepted_by=lex("accepted"),
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
