"""Sweeps: extractor × parameter grid × sequences × windows × corruptions, measured by the VO and
written to the graph (Measurements with provenance) and to the training table (paper §III-A-2)."""
from __future__ import annotations

from ..kg.identity import canonical
from .cells import Cell, run_cell
from .grid import PRESETS, grid
from .records import RunInfo, measurement_graph
from .runner import SweepSpec, export_measurements, plan, sweep

__all__ = ["Cell", "PRESETS", "RunInfo", "SweepSpec", "canonical", "export_measurements", "grid",
           "measurement_graph", "plan", "run_cell", "sweep"]
