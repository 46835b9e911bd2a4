"""The installable Python client (clients/python) against the real service: sync, async, errors, OpenCV."""
from __future__ import annotations

import asyncio
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from nfex_client import (
    AsyncNfexClient,
    BadRequest,
    NfexClient,
    NotFound,
    PreconditionFailed,
    ServiceUnavailable,
    Unauthorized,
    Unprocessable,
    UnsupportedMediaType,
    extractor_from_selection,
    matcher_from_selection,
)

from tests.service.conftest import EDITOR, REPORTER, Service

ROOT = Path(__file__).resolve().parent.parent.parent


def test_select_and_build_the_extractor(service: Service, data_dir: Path) -> None:
    frame = cv2.imread(str(data_dir / "kitti" / "sequences" / "01" / "image_0" / "000000.png"), cv2.IMREAD_GRAYSCALE)
    with NfexClient(service.url) as nfex:
        for context in ({"agent": "car", "motion": "fast"}, {"agent": "human", "scene": "indoor"}, {}):
            sel = nfex.select(context)
            extractor = extractor_from_selection(sel)
            keypoints, descriptors = extractor.detectAndCompute(frame, None)
            assert len(keypoints) > 50 and descriptors is not None
            assert matcher_from_selection(sel) is not None
        assert nfex.select({"agent": "car", "motion": "fast"})["extractor"] != "SIFT"


def test_problems_become_exceptions(service: Service) -> None:
    with NfexClient(service.url) as nfex:
        with pytest.raises(Unprocessable) as e:
            nfex.select({"light": "purple"})
        assert e.value.allowed == ["bright", "dark"] and e.value.slug == "unknown-name"
        with pytest.raises(UnsupportedMediaType):
            nfex.select({}, frame=b"not an image at all")
        with pytest.raises(BadRequest):
            nfex.sparql("SELECT nonsense")
        with pytest.raises(ServiceUnavailable) as q:
            nfex.sparql("SELECT * WHERE { GRAPH ?g { ?s ?p ?o } }")
        assert q.value.problem["limit"] == "result-size"
        with pytest.raises(Unauthorized):
            nfex.update("INSERT DATA { nfex:ORB rdfs:seeAlso <https://example.org/c> }")
        with pytest.raises(NotFound):
            nfex.close_session("nope")


def test_editing_with_a_token(service: Service) -> None:
    with NfexClient(service.url, token=EDITOR) as nfex:
        head = nfex.graph_version()
        r = nfex.update("INSERT DATA { nfex:AKAZE rdfs:seeAlso <https://example.org/client> }", if_match=head)
        assert r["version"] == head + 1
        with pytest.raises(PreconditionFailed) as e:
            nfex.update("INSERT DATA { nfex:AKAZE rdfs:seeAlso <https://example.org/client2> }", if_match=head)
        assert e.value.current_version == head + 1
        with pytest.raises(Unprocessable) as v:
            nfex.patch_parameter("ORB", "scaleFactor", default=0.5)
        assert v.value.violations
        assert nfex.diff(head)["added_count"] == 1
        assert nfex.rollback(head)["version"] == head + 2
        assert nfex.versions(limit=1)[0]["message"] == f"rollback to version {head}"


def test_sessions_and_feedback(service: Service) -> None:
    with NfexClient(service.url, token=REPORTER) as nfex:
        s = nfex.open_session({"agent": "car"}, client="client-test")
        frame = np.random.default_rng(2).integers(0, 255, (120, 160), dtype=np.uint8)
        sel = nfex.session_frame(s["id"], frame)
        assert sel["session"]["frame"] == 1
        r = nfex.feedback(extractor="ORB", session_id=s["id"], ate_rmse=0.8, sequence="client/test")
        assert r["changed"] and r["iri"].startswith("https://w3id.org/nfex#measurement_")
        key = f"client-test-{np.random.default_rng().integers(1 << 62)}"
        first = nfex.feedback(idempotency_key=key, extractor="ORB", session_id=s["id"], ate_rmse=0.8, sequence="client/test")
        retry = nfex.feedback(idempotency_key=key, extractor="ORB", session_id=s["id"], ate_rmse=0.8, sequence="client/test")
        assert first["changed"] and not retry["changed"] and retry["iri"] == first["iri"]
        nfex.close_session(s["id"])


def test_async_client(service: Service) -> None:
    async def main() -> list[str]:
        async with AsyncNfexClient(service.url) as nfex:
            sels = await asyncio.gather(*(nfex.select({"agent": a}) for a in ("car", "drone", "human")))
            with pytest.raises(Unprocessable):
                await nfex.select({"agent": "boat"})
            rows = await nfex.sparql("SELECT ?x WHERE { ?x a nfex:FeatureExtractor }")
            assert len(rows["results"]["bindings"]) >= 4
            return [s["extractor"] for s in sels]

    assert len(asyncio.run(main())) == 3


def test_the_client_is_an_installable_package(tmp_path: Path) -> None:
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(tmp_path),
                        str(ROOT / "clients" / "python")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    wheel = next(tmp_path.glob("nfex_client-0.1.0-*.whl"))
    import zipfile

    names = zipfile.ZipFile(wheel).namelist()
    assert "nfex_client/py.typed" in names and "nfex_client/client.py" in names


def test_a_grid_selection_builds_a_grid_spread_that_orders_as_the_registry(data_dir: Path) -> None:
    from nfex_client import GridSpread, spread_keypoints
    from nfex_slam.features import spread_over_grid

    frame = cv2.imread(str(data_dir / "kitti" / "sequences" / "01" / "image_0" / "000000.png"), cv2.IMREAD_GRAYSCALE)
    sel = {"params": {}, "opencv": {"constructor": "ORB_create", "norm": "NORM_HAMMING",
                                    "args": {"nfeatures": 1500, "fastThreshold": 12}, "grid": {"cell_size": 48, "keep": 500}}}
    extractor = extractor_from_selection(sel)
    assert isinstance(extractor, GridSpread)
    keypoints, descriptors = extractor.detectAndCompute(frame, None)
    assert 400 < len(keypoints) <= 500 and descriptors.shape[0] == len(keypoints)
    detected = cv2.ORB_create(nfeatures=1500, fastThreshold=12).detect(frame, None)
    rng = np.random.default_rng(5)
    ties = [cv2.KeyPoint(float(x), float(y), 7.0, -1, float(r)) for x, y, r in
            zip(rng.integers(0, 600, 300), rng.integers(0, 300, 300), rng.choice([0.25, 0.5], 300), strict=True)]
    for kps, cell, keep in ((detected, 48, 500), (detected, 100, 0), (ties, 48, 120), ([], 48, 10)):
        assert [id(k) for k in spread_keypoints(kps, cell, keep)] == [id(k) for k in spread_over_grid(kps, cell, keep)]
