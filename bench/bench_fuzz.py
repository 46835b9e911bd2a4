"""Fuzz the whole OpenAPI surface of a running service with schemathesis, bounded in time, and count
what came back: no 5xx and no error that is not RFC 9457 problem+json may appear.

    python bench/bench_fuzz.py [--max-time 300] [--seed 16] [--token-role editor]

Starts `nfex serve` (one uvicorn worker) on a fresh embedded store seeded from ontology/ and rules/ in a
temporary folder, then runs ``st run`` over ``/openapi.json`` — phases examples, coverage, fuzzing,
positive and negative data, one worker — with a bearer token of ``--token-role`` on every request (so
the write endpoints are exercised past authentication; the service's SHACL checks and the core shape
keep the graph whole). Every request and response goes to a HAR file, which this script reads back:
requests per operation and status, 5xx, and ≥ 400 responses whose Content-Type is not
``application/problem+json``. Exits 1 on any finding; schemathesis's own check (``not_a_server_error``)
agrees. Figures in docs/service.md ("Fuzzing").
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import httpx
from _timing import free_port  # noqa: E402  (bench/ is the script's folder, first on sys.path)

ROOT = Path(__file__).resolve().parent.parent
TOKEN = "fuzz-token-0123456789"


def start(store: Path, log: Path, role: str) -> tuple[subprocess.Popen[bytes], str]:
    port = free_port()
    env = {**os.environ, "NFEX_STORE": str(store), "NFEX_TOKENS": f"fuzz:{TOKEN}:{role}", "NFEX_LOG_LEVEL": "warning",
           "NFEX_SPARQL_TIMEOUT_S": "5", "NFEX_MAX_SESSIONS": "64", "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port)], cwd=ROOT, env=env,
                            stdout=log.open("wb"), stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    for _ in range(1200):
        if proc.poll() is not None:
            raise SystemExit(f"the service exited with {proc.returncode}; see {log}")
        try:
            if httpx.get(url + "/readyz", timeout=1).status_code == 200:
                return proc, url
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    raise SystemExit("the service did not become ready")


def analyse(har: Path) -> dict[str, object]:
    entries = json.loads(har.read_text())["log"]["entries"]
    statuses: Counter[int] = Counter()
    per_route: Counter[str] = Counter()
    server_errors: list[str] = []
    not_problem: list[str] = []
    for e in entries:
        req, resp = e["request"], e["response"]
        status = int(resp["status"])
        statuses[status] += 1
        path = req["url"].split("?", 1)[0].split("/", 3)[-1]
        per_route[f"{req['method']} /{path.split('/')[0]}"] += 1
        ctype = next((h["value"] for h in resp["headers"] if h["name"].lower() == "content-type"), "")
        where = f"{req['method']} {req['url'][:160]} -> {status} {ctype}"
        if status >= 500:
            server_errors.append(where + " " + str(resp.get("content", {}).get("text", ""))[:200])
        elif status >= 400 and not ctype.startswith("application/problem+json"):
            not_problem.append(where)
    return {"requests": len(entries), "statuses": dict(sorted(statuses.items())), "server_errors": server_errors,
            "not_problem_json": not_problem, "by_resource": dict(per_route.most_common())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--max-time", type=int, default=300, help="seconds for the whole schemathesis run")
    ap.add_argument("--seed", type=int, default=16)
    ap.add_argument("--max-examples", type=int, default=50, help="test cases per operation and phase")
    ap.add_argument("--token-role", default="editor", choices=["reader", "reporter", "editor"])
    ap.add_argument("--keep", type=Path, help="keep the HAR and the service log in this folder")
    args = ap.parse_args()
    st = shutil.which("st") or str(Path(sys.executable).parent / "st")
    if not Path(st).exists():
        raise SystemExit("schemathesis is not installed (pip install -e '.[dev]')")
    work = Path(tempfile.mkdtemp(prefix="nfex-fuzz-"))
    out = args.keep or work
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    proc, url = start(work / "store", out / "service.log", args.token_role)
    ready_s = time.perf_counter() - t0
    try:
        t1 = time.perf_counter()
        run = subprocess.run(
            [st, "run", url + "/openapi.json", "--workers", "1", "--max-time", str(args.max_time), "--seed", str(args.seed),
             "--max-examples", str(args.max_examples), "--phases", "examples,coverage,fuzzing", "--mode", "all",
             "--checks", "not_a_server_error", "-H", f"Authorization: Bearer {TOKEN}", "--request-timeout", "30",
             "--generation-database", "none", "--report", "har", "--report-har-path", str(out / "fuzz.har"), "--no-color"],
            cwd=work, capture_output=True, text=True)
        fuzz_s = time.perf_counter() - t1
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    (out / "schemathesis.txt").write_text(run.stdout + run.stderr)
    found = analyse(out / "fuzz.har")
    tail = "\n".join(run.stdout.strip().splitlines()[-12:])
    print(f"service ready in {ready_s:.1f} s; schemathesis ran {fuzz_s:.0f} s (limit {args.max_time} s), exit {run.returncode}")
    print(tail)
    print(f"(schemathesis's full output: {out / 'schemathesis.txt'})")
    print(f"requests: {found['requests']}  statuses: {found['statuses']}")
    print(f"by resource: {found['by_resource']}")
    print(f"5xx: {len(found['server_errors'])}  errors without problem+json: {len(found['not_problem_json'])}")  # type: ignore[arg-type]
    for line in [*found["server_errors"], *found["not_problem_json"]][:20]:  # type: ignore[misc]
        print("  ", line)
    shutil.rmtree(work / "store", ignore_errors=True)
    return 1 if found["server_errors"] or found["not_problem_json"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
