"""Evidence: the graph's Measurements as readers use them — read once (observations) and carried from version
to version (index), admitted by the trust rule (trust), grouped per reader (groups), aggregated robustly
(aggregate), and viewed by the SPARQL pruning rules (view)."""
from __future__ import annotations

from .aggregate import ROBUST, Aggregate, robust
from .observations import Observation, read_observations
from .trust import Admission, TrustPolicy, admit, admitted

__all__ = ["ROBUST", "Admission", "Aggregate", "Observation", "TrustPolicy", "admit", "admitted",
           "read_observations", "robust"]
