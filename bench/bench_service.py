"""The HTTP service on loopback: /v1/select (context alone; with a 752×480 PNG) and SPARQL SELECT
against the same query on a side-by-side `oxigraph serve` holding the same data.

    python bench/bench_service.py [--n 2000] [--frames 200] [--concurrency 4]

SPARQL latencies alternate request by request between the two servers. Starts, in one run: the service (`nfex serve`, one uvicorn worker, embedded store seeded from
ontology/ and rules/) and `oxigraph serve` on a copy of the same store folder. Each measurement sends
--n sequential requests over one keep-alive connection after a warm-up and prints p50/p99 latency
and requests/s, then requests/s with --concurrency client threads. Baselines measured in the same
run: the advisor in-process (what HTTP adds to a selection) and Oxigraph's own server (the SPARQL
ratio). Logs at warning level (one JSON access line per request at info costs ~0.05 ms more).
"""
from __future__ import annotations

import argparse
import functools
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import httpx
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from _timing import call_ms  # noqa: E402

from nfex_core.advisor import Advisor  # noqa: E402
from nfex_core.advisor.scoring import SCORE_PIXELS  # noqa: E402
from nfex_core.config import Settings  # noqa: E402
from nfex_core.knowledge import open_graph  # noqa: E402

QUERY = """PREFIX nfex: <https://w3id.org/nfex#>
SELECT ?x ?p ?default WHERE { ?p a nfex:Parameter ; nfex:parameterOf ?x ; nfex:defaultValue ?default } ORDER BY ?x ?p"""
CONTEXT = {"agent": "car", "motion": "fast", "scene": "outdoor", "light": "bright"}
# frame requests: a drone carries its default 20 ms budget (ontology/cost.ttl), so only what fits is
# scored; a car has none, so every candidate the rules keep is scored (SelectorNet's first)
FRAME_AGENTS = {"drone": "drone (20 ms budget)", "car": "car (no budget)"}


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait(url: str, proc: subprocess.Popen) -> None:  # type: ignore[type-arg]
    for _ in range(600):
        if proc.poll() is not None:
            raise SystemExit(f"{proc.args} exited with {proc.returncode}")
        try:
            if httpx.get(url, timeout=1).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    raise SystemExit(f"{url} did not answer")


def timed(n: int, call: Callable[[], httpx.Response], warmup: int = 50) -> list[float]:
    for _ in range(warmup):
        r = call()
        r.raise_for_status()
    out = []
    for _ in range(n):
        t = time.perf_counter()
        r = call()
        out.append((time.perf_counter() - t) * 1000)
        if r.status_code != 200:
            raise SystemExit(f"{r.status_code}: {r.text[:300]}")
    return out


def throughput(make: Callable[[httpx.Client], Callable[[], httpx.Response]], base: str, threads: int, seconds: float = 3.0) -> float:
    count = [0] * threads
    stop = time.perf_counter() + seconds

    def worker(i: int) -> None:
        with httpx.Client(base_url=base) as c:
            call = make(c)
            while time.perf_counter() < stop:
                call().raise_for_status()
                count[i] += 1

    ts = [threading.Thread(target=worker, args=(i,)) for i in range(threads)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    return sum(count) / seconds


def row(name: str, ms: list[float], rps: float | None = None) -> None:
    ms = sorted(ms)
    p50, p99 = statistics.median(ms), ms[int(0.99 * (len(ms) - 1))]
    extra = f"  {rps:8.0f} req/s with threads" if rps is not None else ""
    print(f"{name:<44} p50 {p50:7.3f} ms  p99 {p99:7.3f} ms  {1000 / statistics.mean(ms):7.0f} req/s sequential{extra}")


def load_frame() -> np.ndarray:
    """A real 752×480 EuRoC frame (a textured synthetic one where the data folder is absent)."""
    frame_path = Settings.from_env().data / "euroc" / "V1_01_easy_micro" / "mav0" / "cam0" / "data"
    frames = sorted(frame_path.glob("*.png"))[:1]
    image = cv2.imread(str(frames[0]), cv2.IMREAD_GRAYSCALE) if frames else None
    if image is None:
        image = cv2.GaussianBlur(np.random.default_rng(0).integers(0, 255, (480, 752), dtype=np.uint8), (5, 5), 0)
    assert image.shape == (480, 752), image.shape
    return image


def interleaved(n: int, a: Callable[[], httpx.Response], b: Callable[[], httpx.Response]) -> tuple[list[float], list[float]]:
    """Latencies of a and b, alternating request by request, so machine load falls on both alike."""
    out_a: list[float] = []
    out_b: list[float] = []
    for call in (a, b):
        for _ in range(50):
            call().raise_for_status()
    for _ in range(n):
        for call, out in ((a, out_a), (b, out_b)):
            t = time.perf_counter()
            r = call()
            out.append((time.perf_counter() - t) * 1000)
            r.raise_for_status()
    return out_a, out_b


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--concurrency", type=int, default=4)
    args = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="nfex-bench-service-"))
    store = work / "store"
    kg = open_graph(str(store))
    kg.backend.flush()  # type: ignore[attr-defined]
    advisor = Advisor(kg)
    advisor.select(CONTEXT)
    _, in_process = call_ms(functools.partial(advisor.select, CONTEXT), args.n)
    image = load_frame()
    frame_in_process = {}
    for agent in FRAME_AGENTS:
        advisor.select({"agent": agent}, image)
        _, frame_in_process[agent] = call_ms(functools.partial(advisor.select, {"agent": agent}, image), max(5, args.frames // 10))
    # baseline: the car request scored on the copy the advisor used before (a 640-px longer side)
    wide = Advisor(kg, score_pixels=640 * 409)
    wide.select({"agent": "car"}, image)
    _, car_wide = call_ms(functools.partial(wide.select, {"agent": "car"}, image), max(5, args.frames // 10))
    kg.close()
    del kg, advisor, wide
    shutil.copytree(store, work / "oxigraph", ignore=shutil.ignore_patterns("LOCK"))

    port, oport = free_port(), free_port()
    env = dict(os.environ, NFEX_STORE=str(store), NFEX_LOG_LEVEL="warning", PYTHONPATH=str(ROOT))
    svc = subprocess.Popen([sys.executable, "-m", "nfex_core.cli.main", "serve", "--port", str(port), "--log-level", "warning"],
                           env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    exe = shutil.which("oxigraph") or str(Path(sys.executable).parent / "oxigraph")
    oxi = subprocess.Popen([exe, "serve", "--location", str(work / "oxigraph"), "--bind", f"127.0.0.1:{oport}"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    base, obase = f"http://127.0.0.1:{port}", f"http://127.0.0.1:{oport}"
    try:
        wait(base + "/readyz", svc)
        wait(obase + "/query?query=ASK%7B%7D", oxi)
        print(f"loopback, {os.cpu_count()} CPUs, {args.n} sequential requests per row (one keep-alive connection)")
        row("advisor.select in-process, context (baseline)", in_process)
        for agent in FRAME_AGENTS:
            row(f"advisor.select in-process, 752x480, {FRAME_AGENTS[agent]}", frame_in_process[agent])
        row("  baseline: car scored on a 640x409 copy", car_wide)
        print(f"  scoring on a QVGA copy ({640 * 409} -> {SCORE_PIXELS} px): car request "
              f"{statistics.median(car_wide) / statistics.median(frame_in_process['car']):.2f}x faster")

        def select_ctx(c: httpx.Client) -> Callable[[], httpx.Response]:
            return lambda: c.post("/v1/select", json={"context": CONTEXT})

        with httpx.Client(base_url=base) as c:
            row("POST /v1/select, context alone", timed(args.n, select_ctx(c)), throughput(select_ctx, base, args.concurrency))

        png = bytes(cv2.imencode(".png", image)[1])

        for agent, label in FRAME_AGENTS.items():
            def select_frame(c: httpx.Client, agent: str = agent) -> Callable[[], httpx.Response]:
                body = {"context": json.dumps({"agent": agent})}
                return lambda: c.post("/v1/select", files={"frame": ("f.png", png, "image/png")}, data=body)

            with httpx.Client(base_url=base, timeout=60) as c:
                row(f"POST /v1/select, 752x480 PNG ({len(png) // 1024} KiB), {label}", timed(args.frames, select_frame(c), warmup=5),
                    throughput(select_frame, base, args.concurrency))

        def ours(c: httpx.Client) -> Callable[[], httpx.Response]:
            return lambda: c.post("/sparql", content=QUERY, headers={"content-type": "application/sparql-query", "accept": "application/sparql-results+json"})

        def theirs(c: httpx.Client) -> Callable[[], httpx.Response]:
            return lambda: c.post("/query", content=QUERY, headers={"content-type": "application/sparql-query", "accept": "application/sparql-results+json"})

        with httpx.Client(base_url=base) as c, httpx.Client(base_url=obase) as o:
            assert c.post("/sparql", content=QUERY, headers={"content-type": "application/sparql-query"}).json()["results"] == \
                o.post("/query", content=QUERY, headers={"content-type": "application/sparql-query", "accept": "application/sparql-results+json"}).json()["results"]
            a, b = interleaved(args.n, ours(c), theirs(o))
            health = timed(args.n, lambda: c.get("/healthz"))
        ra, rb = throughput(ours, base, args.concurrency), throughput(theirs, obase, args.concurrency)
        row("GET /healthz (nFEX: the HTTP floor)", health)
        row("POST /sparql (nFEX), 26-row SELECT", a, ra)
        row("POST /query (oxigraph serve), same query", b, rb)
        print(f"SPARQL ratio nFEX / oxigraph serve: p50 latency {statistics.median(a) / statistics.median(b):.2f}x, "
              f"p99 {sorted(a)[int(0.99 * (len(a) - 1))] / sorted(b)[int(0.99 * (len(b) - 1))]:.2f}x, "
              f"throughput with threads {ra / rb:.2f}x (above 1: nFEX serves more)")
    finally:
        for p in (svc, oxi):
            p.terminate()
            p.wait(timeout=20)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
