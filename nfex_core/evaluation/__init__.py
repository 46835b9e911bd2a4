"""Evaluation: paired runs of every static method, nFEX and the hindsight oracles on a sequence, under
whole-sequence corruptions and condition schedules, with the same front-end checks for every method and
the evaluated sequence held out of the evidence (``nfex evaluate``)."""
from __future__ import annotations

from .methods import AdvisorChooser, DynChooser, chooser_for, known_methods, static_methods, tuned_static
from .report import as_json, csv_text, frames_csv, markdown, selections_csv
from .run import SCHEDULE, Evaluation, RunRecord, evaluate

__all__ = ["SCHEDULE", "AdvisorChooser", "DynChooser", "Evaluation", "RunRecord", "as_json", "chooser_for", "csv_text",
           "evaluate", "frames_csv", "known_methods", "markdown", "selections_csv", "static_methods", "tuned_static"]
