"""The C++ client (clients/cpp) against the real service: its ctest suite, the nfex_select and nfex_stream
examples on KITTI frames, and agreement with the Python client on α and Θ′ for the same frame and context.

The build is ``make cpp``'s (clients/cpp/build); this module configures and builds it incrementally
(a no-op when ``make cpp`` just ran) and skips, naming ``make cpp``, where the toolchain or a library is
missing. Only one test worker builds at a time (a file lock in the build folder).
"""
from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import cv2
import httpx
import pytest
from nfex_client import NfexClient, extractor_from_selection

from tests.conftest import stop_process
from tests.service.conftest import REPORTER, Service, start_service

ROOT = Path(__file__).resolve().parent.parent.parent
SOURCE = ROOT / "clients" / "cpp"
BUILD = SOURCE / "build"  # the Makefile's CPP_BUILD default
MISSING = ("Could NOT find", "Could not find a package configuration file", "No CMAKE_CXX_COMPILER could be found")
CONTEXTS = [
    {"agent": "car", "scene": "outdoor"},
    {"agent": "car", "budget_ms": "10"},
    {"agent": "drone", "light": "dark"},
    {"agent": "human", "motion": "fast"},
    {},
]


@pytest.fixture(scope="session")
def cpp_build() -> Iterator[Path]:
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed: run `make cpp` (it installs the C++ toolchain and libraries)")
    BUILD.mkdir(parents=True, exist_ok=True)
    with (BUILD / "pytest.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (BUILD / "CMakeCache.txt").exists():
            r = subprocess.run(["cmake", "-S", str(SOURCE), "-B", str(BUILD)], capture_output=True, text=True, timeout=300)
            if r.returncode != 0:
                missing = next((line for line in (r.stdout + r.stderr).splitlines() if any(m in line for m in MISSING)), None)
                if missing is not None:
                    pytest.skip(f"a C++ dependency is missing ({missing.strip()}): run `make cpp`")
                pytest.fail(f"cmake could not configure clients/cpp:\n{r.stdout}\n{r.stderr}")
        r = subprocess.run(["cmake", "--build", str(BUILD), "-j", "2"], capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, f"the C++ client does not build:\n{r.stdout[-4000:]}\n{r.stderr[-4000:]}"
    yield BUILD


@pytest.fixture(scope="module")
def shipped_service(shipped_template: tuple[Path, object], tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """The service over a copy of the store with the shipped measurements: its cost model and measured
    configurations make the chosen extractor depend on the context (ORB, the grid-spread ORB, SIFT)."""
    folder = tmp_path_factory.mktemp("shipped-service")
    store = shutil.copytree(shipped_template[0], folder / "store", ignore=shutil.ignore_patterns("LOCK"))
    svc = start_service(str(store), folder / "service.log", {"NFEX_HOME": str(ROOT)})
    yield svc
    stop_process(svc.proc)


def kitti_frame(data_dir: Path, n: int) -> Path:
    path = data_dir / "kitti" / "sequences" / "01" / "image_0" / f"{n:06d}.png"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    return path


def nfex_select(build: Path, url: str, frame: Path, context: dict[str, str]) -> subprocess.CompletedProcess[str]:
    spec = ",".join(f"{k}={v}" for k, v in context.items())
    return subprocess.run([str(build / "nfex_select"), "--url", url, "--context", spec, "--frame", str(frame)],
                          capture_output=True, text=True, timeout=120)


def test_ctest_suite_against_the_service(cpp_build: Path, service: Service, data_dir: Path) -> None:
    env = dict(os.environ, NFEX_TEST_URL=service.url, NFEX_TEST_FRAME=str(kitti_frame(data_dir, 0)), NFEX_TEST_TOKEN=REPORTER)
    r = subprocess.run(["ctest", "--test-dir", str(cpp_build), "--output-on-failure"], env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-6000:] + r.stderr[-2000:]
    assert "100% tests passed, 0 tests failed out of 3" in r.stdout and "Skipped" not in r.stdout, r.stdout


def test_nfex_select_prints_the_selection_and_a_keypoint_count(cpp_build: Path, service: Service, data_dir: Path) -> None:
    r = nfex_select(cpp_build, service.url, kitti_frame(data_dir, 0), {"agent": "car", "scene": "outdoor"})
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)  # one JSON object, nothing else on stdout
    assert out["keypoints"] > 100
    assert out["extractor"] == out["candidates"][0]["extractor"] and out["params"] and out["opencv"]["args"]
    assert out["mode"] != "prior" and out["versions"]["graph"] >= 1
    assert {"dimension": "agent", "value": "car", "source": "given", "confidence": 1.0} in out["context"]


def test_nfex_select_exits_non_zero_with_the_problem_detail(cpp_build: Path, service: Service, data_dir: Path) -> None:
    frame = kitti_frame(data_dir, 0)
    r = nfex_select(cpp_build, service.url, frame, {"agent": "submarine"})
    with frame.open("rb") as f:
        problem = httpx.post(service.url + "/v1/select", files={"frame": ("f.png", f, "image/png")},
                             data={"context": '{"agent": "submarine"}'}).json()
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.startswith(f"nfex_select: {problem['detail']} [422 unknown-name]"), r.stderr


def test_cpp_and_python_clients_agree_on_alpha_and_theta(cpp_build: Path, shipped_service: Service, data_dir: Path) -> None:
    service, chosen = shipped_service, set()
    with NfexClient(service.url) as nfex:
        for n in (0, 25):
            path = kitti_frame(data_dir, n)
            frame = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            for context in CONTEXTS:
                r = nfex_select(cpp_build, service.url, path, context)
                assert r.returncode == 0, (context, r.stderr)
                cpp = json.loads(r.stdout)
                py = nfex.select(context, frame=frame)
                assert (cpp["extractor"], cpp["params"], cpp["opencv"]) == (py["extractor"], py["params"], py["opencv"]), context
                chosen.add(cpp["extractor"])
                grid = cpp["opencv"]["grid"]
                if grid is not None:  # both clients keep at most `keep` of the spread keypoints
                    assert 0 < cpp["keypoints"] <= grid["keep"]
                    assert 0 < len(extractor_from_selection(py).detect(frame)) <= grid["keep"]
    assert {"SIFT", "ORB_GRID"} <= chosen, chosen  # the contexts exercise the grid recipe too


def test_nfex_stream_runs_a_session_over_a_kitti_folder(cpp_build: Path, service: Service, data_dir: Path) -> None:
    sequence = kitti_frame(data_dir, 0).parent.parent
    r = subprocess.run([str(cpp_build / "nfex_stream"), "--url", service.url, "--context", "agent=car", "--sequence",
                        str(sequence), "--limit", "4", "--feedback", "cpp-client/stream-test",
                        "--token", REPORTER],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = [json.loads(line) for line in r.stdout.splitlines()]
    frames = [x for x in lines if "frame" in x]
    assert [x["frame"] for x in frames] == [0, 1, 2, 3]
    assert [x["temporal"] for x in frames] == [False, True, True, True]
    assert all(x["keypoints"] > 100 and x["extractor"] for x in frames)
    assert "matches" not in frames[0] and all(x["matches"] > 50 for x in frames[1:])
    reports = [x for x in lines if "feedback" in x]
    assert reports and all(x["feedback"].startswith("https://w3id.org/nfex#measurement_") for x in reports)
