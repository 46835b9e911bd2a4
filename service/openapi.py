"""The OpenAPI document and its offline Swagger UI.

FastAPI writes the document from the routes; ``build`` completes it where FastAPI cannot know:

- the schemas that routes reading or writing their own bodies refer to (``SelectRequest`` for
  ``POST /v1/select``'s JSON, read by hand because the same route takes multipart; ``SparqlResults``)
  and ``Problem`` (RFC 9457);
- errors: FastAPI's default 422 (``HTTPValidationError`` as ``application/json``) becomes the problem+json
  our handler really answers (service/problems.py), every operation documents its 500, and every
  operation that needs a token (``security``, from the ``bearer`` scheme in service/deps.py) its 401/403.

``/docs`` is Swagger UI served from the ``swagger_ui_bundle`` package (swagger-ui-bundle-v2 on PyPI:
Swagger UI 5, which reads OpenAPI 3.1), so it works without a network; every URL in the page is
relative, so it also works behind a gateway's path prefix.
"""
from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.openapi.utils import get_openapi
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel
from pydantic.json_schema import models_json_schema

from .schemas import Problem, SelectRequest, SparqlResults, problem_response

ASSETS = "/docs/assets"
EXTRA_MODELS: tuple[type[BaseModel], ...] = (Problem, SelectRequest, SparqlResults)
FASTAPI_422 = "#/components/schemas/HTTPValidationError"
METHODS = ("get", "put", "post", "delete", "patch", "head", "options")


def _add_models(schemas: dict[str, Any], models: tuple[type[BaseModel], ...]) -> None:
    _, defs = models_json_schema([(m, "validation") for m in models], ref_template="#/components/schemas/{model}")
    for name, schema in defs.get("$defs", {}).items():
        schemas.setdefault(name, schema)


def _referenced(doc: Any) -> set[str]:
    """Every ``$ref`` in ``doc``."""
    found: set[str] = set()
    stack = [doc]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            ref = node.get("$ref")
            if isinstance(ref, str):
                found.add(ref)
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
    return found


def build(app: FastAPI) -> dict[str, Any]:
    """The service's OpenAPI 3.1 document (cached on the app like FastAPI's own)."""
    if app.openapi_schema:
        return app.openapi_schema
    doc = get_openapi(title=app.title, version=app.version, summary=app.summary, description=app.description,
                      routes=app.routes, tags=app.openapi_tags)
    schemas = doc.setdefault("components", {}).setdefault("schemas", {})
    _add_models(schemas, EXTRA_MODELS)
    for item in doc.get("paths", {}).values():
        for method in METHODS:
            op = item.get(method)
            if op is None:
                continue
            responses = op.setdefault("responses", {})
            fastapi_422 = responses.get("422", {}).get("content", {}).get("application/json", {}).get("schema", {})
            if fastapi_422.get("$ref") == FASTAPI_422:
                responses["422"] = problem_response(422)
            if op.get("security"):
                responses.setdefault("401", problem_response(401))
                responses.setdefault("403", problem_response(403))
            responses.setdefault("500", problem_response(500))
    used = _referenced(doc["paths"]) | _referenced(schemas)
    for name in ("HTTPValidationError", "ValidationError"):
        if f"#/components/schemas/{name}" not in used:
            schemas.pop(name, None)
    app.openapi_schema = doc
    return doc


def install(app: FastAPI) -> None:
    """Serve the document at /openapi.json and Swagger UI at /docs, both without leaving the process."""
    from swagger_ui_bundle import swagger_ui_path

    app.openapi = lambda: build(app)  # type: ignore[method-assign]
    app.mount(ASSETS, StaticFiles(directory=str(swagger_ui_path)), name="swagger-ui")

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        # relative URLs: /docs → /openapi.json and /docs/assets/…, under any prefix a gateway adds
        return get_swagger_ui_html(
            openapi_url="openapi.json", title=f"{app.title} — API", swagger_js_url="docs/assets/swagger-ui-bundle.js",
            swagger_css_url="docs/assets/swagger-ui.css", swagger_favicon_url="docs/assets/favicon-32x32.png",
            oauth2_redirect_url=None,
        )
