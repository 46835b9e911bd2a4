"""``nfex select``: which extractor and parameters for a frame and a context, and why (DESIGN.md flow)."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from nfex_core.errors import BadInput, DataMissing

from .common import echo_json, open_kg, table

if TYPE_CHECKING:
    from nfex_core.advisor import Selection


def parse_context(text: str) -> dict[str, str]:
    """``agent=car,light=dark`` → {"agent": "car", "light": "dark"} (names are checked by the advisor)."""
    out: dict[str, str] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        key, sep, value = part.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise BadInput(f"--context expects dimension=value pairs separated by commas, e.g. agent=car,light=dark; got {part!r}")
        out[key.strip()] = value.strip()
    return out


def read_image(path: Path) -> Any:
    import cv2

    if not path.is_file():
        raise DataMissing(f"no image file {path}")
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise BadInput(f"{path} is not an image OpenCV can read")
    return image


def _because(citations: Any) -> str:
    return "; ".join(f"{c.label} [{c.rule.rsplit('#', 1)[-1]}]" for c in citations)


def render(sel: Selection) -> str:
    """The selection as text: choice, parameters with their reasons, context, candidates, pruned."""
    lines = [f"{sel.extractor}  ({sel.constructor or 'learned model'}, {sel.norm}; mode {sel.mode}; graph version {sel.versions['graph']})", "", "parameters:"]
    best = next(c for c in sel.candidates if c.extractor == sel.extractor)
    changed = {a.parameter: a for a in best.adjustments}
    for name, value in sel.params.items():
        a = changed.get(name)
        why = f"  ({a.before} × {a.factor:.3g}{' clamped' if a.clamped else ''}: {_because(a.citations)})" if a else ""
        lines.append(f"  {name} = {value}{why}")
    lines += ["", "context:"]
    ctx = [[e.dimension, e.value or "-", e.source + (f" ({e.confidence:.2f})" if e.source == "estimated" and e.confidence is not None else ""), e.evidence or ""] for e in sel.context]
    lines.append(table(["dimension", "value", "source", "evidence"], ctx))
    lines += ["", "candidates:"]
    rows = [
        [c.extractor, "-" if c.score is None else f"{c.score:.4f}", f"{c.bonus:g}", "" if c.keypoints is None else str(c.keypoints),
         "" if c.extraction_ms is None else f"{c.extraction_ms:.1f}"]
        for c in sel.candidates
    ]
    lines.append(table(["extractor", "score", "bonus", "keypoints", "ms"], rows))
    weights = [f"{m} × {f.value:g} ({_because(f.citations)})" for m, f in sel.weights.items() if f.citations]
    if weights:
        lines += ["", "metric weights h_x(E):", *(f"  {w}" for w in weights)]
    if sel.pruned:
        lines += ["", "pruned:"]
        for p in sel.pruned:
            for c in p.because:
                src = f" [{c.source}]" if c.source else ""
                lines.append(f"  {p.extractor}: {c.reason} — rule {c.rule} \"{c.label}\"{src}")
    budget = sel.budget
    if budget:
        lines += ["", f"budget: {budget['ms']:g} ms per frame ({budget['source']}; compute {budget['compute']} ×{budget['factor']:g}; "
                      f"{budget['width']}×{budget['height']}, {budget['size_source']})"]
        lines += [f"  expected {c.extractor}: {c.evidence.cost.ms:.3f} ms ({c.evidence.cost.source})"
                  for c in sel.candidates if c.evidence.cost is not None and c.evidence.cost.ms is not None]
    for w in sel.warnings:
        lines.append(f"warning: {w}")
    return "\n".join(lines)


def select(
    frame: Annotated[Path | None, typer.Argument(help="An image (PNG, JPEG, …); without one the answer comes from the context alone.")] = None,
    context: Annotated[str, typer.Option("--context", "-c", help="What you know: dimension=value pairs, e.g. agent=car,light=dark.")] = "",
    previous: Annotated[Path | None, typer.Option("--previous", help="The frame before FRAME (enables the temporal metrics).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the full selection as JSON.")] = False,
) -> None:
    """Choose the extractor α* and its parameters Θ′ for FRAME and a context, with the reasons."""
    from nfex_core.advisor import Advisor

    given = parse_context(context)
    if previous is not None and frame is None:
        raise BadInput("--previous needs a FRAME")
    advisor = Advisor(open_kg())
    state = None
    if previous is not None:
        state = advisor.select(given, read_image(previous)).state
    sel = advisor.select(given, read_image(frame) if frame is not None else None, previous=state)
    if as_json:
        echo_json(sel.as_dict())
    else:
        typer.echo(render(sel))
