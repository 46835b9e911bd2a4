"""Evaluation: paired runs of every static method, nFEX, the motion-prior control and the hindsight oracles on one
or more sequences, under whole-sequence corruptions and condition schedules (abrupt or ramping), with the same
front-end checks for every method and each evaluated sequence held out of the evidence (``nfex evaluate``);
front-end figures (pose AUC, front-end ATE) first, monocular ATE beside, per sequence and pooled."""
from __future__ import annotations

from .methods import AdvisorChooser, DynChooser, chooser_for, known_methods, static_methods, tuned_static
from .pooled import Study, evaluate_sequences, pooled_json, study_json, study_markdown
from .report import as_json, csv_text, frames_csv, markdown, selections_csv
from .run import MOTION_PRIOR, SCHEDULE, Evaluation, RunRecord, evaluate

__all__ = ["MOTION_PRIOR", "SCHEDULE", "AdvisorChooser", "DynChooser", "Evaluation", "RunRecord", "Study", "as_json",
           "chooser_for", "csv_text", "evaluate", "evaluate_sequences", "frames_csv", "known_methods", "markdown",
           "pooled_json", "selections_csv", "static_methods", "study_json", "study_markdown", "tuned_static"]
