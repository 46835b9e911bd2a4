"""HEAD and OPTIONS on every documented path, and a 405 whose Allow lists every method of the path."""
from __future__ import annotations

import re

import httpx
import pytest

from .conftest import Service, assert_problem

FILLED = {"{name}": "ORB", "{param}": "nfeatures", "{dimension}": "light", "{value}": "dark", "{rule_id}": "?",
          "{session_id}": "?", "{number}": "1", "{report_id}": "measurement_" + "0" * 32,
          "{sample_id}": "?"}
ORDER = ["GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"]
QUERIES = {"/v1/graph/diff": {"since": 0}, "/sparql/graph": {"default": ""}}


@pytest.fixture(scope="module")
def paths(service: Service) -> dict[str, list[str]]:
    """Every documented path, filled in, with the methods the document gives it (plus HEAD and OPTIONS)."""
    spec = httpx.get(service.url + "/openapi.json").json()
    session = httpx.post(service.url + "/v1/sessions", json={"context": {}}).json()["id"]
    rule = httpx.get(service.url + "/v1/rules").json()["rules"][0]["id"]
    samples = httpx.get(service.url + "/v1/samples").json()["samples"]
    assert samples, "the service's data folder (NFEX_DATA) has no frames"
    fill = {**FILLED, "{session_id}": session, "{rule_id}": rule, "{sample_id}": samples[0]["id"]}
    out = {}
    for path, item in spec["paths"].items():
        methods = {m.upper() for m in item if m in ("get", "put", "post", "delete", "patch")}
        methods |= {"OPTIONS"} | ({"HEAD"} if "GET" in methods else set())
        url = re.sub(r"\{[a-z_]+\}", lambda m: fill[m.group(0)], path)
        if path == "/v1/programs/{name}":
            url = "/v1/programs/default"
        out[url] = sorted(methods, key=ORDER.index)
    out["/docs"] = ["GET", "HEAD", "OPTIONS"]
    return out


def test_options_answers_allow_everywhere(service: Service, paths: dict[str, list[str]]) -> None:
    for url, methods in paths.items():
        r = httpx.options(service.url + url, params=QUERIES.get(url))
        assert r.status_code == 204 and r.content == b"", (url, r.status_code, r.text[:200])
        assert r.headers["allow"].split(", ") == methods, url


def test_head_is_get_without_the_body(service: Service, paths: dict[str, list[str]]) -> None:
    for url, methods in paths.items():
        if "GET" not in methods:
            continue
        params = QUERIES.get(url)
        get = httpx.get(service.url + url, params=params)
        head = httpx.head(service.url + url, params=params)
        assert head.status_code == get.status_code == 200, (url, head.status_code, get.text[:200])
        assert head.content == b"" and head.headers["content-type"] == get.headers["content-type"], url
        if url not in ("/metrics", "/readyz", "/v1/sessions/" + url.rsplit("/", 1)[-1]):  # these change between calls
            assert head.headers["content-length"] == str(len(get.content)), url


def test_head_of_a_missing_resource_is_404_and_of_a_write_only_path_405(service: Service) -> None:
    missing = httpx.head(service.url + "/v1/rules/nope")
    assert missing.status_code == 404 and missing.content == b""
    r = httpx.head(service.url + "/v1/select")
    assert r.status_code == 405 and r.headers["allow"] == "POST, OPTIONS"
    assert httpx.options(service.url + "/nope").status_code == 404


def test_405_allows_every_method_of_the_path(service: Service) -> None:
    r = httpx.delete(service.url + "/sparql")
    assert_problem(r, 405)
    assert r.headers["allow"] == "GET, HEAD, POST, OPTIONS"
    r = httpx.patch(service.url + "/sparql/graph", params={"default": ""})
    assert_problem(r, 405)
    assert r.headers["allow"] == "GET, HEAD, POST, PUT, DELETE, OPTIONS"
