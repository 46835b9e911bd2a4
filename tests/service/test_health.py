"""Operations: health, readiness (without torch), Prometheus metrics, problem+json for 404/405,
OpenAPI with examples, one JSON log line per request."""
from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import httpx
import pytest

from tests.conftest import stop_process

from .conftest import Service, assert_problem, start_service


def test_health_readiness_and_vocabulary(service: Service) -> None:
    assert httpx.get(service.url + "/healthz").json() == {"status": "ok"}
    ready = httpx.get(service.url + "/readyz").json()
    assert ready["status"] == "ready" and ready["graph_version"] >= 1
    assert ready["torch_loaded"] is False  # readiness never waits on importing torch
    assert ready["rule_table"]["contexts"] > 0
    for _ in range(300):  # the SHACL worker starts once the service is ready
        shacl = httpx.get(service.url + "/readyz").json()["shacl_process"]
        if shacl["running"]:
            break
        time.sleep(0.1)
    assert shacl == {"running": True, "starts": 1, "fallbacks": 0}
    vocab = httpx.get(service.url + "/v1/vocabulary").json()
    assert vocab["context"]["light"]["values"] == ["dark", "bright"]
    assert set(vocab["extractors"]) == {"ORB", "ORB_GRID", "SIFT", "AKAZE", "BRISK", "XFEAT"}
    backends = ready["backends"]
    assert backends["opencv"]["available"] is True and "ORB" in backends["opencv"]["extractors"]
    assert backends["xfeat"]["extractors"] == ["XFEAT"] and isinstance(backends["xfeat"]["available"], bool)


def test_a_learned_extractor_without_weights_is_absent_with_a_note(seeded_template: Path, tmp_path: Path) -> None:
    """No weights file: the service starts, /readyz says why XFeat cannot run, and every selection lists
    XFEAT as pruned by nfex:rule_backend_available with that reason, never an import error."""
    store = tmp_path / "store"
    shutil.copytree(seeded_template, store, ignore=shutil.ignore_patterns("LOCK"))
    svc = start_service(str(store), tmp_path / "service.log", {"NFEX_XFEAT_WEIGHTS": str(tmp_path / "missing.pt")})
    try:
        xfeat = httpx.get(svc.url + "/readyz").json()["backends"]["xfeat"]
        assert xfeat["available"] is False and xfeat["setting"] == "NFEX_XFEAT_WEIGHTS"
        assert str(tmp_path / "missing.pt") in xfeat["detail"]
        sel = httpx.post(svc.url + "/v1/select", json={"context": {"light": "dark"}}).json()
        assert sel["extractor"] != "XFEAT" and all(c["extractor"] != "XFEAT" for c in sel["candidates"])
        [pruned] = [p for p in sel["pruned"] if p["extractor"] == "XFEAT"]
        assert pruned["because"][0]["rule"] == "https://w3id.org/nfex#rule_backend_available"
        assert "missing.pt" in pruned["because"][0]["reason"]
    finally:
        stop_process(svc.proc)


def test_unknown_route_and_method_are_problem_json(service: Service) -> None:
    assert_problem(httpx.get(service.url + "/nope"), 404)
    r = httpx.delete(service.url + "/v1/select")
    assert_problem(r, 405)
    assert "POST" in r.headers["allow"]


def test_metrics_count_requests(service: Service) -> None:
    httpx.post(service.url + "/v1/select", json={"context": {}})
    text = httpx.get(service.url + "/metrics").text
    assert 'nfex_http_requests_total{method="POST",route="/v1/select",status="200"}' in text
    assert "nfex_http_request_seconds_bucket" in text and "nfex_graph_version" in text


def test_openapi_has_every_resource_with_examples(service: Service) -> None:
    spec = httpx.get(service.url + "/openapi.json").json()
    paths = set(spec["paths"])
    assert {"/v1/select", "/v1/sessions/{session_id}/frames", "/v1/feedback", "/sparql", "/sparql/update", "/v1/rules/{rule_id}",
            "/v1/graph/rollback", "/metrics", "/readyz"} <= paths
    body = spec["paths"]["/v1/select"]["post"]["requestBody"]["content"]
    assert body["application/json"]["example"]["context"]["agent"] == "car" and "multipart/form-data" in body
    assert spec["components"]["schemas"]["FeedbackRequest"]["examples"]


def test_logs_are_one_json_object_per_line(service: Service) -> None:
    httpx.get(service.url + "/healthz", headers={"x-test": "log"})
    lines = [json.loads(x) for x in service.log_lines() if x.startswith("{")]
    requests = [x for x in lines if x.get("logger") == "nfex.access"]
    assert requests and {"method", "path", "status", "ms", "time", "level"} <= set(requests[-1])
    # every line is JSON but what native libraries print straight to stderr (libpng's decoder errors)
    assert all(x.startswith(("{", "libpng")) for x in service.log_lines() if x.strip())


def test_the_app_sets_the_gil_switch_interval() -> None:
    """NFEX_SWITCH_INTERVAL_MS: a selection waits on a compile or a validation at most one switch interval per
    switch (bench/bench_fleet.py measures what it buys); 0 leaves Python's own."""
    import sys

    from service.config import Settings
    from service.main import create_app

    before = sys.getswitchinterval()
    try:
        create_app(Settings(switch_interval_ms=0.7))
        assert abs(sys.getswitchinterval() - 0.0007) < 1e-9
        create_app(Settings(switch_interval_ms=0))
        assert abs(sys.getswitchinterval() - 0.0007) < 1e-9
    finally:
        sys.setswitchinterval(before)


@pytest.mark.parametrize("freeze", [True, False])
def test_the_warm_up_freezes_what_start_up_built_and_reads_the_shapes_footprint(freeze: bool) -> None:
    """NFEX_GC_FREEZE: after the first snapshot, what start-up built leaves the collector's full collections
    (gc.freeze), which otherwise stopped every thread ~100 ms at a time (bench/bench_fleet.py's select max)."""
    import gc
    import threading
    from types import SimpleNamespace

    from nfex_core.kg import parse_rdf
    from nfex_core.kg.shacl.validation import shapes_in
    from service.config import Settings
    from service.main import _warm

    snap = SimpleNamespace(version=7)
    shapes = shapes_in(parse_rdf("@prefix sh: <http://www.w3.org/ns/shacl#> . <urn:S> a sh:NodeShape ; sh:targetClass <urn:C> ."))
    state = SimpleNamespace(settings=Settings(gc_freeze=freeze), advisor=SimpleNamespace(snapshot=lambda: snap),
                            kg=SimpleNamespace(shacl=None, shapes=lambda: shapes), ready=threading.Event())
    gc.unfreeze()
    try:
        _warm(SimpleNamespace(state=state))  # type: ignore[arg-type]
        assert state.ready.is_set()
        assert (gc.get_freeze_count() > 0) == freeze
        assert "footprint" in vars(shapes)  # read by the warm-up (~0.3 s on the shipped graph), not by the first write
    finally:
        gc.unfreeze()
