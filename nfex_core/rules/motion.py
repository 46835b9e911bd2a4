"""The front-end checks' limits as data: per agent, from the graph (the checks themselves: nfex_slam.motion)."""
from __future__ import annotations

from nfex_slam.motion import StepChecks

from ..kg.backends import GraphReader
from ..kg.terms import py


def load_step_checks(kg: GraphReader) -> dict[str, StepChecks]:
    """Agent token → its StepChecks, from ``nfex:maxRotationRate`` / ``nfex:maxHeadingChangeRate``."""
    out: dict[str, StepChecks] = {}
    for r in kg.select(
        """SELECT ?tok ?rot ?head WHERE { ?v a nfex:ConditionValue ; nfex:inDimension nfex:agent ; nfex:token ?tok .
               OPTIONAL { ?v nfex:maxRotationRate ?rot } OPTIONAL { ?v nfex:maxHeadingChangeRate ?head }
               FILTER (BOUND(?rot) || BOUND(?head)) }"""
    ).rows:
        rot = float(py(r["rot"])) if "rot" in r else None
        head = float(py(r["head"])) if "head" in r else None
        out[str(r["tok"])] = StepChecks(rot, head, str(r["tok"]))
    return out
