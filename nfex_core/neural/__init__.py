"""The neural part (§IV-B): ParamNet for Θ′, SelectorNet for α*, served in NumPy (``serve``, ``artifacts``,
``encoding``, the nets' inference); trained with torch in ``training/``, which serving never imports."""
from __future__ import annotations

from .artifacts import NeuralModel
from .encoding import InputVocabulary, Scaler
from .paramnet import ParamNet
from .selectornet import SelectorNet

__all__ = ["InputVocabulary", "NeuralModel", "ParamNet", "Scaler", "SelectorNet"]
