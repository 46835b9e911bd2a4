"""The OpenAPI contract, read from the running service as a client generator reads it: a valid OpenAPI
3.1 document without dangling references, a schema for every JSON response (and real responses that
conform to it), problem+json on errors, a bearer security scheme on the routes that need a token, and
Swagger UI that loads without a network."""
from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from typing import Any
from urllib.parse import urljoin

import httpx
import pytest
from openapi_schema_validator import OAS31Validator
from openapi_spec_validator import validate as validate_spec

from .conftest import EDITOR, Service

METHODS = ("get", "put", "post", "delete", "patch")


@pytest.fixture(scope="module")
def spec(service: Service) -> dict[str, Any]:
    r = httpx.get(service.url + "/openapi.json")
    assert r.status_code == 200
    return r.json()  # type: ignore[no-any-return]


def operations(spec: dict[str, Any]) -> list[tuple[str, str, dict[str, Any]]]:
    return [(path, m, item[m]) for path, item in spec["paths"].items() for m in METHODS if m in item]


def refs(node: Any) -> list[str]:
    if isinstance(node, dict):
        return ([node["$ref"]] if isinstance(node.get("$ref"), str) else []) + [r for v in node.values() for r in refs(v)]
    if isinstance(node, list):
        return [r for v in node for r in refs(v)]
    return []


def conforms(spec: dict[str, Any], instance: Any, schema: dict[str, Any]) -> None:
    """``instance`` against ``schema``, whose $refs point into the document's components."""
    validator = OAS31Validator({**schema, "components": spec["components"]})
    errors = sorted(validator.iter_errors(instance), key=str)
    assert not errors, [f"{'/'.join(map(str, e.absolute_path))}: {e.message}" for e in errors[:5]]


def test_the_document_is_valid_openapi(spec: dict[str, Any]) -> None:
    assert spec["openapi"].startswith("3.1")
    validate_spec(spec)


def test_no_dangling_references(spec: dict[str, Any]) -> None:
    schemas = spec["components"]["schemas"]
    dangling = {r for r in refs(spec) if not (r.startswith("#/components/schemas/") and r.rsplit("/", 1)[1] in schemas)}
    assert not dangling
    body = spec["paths"]["/v1/select"]["post"]["requestBody"]["content"]["application/json"]
    assert body["schema"] == {"$ref": "#/components/schemas/SelectRequest"}
    conforms(spec, body["example"], body["schema"])


def test_every_json_response_has_a_schema(spec: dict[str, Any]) -> None:
    missing = []
    for path, method, op in operations(spec):
        for status, response in op["responses"].items():
            for media, content in response.get("content", {}).items():
                if "json" in media and not (content.get("schema") or {}).keys() & {"$ref", "type", "anyOf"}:
                    missing.append(f"{method.upper()} {path} {status} {media}")
        ok = [s for s in op["responses"] if s.startswith("2") and s != "204"]
        if ok and not any(op["responses"][s].get("content") for s in ok):
            missing.append(f"{method.upper()} {path}: no 2xx body documented")
    assert not missing


def test_errors_are_problem_json(spec: dict[str, Any]) -> None:
    wrong = []
    for path, method, op in operations(spec):
        if path == "/readyz":  # its 503 is the readiness document itself (status: starting | failed)
            continue
        for status, response in op["responses"].items():
            if int(status) >= 400 and response.get("content") != {
                "application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}
            }:
                wrong.append(f"{method.upper()} {path} {status}: {list(response.get('content', {}))}")
        assert "500" in op["responses"], (method, path)
    assert not wrong
    assert {"type", "title", "status", "detail"} <= set(spec["components"]["schemas"]["Problem"]["required"])


def test_writes_declare_the_bearer_scheme_and_need_a_token(spec: dict[str, Any], service: Service) -> None:
    assert spec["components"]["securitySchemes"]["bearer"] == {
        "type": "http", "scheme": "bearer", "description": spec["components"]["securitySchemes"]["bearer"]["description"]}
    secured = []
    for path, method, op in operations(spec):
        params = [p for p in op.get("parameters", []) if p["in"] == "header"]
        assert all(p["name"].lower() != "authorization" for p in params), (method, path)
        if op.get("security"):
            assert op["security"] == [{"bearer": []}] and {"401", "403"} <= set(op["responses"])
            secured.append((method, path))
    assert ("post", "/sparql/update") in secured and ("put", "/sparql/graph") in secured and ("get", "/sparql") not in secured
    # what the document says is what the service does: every secured operation is 401 without a token
    filled = {"{name}": "ORB", "{param}": "nfeatures", "{dimension}": "light", "{value}": "dark", "{rule_id}": "x",
              "{session_id}": "x", "{number}": "1", "{report_id}": "measurement_" + "0" * 32}
    before = service.version()
    for method, path in secured:
        url = service.url + re.sub(r"\{[a-z_]+\}", lambda m: filled[m.group(0)], path)
        r = httpx.request(method.upper(), url, params={"default": ""})
        assert r.status_code == 401 and r.headers["www-authenticate"].startswith("Bearer"), (method, path, r.text)
        assert r.headers["content-type"].startswith("application/problem+json")
    assert service.version() == before


def test_real_responses_conform_to_their_schemas(spec: dict[str, Any], service: Service) -> None:
    session = httpx.post(service.url + "/v1/sessions", json={"context": {"agent": "car"}}).json()["id"]
    rule = httpx.get(service.url + "/v1/rules").json()["rules"][0]["id"]
    calls: list[tuple[str, str, dict[str, Any]]] = [
        ("get", "/healthz", {}), ("get", "/readyz", {}), ("get", "/v1/vocabulary", {}),
        ("post", "/v1/select", {"json": {"context": {"agent": "car", "motion": "fast"}}}),
        ("post", "/v1/select", {"json": {"context": {"agent": "drone"}}}),
        ("get", "/v1/sessions/{session_id}", {}), ("get", "/v1/extractors", {}), ("get", "/v1/extractors/{name}", {}),
        ("get", "/v1/extractors/{name}/parameters/{param}", {}), ("get", "/v1/conditions", {}), ("get", "/v1/rules", {}),
        ("get", "/v1/rules/{rule_id}", {}), ("get", "/v1/programs", {}), ("get", "/v1/programs/{name}", {}),
        ("get", "/v1/graph", {}), ("get", "/v1/graph/versions", {}), ("get", "/v1/graph/versions/{number}", {}),
        ("get", "/v1/graph/diff", {"params": {"since": 0}}),
        ("get", "/sparql", {"params": {"query": "SELECT ?x WHERE { ?x a nfex:FeatureExtractor }"}, "headers": {"accept": "application/json"}}),
        ("post", "/v1/sparql-missing", {}),  # an error: Problem
        ("post", "/sparql/update", {"content": "INSERT DATA { nfex:a nfex:b nfex:c }", "headers": {
            "authorization": f"Bearer {EDITOR}", "content-type": "application/sparql-update", "if-match": '"0"'}}),
    ]
    filled = {"{session_id}": session, "{name}": "ORB", "{param}": "nfeatures", "{rule_id}": rule, "{number}": "1"}
    names = {"/v1/programs/{name}": "default"}
    for method, path, kwargs in calls:
        url = names.get(path) and path.replace("{name}", names[path]) or re.sub(r"\{[a-z_]+\}", lambda m: filled[m.group(0)], path)
        r = httpx.request(method.upper(), service.url + url, **kwargs)
        assert r.status_code == {"/v1/sparql-missing": 404, "/sparql/update": 412}.get(path, 200), (path, r.text[:300])
        media = r.headers["content-type"].split(";")[0]
        documented = spec["paths"].get(path, {}).get(method, {}).get("responses", {}).get(str(r.status_code))
        schema = (documented or {}).get("content", {}).get(media, {}).get("schema")
        if r.status_code >= 400 and documented is None:  # 404 on an unknown path: every error is a Problem
            schema = {"$ref": "#/components/schemas/Problem"}
        assert schema, (method, path, r.status_code, media)
        conforms(spec, r.json(), schema)


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.urls: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.urls += [v for k, v in attrs if k in ("src", "href") and v]


def test_docs_load_without_a_network(service: Service) -> None:
    page = httpx.get(service.url + "/docs")
    assert page.status_code == 200 and "swagger-ui" in page.text
    assert not re.search(r"https?://", page.text), "the page refers to another host (a CDN)"
    links = _Links()
    links.feed(page.text)
    urls = links.urls + re.findall(r"url: '([^']+)'", page.text)
    assert {"docs/assets/swagger-ui-bundle.js", "docs/assets/swagger-ui.css", "openapi.json"} <= set(urls)
    for url in urls:
        r = httpx.get(urljoin(service.url + "/docs", url))
        assert r.status_code == 200 and r.content, url


@pytest.mark.skipif(not (shutil.which("chromium") or shutil.which("chromium-browser")), reason="needs headless Chromium")
def test_swagger_ui_renders_the_operations_in_a_browser(service: Service) -> None:
    """Chromium renders /docs with the service as its only reachable host: the operations appear."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    assert exe
    dom = subprocess.run(
        [exe, "--headless=new", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=15000",
         "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1", "--dump-dom", service.url + "/docs"],
        capture_output=True, text=True, timeout=120,
    ).stdout
    assert "opblock-summary-path" in dom and "/v1/select" in dom and "/sparql/graph" in dom
