"""``/v1/rule-effects``: what every SPARQL rule, program statement and context shape does across all
contexts of the compiled rule table (``nfex_core.rules.effects``): the workbench's browse view reads it.

Its own path, not ``/v1/rules/effects``, which ``/v1/rules/{rule_id}`` (PUT, DELETE) would also match.
"""
from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from nfex_core.rules.effects import effects
from nfex_core.rules.engine import RuleEngine

from ..deps import KGDep
from ..schemas import PROBLEM_RESPONSES

router = APIRouter(prefix="/v1", tags=["editing: rules"], responses=PROBLEM_RESPONSES)


@router.get("/rule-effects", summary="What every rule, statement and context shape does across all contexts (from the compiled table)")
def rule_effects(kg: KGDep) -> dict[str, Any]:
    table = RuleEngine(kg).table()  # the advisor's cached table for this graph version
    return {"graph_version": table.version, "contexts": len(table.decisions),
            "rules": [r.as_dict() for r in sorted(effects(table).values(), key=lambda r: r.iri)]}
