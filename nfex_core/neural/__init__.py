"""The neural part (§IV-B): ParamNet for Θ′, SelectorNet for α*, trained with torch, served in NumPy."""
from __future__ import annotations

from .artifacts import NeuralModel
from .encoding import InputVocabulary, Scaler
from .paramnet import ParamNet
from .selectornet import SelectorNet

__all__ = ["InputVocabulary", "NeuralModel", "ParamNet", "Scaler", "SelectorNet"]
