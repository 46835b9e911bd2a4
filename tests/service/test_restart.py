"""A restarted service answers from the rule table it kept when it stopped (NFEX_COMPILED_CACHE,
nfex_core/rules/persisted.py) — the same answers, without compiling — and a report after the restart is
compiled on from it."""
from __future__ import annotations

import shutil
from pathlib import Path

import httpx

from tests.conftest import stop_process

from .conftest import REPORTERS, start_service

CONTEXT = {"context": {"agent": "car", "light": "dark"}}


def _answer(url: str) -> dict:  # type: ignore[type-arg]
    out = httpx.post(url + "/v1/select", json=CONTEXT).json()
    return {k: out[k] for k in ("extractor", "params", "candidates", "pruned")}


def test_a_restart_answers_from_the_kept_table(seeded_template: Path, tmp_path: Path) -> None:
    store = tmp_path / "store"
    shutil.copytree(seeded_template, store, ignore=shutil.ignore_patterns("LOCK"))
    env = {"NFEX_COMPILED_CACHE": str(tmp_path / "compiled")}
    svc = start_service(str(store), tmp_path / "first.log", env)
    try:
        assert httpx.get(svc.url + "/readyz").json()["rule_table"]["kept"] is False
        before = _answer(svc.url)
    finally:
        stop_process(svc.proc)
    assert list((tmp_path / "compiled").glob("*.pickle"))
    svc = start_service(str(store), tmp_path / "second.log", env)
    try:
        ready = httpx.get(svc.url + "/readyz").json()
        assert ready["rule_table"]["kept"] is True
        assert _answer(svc.url) == before
        name, token = next(iter(REPORTERS.items()))
        r = httpx.post(svc.url + "/v1/feedback", headers={"Authorization": f"Bearer {token}"},
                       json={"extractor": "ORB", "context": CONTEXT["context"], "ate_rmse": 0.4, "sequence": "restart/test"})
        assert r.status_code == 201, r.text
        after = httpx.post(svc.url + "/v1/select", params={"consistency": "latest"}, json=CONTEXT).json()
        assert after["versions"]["graph"] == r.json()["version"]
        assert httpx.get(svc.url + "/readyz").json()["rule_table"]["kept"] is False  # compiled on from the kept one
    finally:
        stop_process(svc.proc)
