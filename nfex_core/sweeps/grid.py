"""Parameter grids Θ for sweeps: named presets, or a full product of per-parameter values, or a sample.

The paper populates its graph "by running exhaustive combinations of feature extractors and their
parameters" (§III-A-2). A grid is the Cartesian product of value lists per tunable parameter; every
value is validated against the graph's range (``ExtractorSpec.resolve``), and the OpenCV default
configuration is always included so that "default" windows exist for every sweep.
"""
from __future__ import annotations

import itertools
import random
from collections.abc import Mapping

from ..kg.identity import canonical
from ..kg.vocab import ExtractorSpec, Value

# 24 configurations each (2·3·2·2 for ORB, 3·2·2·2 for SIFT), spanning the parameters the paper tunes:
# number of features (NF), scale factor / octave layers (SF/NL), and detector thresholds (ST).
PRESETS: dict[str, dict[str, list[Value]]] = {
    "ORB": {"nfeatures": [500, 1000, 2000], "scaleFactor": [1.2, 1.4], "nlevels": [4, 8], "fastThreshold": [10, 20]},
    "SIFT": {"nfeatures": [0, 1000, 2000], "contrastThreshold": [0.02, 0.04], "edgeThreshold": [10.0, 20.0],
             "nOctaveLayers": [3, 4]},
    # the grid-spread ORB (issue 8): the two parameters its cost depends on and the FAST threshold, 16
    # configurations; 3000 features because spreading them pays on wide road scenes (docs/cost.md)
    "ORB_GRID": {"nfeatures": [500, 1000, 2000, 3000], "nlevels": [4, 8], "fastThreshold": [10, 20]},
    "AKAZE": {"threshold": [0.0005, 0.001, 0.002], "nOctaves": [3, 4], "nOctaveLayers": [2, 4], "diffusivity": [1, 2]},
    "BRISK": {"thresh": [15, 30, 60], "octaves": [2, 3], "patternScale": [0.8, 1.0]},
    # XFeat (issue 15): its cost is the input scale's square; top_k 1024 against the authors' 4096
    "XFEAT": {"top_k": [1024, 4096], "input_scale": [0.5, 0.75, 1.0]},
}


def value_lists(spec: ExtractorSpec) -> dict[str, list[Value]]:
    """Values to sweep per parameter: the preset where one exists, else default ×{½, 1, 2} of each tunable one."""
    preset = {k: v for k, v in PRESETS.get(spec.name, {}).items() if v and k in spec.parameters}
    if preset:
        return preset
    out: dict[str, list[Value]] = {}
    for name, p in spec.parameters.items():
        if not p.tunable or p.datatype == "boolean" or p.allowed is not None:
            continue
        vals = {p.clamp(float(p.default) * f) for f in (0.5, 1.0, 2.0)} if p.default else {p.default}
        out[name] = sorted(vals)
    return out


def grid(spec: ExtractorSpec, values: Mapping[str, list[Value]] | None = None, sample: int | None = None,
         seed: int = 0) -> list[dict[str, Value]]:
    """Full parameter sets (defaults overridden) for the product of ``values``; the default set first.

    ``sample`` draws that many distinct sets (seeded) from the product, the default always among them.
    """
    values = dict(values) if values is not None else value_lists(spec)
    names = sorted(values)
    default = spec.resolve({})
    combos = [spec.resolve(dict(zip(names, combo, strict=True))) for combo in itertools.product(*(values[n] for n in names))]
    seen = {canonical(default)}
    out = [default]
    for c in combos:
        key = canonical(c)
        if key not in seen:
            seen.add(key)
            out.append(c)
    if sample is not None and sample < len(out):
        rest = out[1:]
        random.Random(seed).shuffle(rest)
        out = [default, *rest[: max(sample - 1, 0)]]
    return out
