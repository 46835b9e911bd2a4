"""The routes the workbench page uses: program check and preview, keypoints on /v1/select, dataset
samples, saved queries, rule effects, and the page itself (served with a self-only CSP)."""
from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from .conftest import Service, assert_problem, auth

TEXT = {"content-type": "text/plain"}
KITTI = Path("kitti") / "sequences" / "01" / "image_0" / "000010.png"


def test_check_lists_problems_with_line_column_and_known_names(service: Service) -> None:
    r = httpx.post(service.url + "/v1/programs/wb_check/check", content="prune ORB when light is drak\nadjust ORB.nfeaturs by 2\n", headers=TEXT)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert doc["valid"] is False and doc["statements"] == 2
    first, second = doc["problems"]
    assert (first["line"], first["column"], first["name"]) == (1, 25, "drak") and "dark" in first["allowed"]
    assert (second["line"], second["column"]) == (2, 12) and "ORB.nfeatures" in second["allowed"]
    assert first["type"].endswith("/unknown-name")
    syntax = httpx.post(service.url + "/v1/programs/wb_check/check", content="prune ORB when\n", headers=TEXT).json()
    assert syntax["valid"] is False and syntax["statements"] is None and syntax["problems"][0]["type"].endswith("/parse-error")
    ok = httpx.post(service.url + "/v1/programs/wb_check/check", content='prune ORB when light is dark because "x"\n', headers=TEXT).json()
    assert ok == {"name": "wb_check", "valid": True, "statements": 1, "problems": []}
    assert_problem(httpx.post(service.url + "/v1/programs/wb_check/check", json={"text": "x"}), 415)
    assert_problem(httpx.post(service.url + "/v1/programs/bad%20name/check", content="x", headers=TEXT), 400)


def test_preview_lists_changed_decisions_and_writes_nothing(service: Service) -> None:
    before = service.version()
    ctx = {"agent": "drone", "light": "dark"}
    alpha = httpx.post(service.url + "/v1/select", json={"context": ctx}).json()["extractor"]
    r = httpx.post(service.url + "/v1/programs/wb_preview/preview", content=f'prune {alpha} when agent is drone because "preview test"\n',
                   headers=TEXT, timeout=120)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert doc["graph_version"] == before and doc["conforms"] is True and doc["added"] > 0
    assert doc["changed"] == doc["alpha_changed"] > 0 and doc["contexts"] > doc["changed"]
    assert all(c["context"]["agent"] == "drone" and c["before"]["extractor"] == alpha != c["after"]["extractor"] for c in doc["changes"])
    assert ctx in [{k: c["context"][k] for k in ("agent", "light") if k in c["context"]} for c in doc["changes"]]
    assert service.version() == before
    assert all(p["name"] != "wb_preview" for p in httpx.get(service.url + "/v1/programs").json()["programs"])
    bad = httpx.post(service.url + "/v1/programs/wb_preview/preview", content="prune NOPE when agent is drone\n", headers=TEXT)
    assert assert_problem(bad, 422, "unknown-name")["line"] == 1


@pytest.fixture(scope="module")
def kitti_png(data_dir: Path) -> bytes:
    path = data_dir / KITTI
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    return path.read_bytes()


def test_keypoints_are_opt_in(service: Service, kitti_png: bytes) -> None:
    files = {"frame": ("f.png", kitti_png, "image/png")}
    data = {"context": '{"agent": "car"}'}
    plain = httpx.post(service.url + "/v1/select", files=files, data=data, timeout=60).json()
    assert "keypoints" not in plain
    r = httpx.post(service.url + "/v1/select?keypoints=true", files=files, data=data, timeout=60)
    assert r.status_code == 200, r.text
    doc = r.json()
    kp = doc["keypoints"]
    assert kp["extractor"] == doc["extractor"] and (kp["width"], kp["height"]) == (1241, 376)
    assert 0 < len(kp["xy"]) == len(kp["size"]) <= kp["count"]
    assert all(0 <= x < 1241 and 0 <= y < 376 for x, y in kp["xy"])
    assert_problem(httpx.post(service.url + "/v1/select?keypoints=maybe", files=files, data=data), 400, "bad-input")
    assert_problem(httpx.post(service.url + "/v1/select?keypoints=true", json={"context": {}}), 400, "bad-input")
    assert "keypoints" not in httpx.post(service.url + "/v1/select?keypoints=false", files=files, data=data, timeout=60).json()


def test_samples_list_and_serve_frames_by_id_only(service: Service, data_dir: Path) -> None:
    listed = httpx.get(service.url + "/v1/samples").json()["samples"]
    kitti = next((s for s in listed if s["dataset"] == "kitti" and s["sequence"] == "01"), None)
    if kitti is None:
        pytest.skip("KITTI 01 is not in the data folder")
    assert kitti["context"] == {"agent": "car", "scene": "outdoor"}
    r = httpx.get(service.url + f"/v1/samples/{kitti['id']}")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png"
    assert r.content == (data_dir / "kitti" / "sequences" / "01" / "image_0" / kitti["file"]).read_bytes()
    assert_problem(httpx.get(service.url + "/v1/samples/kitti-01-9999"), 404, "not-found")
    assert_problem(httpx.get(service.url + "/v1/samples/..%2F..%2Fetc%2Fpasswd"), 404)


def test_rule_effects_cover_the_programs_statements(service: Service) -> None:
    doc = httpx.get(service.url + "/v1/rule-effects").json()
    by_label = {r["label"]: r for r in doc["rules"]}
    dark = by_label["adjust ORB.nfeatures by 1.6 when light is dark"]
    (effect,) = dark["effects"]
    assert effect["what"] == "adjusts ORB.nfeatures" and effect["example"]["light"] == "dark"
    # light is dark in 1/(|light values| + 1) of the contexts
    lights = len(httpx.get(service.url + "/v1/vocabulary").json()["context"]["light"]["values"]) + 1
    assert effect["contexts"] * lights == doc["contexts"]
    assert dark["source"].startswith("rules/programs/default.nfex:") and dark["reasons"]


def test_saved_queries_and_the_page(service: Service) -> None:
    assert isinstance(httpx.get(service.url + "/v1/queries").json()["queries"], list)
    r = httpx.get(service.url + "/ui/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    csp = r.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "connect-src 'self'" in csp and "http" not in csp
    assert '<script type="module" src="js/app.js">' in r.text
    for asset in ("ui.css", "js/app.js", "js/sparql.js", "js/editor.js"):
        a = httpx.get(service.url + "/ui/" + asset)
        assert a.status_code == 200 and a.headers["content-security-policy"] == csp, asset
    assert httpx.get(service.url + "/ui", follow_redirects=False).headers["location"] == "/ui/"
    assert_problem(httpx.get(service.url + "/ui/nope.js"), 404)


def test_page_assets_load_nothing_from_elsewhere() -> None:
    """No asset names another origin (the CSP would refuse it; this says where, before a browser does)."""
    import re

    root = Path(__file__).resolve().parents[2] / "service" / "ui"
    for path in root.rglob("*"):
        if path.suffix not in (".html", ".js", ".css"):
            continue
        text = path.read_text()
        for url in re.findall(r"""(?:src|href|url|import)\s*(?:=|\()?\s*["'(]?\s*(https?://[^"')\s]+)""", text):
            pytest.fail(f"{path.name} loads {url}")
    assert (root / "index.html").is_file()


def test_apply_then_versions_then_rollback(service: Service) -> None:
    head = service.version()
    r = httpx.put(service.url + "/v1/programs/wb_apply", content='prune AKAZE when agent is human because "wb"\n', headers={**TEXT, **auth()})
    assert r.status_code == 201 and r.json()["version"] == head + 1
    assert httpx.get(service.url + "/v1/graph/versions").json()["versions"][0]["message"] == "PUT program wb_apply"
    assert httpx.post(service.url + "/v1/graph/rollback", json={"to": head}, headers=auth()).json()["version"] == head + 2
    assert all(p["name"] != "wb_apply" for p in httpx.get(service.url + "/v1/programs").json()["programs"])
