"""Frame streams over HTTP, and the session store's bounds (TTL, count, memory) directly."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import httpx
import numpy as np
import pytest

from nfex_core.advisor.scoring import SCORE_PIXELS
from nfex_core.errors import NotFound
from service.sessions import SessionStore, TooManySessions

from .conftest import Service, assert_problem, auth


def test_session_lifecycle(service: Service) -> None:
    r = httpx.post(service.url + "/v1/sessions", json={"context": {"agent": "drone"}, "client": "pytest"})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    assert httpx.get(f"{service.url}/v1/sessions/{sid}").json()["context"] == {"agent": "drone"}
    rng = np.random.default_rng(1)
    frame = cv2.GaussianBlur(rng.integers(0, 255, (240, 320), dtype=np.uint8), (3, 3), 0)
    ok, buf = cv2.imencode(".png", frame)
    results = [httpx.post(f"{service.url}/v1/sessions/{sid}/frames", files={"frame": ("f.png", bytes(buf), "image/png")}, timeout=60)
               for _ in range(2)]
    assert all(x.status_code == 200 for x in results), results[0].text
    assert [x.json()["session"]["temporal"] for x in results] == [False, True]
    # the same frame again: its evidence has not moved, the decision is reused with α* alone extracted
    assert [x.json()["session"]["reused"] for x in results] == [False, True]
    assert results[1].json()["reused"] == 1 and results[1].json()["scoring"]["outcome"] == "unscored"
    assert results[1].json()["scoring"]["extractions"] == 1
    assert results[1].json()["extractor"] == results[0].json()["extractor"]
    state = httpx.get(f"{service.url}/v1/sessions/{sid}").json()
    assert state["frames"] == 2 and state["has_previous"]
    # the scoring image, and the keypoints and descriptors of the candidates extracted on it (if any)
    assert state["state_bytes"] >= SCORE_PIXELS
    assert "nfex_session_state_bytes" in httpx.get(service.url + "/metrics").text
    r = httpx.post(f"{service.url}/v1/sessions/{sid}/frames", json={"context": {}})
    assert_problem(r, 400, "bad-input")  # a stream frame needs an image
    assert httpx.delete(f"{service.url}/v1/sessions/{sid}").status_code == 204
    assert_problem(httpx.get(f"{service.url}/v1/sessions/{sid}"), 404, "not-found")
    assert_problem(httpx.delete(f"{service.url}/v1/sessions/{sid}"), 404, "not-found")


def test_session_with_unknown_context_is_422(service: Service) -> None:
    doc = assert_problem(httpx.post(service.url + "/v1/sessions", json={"context": {"agent": "boat"}}), 422, "unknown-name")
    assert doc["allowed"] == ["car", "drone", "human"]


def test_session_count_is_bounded_over_http(service: Service) -> None:
    opened = []
    try:
        for _ in range(40):
            r = httpx.post(service.url + "/v1/sessions", json={})
            if r.status_code == 429:
                assert_problem(r, 429, "too-many-sessions")
                break
            opened.append(r.json()["id"])
        else:
            pytest.fail("the session count is not bounded")
        assert len(opened) <= 16
    finally:
        for sid in opened:
            httpx.delete(f"{service.url}/v1/sessions/{sid}")


@dataclass
class FakeFeatures:
    xy: np.ndarray


@dataclass
class State:
    image: np.ndarray
    features: dict[str, FakeFeatures]


def state(nbytes: int) -> State:
    return State(np.zeros(nbytes // 2, np.uint8), {"ORB": FakeFeatures(np.zeros(nbytes // 2, np.uint8))})


class Clock:
    """A clock the test moves by hand (SessionStore's ``clock``)."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_store_expires_idle_sessions() -> None:
    clock = Clock()
    store = SessionStore(ttl_s=60, max_sessions=4, memory_bytes=10**6, clock=clock)
    s = store.create({})
    clock.now += 59
    assert store.get(s.id) is s and s.as_dict(store.ttl_s, clock())["expires_in_s"] == 60  # use renews it
    clock.now += 60.5
    with pytest.raises(NotFound):
        store.get(s.id)
    assert len(store) == 0


def test_store_bounds_the_count_and_sweeps_expired_ones_first() -> None:
    clock = Clock()
    store = SessionStore(ttl_s=60, max_sessions=2, memory_bytes=10**6, clock=clock)
    store.create({})
    store.create({})
    with pytest.raises(TooManySessions):
        store.create({})
    clock.now += 61
    store.create({})  # the expired two made room
    assert len(store) == 1


def test_store_bounds_memory_by_dropping_least_recent_states() -> None:
    store = SessionStore(ttl_s=60, max_sessions=10, memory_bytes=3000)
    a, b, c = store.create({}), store.create({}), store.create({})
    store.keep(a, state(1000))
    store.keep(b, state(1000))
    store.get(a.id)  # a is now more recent than b
    store.keep(c, state(1500))
    assert store.bytes_held <= 3000
    assert b.state is None and a.state is not None and c.state is not None
    store.keep(a, state(5000))  # larger than the whole budget: not kept
    assert a.state is None and store.bytes_held <= 3000


def _estimate(yaw_deg: float, heading_deg: float, extractor: str, **measured: float) -> dict:  # type: ignore[type-arg]
    """A reported estimate that yaws by ``yaw_deg`` and moves ``heading_deg`` off straight ahead."""
    import math

    a, h = math.radians(yaw_deg), math.radians(heading_deg)
    R = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    d = np.array([math.sin(h), 0.0, math.cos(h)])
    t = -R @ d
    return {"extractor": extractor, "R": R.tolist(), "t": t.tolist(), "keypoints": 2000, "matches": 600, "inliers": 400,
            "parallax_px": 8.0, "extraction_ms": 5.0, **measured}


def test_a_stream_verifies_each_pair_accepting_escalating_and_falling_back(service: Service, data_dir) -> None:  # type: ignore[no-untyped-def]
    """The verification protocol through a real `nfex serve`: the learned program applied through the API, the
    frame's proposals, then /verdict with the estimates tried so far: next (with the next proposal), accept
    (citing the accept statement), fallback; removing the program turns verification off again."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "rules" / "verification" / "verification.nfex").read_text()
    plain = {"content-type": "text/plain", **auth()}
    r = httpx.put(service.url + "/v1/programs/verification", content=text, headers=plain, timeout=60)
    assert r.status_code in (200, 201), r.text
    try:
        _verify_a_stream(service, data_dir)
    finally:
        assert httpx.delete(service.url + "/v1/programs/verification", headers=auth(), timeout=60).status_code in (200, 204)
    r = httpx.post(service.url + "/v1/select?consistency=latest", json={"context": {"agent": "car"}}, timeout=60)
    assert r.status_code == 200, r.text
    assert r.json()["verification"]["accept"] == [] and r.json()["verification"]["max_tries"] == 1


def _verify_a_stream(service: Service, data_dir) -> None:  # type: ignore[no-untyped-def]
    sid = httpx.post(service.url + "/v1/sessions", json={"context": {"agent": "car", "scene": "outdoor"}}).json()["id"]
    frames = [cv2.imread(str(data_dir / "kitti" / "sequences" / "00" / "image_0" / f"{i:06d}.png"), cv2.IMREAD_GRAYSCALE) for i in range(4)]

    def frame(i: int) -> dict:  # type: ignore[type-arg]
        ok, buf = cv2.imencode(".png", frames[i])
        r = httpx.post(f"{service.url}/v1/sessions/{sid}/frames", files={"frame": ("f.png", bytes(buf), "image/png")}, timeout=120)
        assert r.status_code == 200, r.text
        return r.json()["verification"]  # type: ignore[no-any-return]

    def verdict(tried: list) -> httpx.Response:  # type: ignore[type-arg]
        return httpx.post(f"{service.url}/v1/sessions/{sid}/verdict", json={"tried": tried}, timeout=30)

    v = frame(0)
    assert v["accept"], "the applied program is in force for a car"
    assert v["max_tries"] >= 2 and 1 <= len(v["proposals"]) <= v["max_tries"]
    first, second = v["proposals"][0]["extractor"], v["proposals"][1]["extractor"]
    assert first != second  # escalation goes to a different extractor
    v = frame(1)
    # no motion prior yet and one estimate: nothing vouches for it → the next proposal
    r = verdict([_estimate(0.2, 1.0, first)])
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["action"] == "next" and out["next"]["extractor"] == v["proposals"][1]["extractor"] and out["tries"] == 1
    assert out["signals"][0]["heading_change"] is None and out["signals"][0]["agreement"] is None
    # a second, agreeing estimate: both vouch for each other; the first in order is taken
    out = verdict([_estimate(0.2, 1.0, first), _estimate(0.25, 1.2, out["next"]["extractor"])]).json()
    assert out["action"] == "accept" and out["accepted"] == 0 and "agreement" in out["because"]["label"]
    assert_problem(verdict([_estimate(0.2, 1.0, first)]), 409, "no-pair-to-judge")  # a pair is judged once
    # now the motion so far is known: a consistent estimate is accepted at once, by the motion rule
    frame(2)
    out = verdict([_estimate(0.3, 1.1, first)]).json()
    assert out["action"] == "accept" and "heading_change" in out["because"]["label"]
    # a pair every candidate gets wrong, each differently, falls back to the motion prior
    v = frame(3)
    wild = [_estimate(40.0 * (k + 1), 90.0 + 30 * k, p["extractor"]) for k, p in enumerate(v["proposals"])]
    out = verdict(wild).json()
    assert out["action"] == "fallback" and "motion prior" in out["reason"]
    # bad input: a matrix that is not a rotation, a lost pair is fine
    frame(3)
    bad = _estimate(0.0, 0.0, first)
    bad["R"] = [[2, 0, 0], [0, 1, 0], [0, 0, 1]]
    assert "not a rotation" in assert_problem(verdict([bad]), 400, "bad-input")["detail"]
    lost = verdict([{"extractor": first, "R": None, "t": None, "rejected": "too few matches"}]).json()
    assert lost["action"] == "next" and lost["signals"][0]["rotation"] is None
