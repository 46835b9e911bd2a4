"""The Python client's types come from the service's OpenAPI document: the committed
``nfex_client/schema.py`` is what ``python -m nfex_client.generate`` writes for the running service, so a
change to the service's schemas that is not regenerated fails here (drift fails CI)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import httpx
from nfex_client import NfexClient, schema
from nfex_client.generate import render, response_schemas

from tests.service.conftest import Service

SCHEMA_PY = Path(__file__).resolve().parents[2] / "clients" / "python" / "nfex_client" / "schema.py"


def test_the_committed_types_are_generated_from_the_services_document(service: Service) -> None:
    doc = httpx.get(service.url + "/openapi.json").json()
    assert render(doc) == SCHEMA_PY.read_text(), (
        "clients/python/nfex_client/schema.py is stale: regenerate it with "
        "`python -m nfex_client.generate http://127.0.0.1:8000/openapi.json -o clients/python/nfex_client/schema.py`"
    )
    assert {"Selection", "SessionSelection", "WriteResult", "Problem", "Budget"} <= set(response_schemas(doc))


def _keys(typed: Any) -> tuple[set[str], set[str]]:
    """(required, all) keys of a generated TypedDict, read from its annotations (strings, which TypedDict
    wraps in ForwardRef: its own ``__required_keys__`` cannot see a ``NotRequired`` inside one)."""
    notes: dict[str, str] = {k: getattr(v, "__forward_arg__", str(v)) for k, v in typed.__annotations__.items()}
    return {k for k, v in notes.items() if not v.startswith("NotRequired[")}, set(notes)


def test_a_real_selection_has_the_types_keys(service: Service) -> None:
    with NfexClient(service.url) as nfex:
        sel = nfex.select({"agent": "drone", "light": "dark"})
    required, every = _keys(schema.Selection)
    assert required <= set(sel) <= every and {"budget", "warnings"} <= every
    for c in sel["candidates"]:
        required, every = _keys(schema.Candidate)
        assert required <= set(c) <= every
