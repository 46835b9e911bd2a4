"""The neural part's costs (the paper's Table V: load 1,800 ms, Θ′ 5.49 µs, α 4.37 µs), in one run.

    python bench/bench_neural.py [--models models] [--calls 20000] [--repeat 5]

Prints: model load time (NeuralModel.load, cold in a fresh process and warm in-process); ParamNet and
SelectorNet per-call inference (µs; the bare forward and the whole neural step the advisor runs);
and the process start-to-first-answer of ``nfex select --context agent=car`` against a bare
``python -c 'import torch'`` (median of --repeat fresh processes each), with their ratio.
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from nfex_core.knowledge import open_graph  # noqa: E402
from nfex_core.neural.artifacts import NeuralModel, find_model  # noqa: E402
from nfex_core.neural.selectornet import IMAGE_HW, numeric_input  # noqa: E402
from nfex_core.neural.serve import NeuralStep  # noqa: E402


def per_call_us(fn, calls: int) -> float:  # type: ignore[no-untyped-def]
    """Median of single-call times (robust to a shared, busy host), µs."""
    fn()
    times = np.empty(calls)
    clock = time.perf_counter
    for i in range(calls):
        t = clock()
        fn()
        times[i] = clock() - t
    return float(np.median(times) * 1e6)


def wall(cmd: list[str], repeat: int, env: dict[str, str] | None = None) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, env=env, cwd=REPO)
        times.append((time.perf_counter() - t) * 1000)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", type=Path, default=REPO / "models")
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    path = find_model(args.models)
    if path is None:
        sys.exit(f"no model under {args.models} (train one: nfex train --table …)")

    load_code = (
        "import time; t0=time.perf_counter(); from pathlib import Path; from nfex_core.neural.artifacts import NeuralModel; "
        f"t1=time.perf_counter(); NeuralModel.load(Path({str(path)!r})); t2=time.perf_counter(); print((t1-t0)*1000, (t2-t1)*1000)"
    )
    runs = [
        [float(v) for v in subprocess.run([sys.executable, "-c", load_code], capture_output=True, text=True, check=True, cwd=REPO).stdout.split()]
        for _ in range(args.repeat)
    ]
    imp, cold = statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)
    warm = per_call_us(lambda: NeuralModel.load(path), 50) / 1000
    model = NeuralModel.load(path)
    print(f"model {path} ({sum(f.stat().st_size for f in path.iterdir()) / 1024:.1f} KiB), version {model.version}")
    print(f"model load, first in a fresh process  {cold:9.2f} ms   paper: 1800 ms   ratio paper/ours {1800 / cold:7.0f}×")
    print(f"  (+ importing nfex_core.neural and the graph code it needs: {imp:.0f} ms, paid by any nfex process)")
    print(f"model load, again in a warm process   {warm:9.3f} ms")

    store = tempfile.mkdtemp(prefix="nfex-bench-") + "/store"
    kg = open_graph(store)
    vocab = kg.vocabulary()
    kg.close()
    bad = model.check(vocab)
    if bad:
        print(f"note: {bad} (timings below are still valid)")
    assert model.paramnet is not None and model.selectornet is not None
    rng = np.random.default_rng(0)
    x = rng.normal(size=model.paramnet.n_inputs).astype(np.float32)
    ctx = {"agent": "car", "light": "dark"}
    stats = {k: float(v) for k, v in zip(model.scaler.keys, model.scaler.mean, strict=True)}
    step = NeuralStep(model, True, True)
    spec = vocab.extractor("ORB")

    def paramnet_step() -> None:
        step.prepare(ctx, stats)
        for s in vocab.extractors.values():
            step.params(s, 1241 * 376)

    p_fwd = per_call_us(lambda: model.paramnet.forward(x), args.calls)  # type: ignore[union-attr]
    p_step = per_call_us(paramnet_step, max(1, args.calls // 10))
    p_one = per_call_us(lambda: step.params(spec, 1241 * 376), args.calls // 4)
    print(f"ParamNet forward                      {p_fwd:9.2f} µs   paper: 5.49 µs   goal < 20 µs")
    print(f"ParamNet step (encode E+s, forward, Θ′ clamped for 4 extractors) {p_step:7.2f} µs   (one extractor's Θ′ {p_one:.2f} µs)")

    img = rng.uniform(size=IMAGE_HW).astype(np.float32)
    num = numeric_input(np.zeros(model.inputs.context_size, np.float32), np.zeros(len(model.scaler.keys), np.float32), True, {}, model.inputs.extractors, model.inputs.metrics)
    s_fwd = per_call_us(lambda: model.selectornet.logits(img, num), args.calls // 10)  # type: ignore[union-attr]
    frame = (rng.uniform(size=(376, 1241)) * 255).astype(np.uint8)
    s_step = per_call_us(lambda: step.probabilities(frame, {}, ("ORB", "SIFT")), args.calls // 20)
    print(f"SelectorNet forward (48×160 CNN + MLP) {s_fwd:8.2f} µs   paper: 4.37 µs   goal < 1000 µs")
    print(f"SelectorNet step (resize a 1241×376 frame, forward, masked softmax) {s_step:7.2f} µs")

    import os

    env = {**os.environ, "PYTHONPATH": str(REPO), "NFEX_MODELS": str(args.models)}
    select = [sys.executable, "-m", "cli.main", "--store", store, "select", "--context", "agent=car"]
    cmds = {
        "both": (select, env),
        "symbolic": (select, {**env, "NFEX_NEURAL": "symbolic"}),
        "torch": ([sys.executable, "-c", "import torch"], None),
    }
    times: dict[str, list[float]] = {k: [] for k in cmds}
    for _ in range(args.repeat):  # interleaved, so a busy moment of the host hits all three alike
        for k, (cmd, e) in cmds.items():
            times[k].append(wall(cmd, 1, e))
    select_ms, symbolic_ms, torch_ms = (statistics.median(times[k]) for k in ("both", "symbolic", "torch"))
    print(f"process start → first answer, nfex select --context agent=car (NFEX_NEURAL=both){select_ms:8.1f} ms")
    print(f"process start → first answer, same with NFEX_NEURAL=symbolic               {symbolic_ms:8.1f} ms")
    print(f"process start → python -c 'import torch'                                  {torch_ms:8.1f} ms")
    print(f"ratio import torch / nfex select: {torch_ms / select_ms:.2f}×  (median of {args.repeat} fresh processes each)")


if __name__ == "__main__":
    main()
