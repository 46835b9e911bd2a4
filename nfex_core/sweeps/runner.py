"""Running a sweep: cells on a local process pool (default) or a Ray cluster, resumable, with a
progress bar, rows appended to the training table and committed to the graph in batches.

Resuming: the table is the record of what is finished — cells whose key is already in it are skipped,
and rows in the table but not yet in the graph (a sweep killed between the two writes) are committed
first. Each batch is one graph transaction (SHACL-checked, one version).
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nfex_slam.datasets.schedule import Schedule

from ..errors import BadInput
from ..kg.identity import canonical, measurement_iri
from ..kg.namespaces import PREFIXES
from ..rules.motion import load_step_checks
from .cells import Cell, init_worker, run_cell
from .grid import grid
from .records import RunInfo, measurement_graph
from .table import label as table_label
from .table import pairs_path, write_pairs
from .table import read as read_table
from .table import write as write_table

if TYPE_CHECKING:
    from ..kg.store import KnowledgeGraph


@dataclass(frozen=True)
class SweepSpec:
    """What to sweep: data × windows × corruptions × extractors × parameter sets."""

    path: str
    format: str
    sequences: tuple[str, ...]
    extractors: tuple[str, ...]
    window: int = 20
    stride: int = 50
    max_windows: int | None = None
    corruptions: tuple[str, ...] = ("none",)
    severity: float = 0.7
    seed: int = 0
    severities: tuple[float, ...] = ()  # every corruption at each of these (default: ``severity``)
    schedules: tuple[str, ...] = ()  # condition schedules over each whole sequence (datasets.schedule)
    checks: bool = True  # the front-end checks of each sequence's agent, from the graph (motion.py)
    sample: int | None = None  # parameter sets per extractor (None: the whole grid)
    grids: Mapping[str, Mapping[str, list[Any]]] = field(default_factory=dict)


def plan(spec: SweepSpec, kg_vocab: Any, lengths: Mapping[str, int],
         checks: Mapping[str, tuple[float | None, float | None]] | None = None) -> list[Cell]:
    """Every cell of the sweep, ordered window-major so that workers share decoded windows; ``checks``:
    per sequence, the front-end limits of its agent."""
    severities = spec.severities or (spec.severity,)
    conditions = [(c, sv, "") for c in spec.corruptions for sv in (severities if c != "none" else (0.0,))]
    conditions += [("schedule", sv, text) for text in spec.schedules for sv in severities]
    configs = {
        x: [canonical(p) for p in grid(kg_vocab.extractor(x), spec.grids.get(x), spec.sample, spec.seed)]
        for x in spec.extractors
    }
    cells: list[Cell] = []
    for s in spec.sequences:
        n = lengths[s]
        starts = list(range(0, max(n - spec.window, 0) + 1, spec.stride))[: spec.max_windows]
        if not starts:
            raise BadInput(f"sequence {s} has {n} frames, fewer than one window of {spec.window}")
        limits = (checks or {}).get(s, (None, None))
        for c, sv, text in conditions:
            for start in starts:
                for x in spec.extractors:
                    for params in configs[x]:
                        cells.append(Cell(spec.format, spec.path, s, c, sv, spec.seed, start, start + spec.window, x,
                                          params, text, limits))
    return cells


def _local(cells: list[Cell], specs: Mapping[str, Any], workers: int) -> Iterator[dict[str, Any]]:
    if workers <= 1:
        init_worker(specs)
        for c in cells:
            yield run_cell(c)
        return
    import multiprocessing as mp

    ctx = mp.get_context("spawn")  # fresh interpreters: OpenCV and fork do not mix well
    with ctx.Pool(workers, initializer=init_worker, initargs=(dict(specs),)) as pool:
        yield from pool.imap_unordered(run_cell, cells, chunksize=1)


def _ray(cells: list[Cell], specs: Mapping[str, Any], address: str | None, workers: int) -> Iterator[dict[str, Any]]:
    try:
        import ray
    except ImportError:
        raise BadInput("--executor ray needs Ray: pip install 'nfex[ray]'") from None
    started = not ray.is_initialized()
    if started:
        ray.init(address=address, num_cpus=None if address else workers, include_dashboard=False,
                 ignore_reinit_error=True, log_to_driver=False)
    try:
        task = ray.remote(num_cpus=1)(run_cell)
        ref = ray.put(dict(specs))
        pending = [task.remote(c, ref) for c in cells]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        if started:
            ray.shutdown()


def sweep(
    spec: SweepSpec,
    kg: KnowledgeGraph,
    csv_path: Path,
    *,
    run: RunInfo,
    executor: str = "local",
    workers: int = 2,
    address: str | None = None,
    batch: int = 32,
    author: str = "nfex sweep",
    progress: bool = True,
    on_batch: Callable[[int], None] | None = None,
) -> dict[str, int]:
    """Run the sweep; returns counts (cells planned, skipped as done, run, rows committed to the graph)."""
    from nfex_slam.datasets import open_sequence

    vocab = kg.vocabulary()
    for x in spec.extractors:
        vocab.extractor(x)
    opened = {s: open_sequence(spec.path, spec.format, s or None) for s in spec.sequences}
    lengths = {s: len(q) for s, q in opened.items()}
    for text in spec.schedules:
        for n in lengths.values():
            Schedule.parse(text, n)  # a schedule must cover each sequence: fail before any cell runs
    limits: dict[str, tuple[float | None, float | None]] = {}
    if spec.checks:
        table = load_step_checks(kg)
        for s, q in opened.items():
            c = table.get(q.context.get("agent", ""))
            if c is not None:
                limits[s] = (c.max_rotation_rate, c.max_heading_change_rate)
    cells = plan(spec, vocab, lengths, limits)
    rows: list[dict[str, Any]] = [dict(r) for r in read_table(csv_path)]
    done = {r["cell"] for r in rows}
    todo = [c for c in cells if c.key not in done]
    committed = _sync_graph(kg, rows, vocab, run, author, batch)
    specs = {x: vocab.extractor(x) for x in spec.extractors}
    stream: Iterable[dict[str, Any]] = (
        _ray(todo, specs, address, workers) if executor == "ray" else _local(todo, specs, workers)
    )
    if progress and todo:
        from tqdm import tqdm

        stream = tqdm(stream, total=len(todo), desc="sweep", unit="cell", smoothing=0.05)
    pending: list[dict[str, Any]] = []
    for row in stream:
        pending.append(row)
        if len(pending) >= batch:
            committed += _flush(kg, csv_path, rows, pending, vocab, run, author)
            if on_batch is not None:
                on_batch(len(rows))
    committed += _flush(kg, csv_path, rows, pending, vocab, run, author)
    write_table(csv_path, table_label(rows))
    return {"cells": len(cells), "skipped": len(cells) - len(todo), "ran": len(todo), "committed": committed}


def _flush(kg: KnowledgeGraph, csv_path: Path, rows: list[dict[str, Any]], pending: list[dict[str, Any]],
           vocab: Any, run: RunInfo, author: str) -> int:
    """Table first (the record of what is done), then one graph transaction for the batch."""
    if not pending:
        return 0
    write_pairs(pairs_path(csv_path), [p for r in pending for p in r.pop("_pairs", [])])
    rows.extend(pending)
    write_table(csv_path, rows)
    n = len(pending)
    _replace(kg, pending, vocab, run, author, f"sweep {run.id}: {n} measurements")
    pending.clear()
    return n


def _replace(kg: KnowledgeGraph, rows: Sequence[dict[str, Any]], vocab: Any, run: RunInfo, author: str, message: str) -> None:
    """One transaction: the rows' Measurements replace any earlier ones of the same cells (a re-measured
    cell must not carry two values of a functional property)."""
    from ..kg.changes import ChangeSet, graph_triples

    iris = " ".join(f"<{measurement_iri(str(r['cell']))}>" for r in rows)
    old = kg.construct(
        f"""CONSTRUCT {{ ?m ?p ?o . ?r ?rp ?ro }} WHERE {{ VALUES ?m {{ {iris} }}
            {{ ?m ?p ?o }} UNION {{ ?m nfex:hasMetricResult ?r . ?r ?rp ?ro }} }}"""
    )
    new = graph_triples(measurement_graph(rows, vocab, run))
    kg.commit(ChangeSet.of(added=new, removed=graph_triples(old) - new), author=author, message=message)


def _sync_graph(kg: KnowledgeGraph, rows: Sequence[dict[str, Any]], vocab: Any, run: RunInfo, author: str,
                batch: int) -> int:
    """Commit table rows the graph lacks (a sweep killed between its two writes)."""
    if not rows:
        return 0
    have = {str(r["m"]) for r in kg.select("SELECT ?m WHERE { ?m a nfex:Measurement }").rows}
    missing = [r for r in rows if str(measurement_iri(r["cell"])) not in have]
    for i in range(0, len(missing), batch):
        part = missing[i : i + batch]
        _replace(kg, part, vocab, run, author, f"sweep {run.id}: {len(part)} measurements (resumed)")
    return len(missing)


def export_measurements(kg: KnowledgeGraph, path: Path, cells: Iterable[str] | None = None) -> int:
    """Write the graph's measurements (only those of ``cells``, a table's ``cell`` column, when given), with their
    configurations, runs and machines; returns the triples. ``.nt`` writes N-Triples, anything else Turtle,
    and a trailing ``.gz`` compresses (``dense.nt.gz``: the compact form for a large bundle)."""
    only = ""
    if cells is not None:
        only = "VALUES ?m { " + " ".join(f"<{measurement_iri(c)}>" for c in sorted(set(cells))) + " }"
    branches = ("BIND(?m AS ?s)", "?m nfex:hasMetricResult ?s", "?m sosa:usedProcedure ?s", "?m sosa:usedProcedure/nfex:hasSetting ?s",
                "?m prov:wasGeneratedBy ?s", "?m prov:wasGeneratedBy/prov:wasAssociatedWith ?s", "?m nfex:sequence ?s",
                "?m nfex:sequence/nfex:inDataset ?s", "?m nfex:corruption ?s")  # fmt: skip
    union = "\n        UNION ".join(f"{{ ?m a nfex:Measurement . {b} }}" for b in branches)
    g = kg.construct(f"CONSTRUCT {{ ?s ?p ?o }} WHERE {{\n        {only}\n        {union}\n        ?s ?p ?o }}")
    for p in ("nfex", "sosa", "prov", "xsd"):
        g.bind(p, PREFIXES[p])
    path.parent.mkdir(parents=True, exist_ok=True)
    zipped = path.suffix == ".gz"
    nt = (Path(path.stem) if zipped else path).suffix == ".nt"
    body = g.serialize(format="nt" if nt else "turtle")
    if not nt:
        body = "# Generated by `nfex sweep` (nfex_core/sweeps): measured performance with provenance. Do not edit.\n" + body
    if zipped:
        import gzip

        path.write_bytes(gzip.compress(body.encode(), mtime=0))
    else:
        path.write_text(body)
    return len(g)


__all__ = ["SweepSpec", "export_measurements", "plan", "sweep"]
