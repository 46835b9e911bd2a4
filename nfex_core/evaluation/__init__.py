"""Evaluation: the paper's Table I (Mean ATE of ORB/SIFT default and dynamic, and nFEX) on a sequence,
with cost per frame, written as Markdown, CSV, JSON and plots (``nfex evaluate``)."""
from __future__ import annotations

from .methods import METHODS, AdvisorChooser, best_params, chooser_for
from .report import as_json, csv_text, markdown, selections_csv
from .run import Evaluation, RunRecord, evaluate

__all__ = ["METHODS", "AdvisorChooser", "Evaluation", "RunRecord", "as_json", "best_params", "chooser_for",
           "csv_text", "evaluate", "markdown", "selections_csv"]
