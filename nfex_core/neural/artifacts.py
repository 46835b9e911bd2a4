"""A trained model as a versioned folder: what the advisor loads, without torch.

    <dir>/manifest.json   format, version, created, code (nfex version, git commit), data (path, sha256,
                          rows, windows, split), training (optimizer, lr, batch, epochs), metrics
                          (validation loss/accuracy), input vocabulary (from the graph), stats scaler
    <dir>/paramnet.npz    ParamNet weights (torch layout)
    <dir>/selectornet.npz SelectorNet weights (torch layout)

``check(vocab)`` compares the stored input vocabulary with the live graph's: any difference means the
inputs would be misread, and the advisor falls back to the symbolic g(Θ, E) and says why.
"""
from __future__ import annotations

import hashlib
import json
import subprocess
import time
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..kg.vocabulary.vocab import Vocabulary
from .encoding import InputVocabulary, Scaler
from .paramnet import ParamNet
from .selectornet import SelectorNet

FORMAT = "nfex-model/1"
MANIFEST = "manifest.json"


@dataclass
class NeuralModel:
    inputs: InputVocabulary
    scaler: Scaler
    paramnet: ParamNet | None
    selectornet: SelectorNet | None
    manifest: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    @property
    def version(self) -> str:
        return str(self.manifest.get("version", "unsaved"))

    @cached_property
    def trained_params(self) -> frozenset[str]:
        """ParamNet outputs that had a training target (all, for a manifest that does not say)."""
        listed = self.manifest.get("paramnet_trained")
        return frozenset(listed if listed is not None else (p.qualified for p in self.inputs.params))

    @cached_property
    def context_seen(self) -> dict[str, frozenset[str]] | None:
        """Per dimension, the values the training windows had (None: the manifest does not say)."""
        seen = self.manifest.get("context_seen")
        return {d: frozenset(v) for d, v in seen.items()} if seen is not None else None

    @cached_property
    def selector_extractors(self) -> frozenset[str]:
        """Extractors SelectorNet saw measured in training (all, for a manifest that does not say)."""
        listed = self.manifest.get("selectornet_extractors")
        return frozenset(listed if listed is not None else self.inputs.extractors)

    @cached_property
    def grid(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Output index → (normalised, actual) values the sweep measured for that parameter (at 640×480
        for count parameters); ParamNet's outputs snap to the nearest. Absent: no snapping."""
        listed = self.manifest.get("paramnet_grid") or {}
        out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        for i, p in enumerate(self.inputs.params):
            values = sorted(float(v) for v in listed.get(p.qualified, ()))
            if values:
                out[i] = (np.array([p.to_unit(v) for v in values]), np.array(values))
        return out

    def validation_gates(self) -> dict[str, str]:
        """The networks that did not beat every baseline of their validation (``validation``), with the numbers.

        ParamNet needs a lower MSE than the best constant and the lookup by condition labels; SelectorNet a
        higher accuracy *and* a lower regret than both. A tie counts against the network: one only as good
        as a constant has learned nothing a config file does not say. A network validated before these
        baselines existed (only against the training majority or mean) is not used either
        (tests/nfex_core/neural/test_artifacts.py)."""
        m = self.manifest.get("metrics") or {}
        out: dict[str, str] = {}
        pn, sn = m.get("paramnet") or {}, m.get("selectornet") or {}
        if self.paramnet is not None:
            base = {n: pn[k] for n, k in (("the best constant", "val_mse_best_constant"), ("the lookup", "val_mse_lookup")) if k in pn}
            if "val_mse" not in pn or not base:
                out["paramnet"] = "not validated against a constant predictor and the lookup (train it again)"
            elif pn["val_mse"] >= min(base.values()):
                name = min(base, key=lambda n: base[n])
                out["paramnet"] = f"validation MSE {pn['val_mse']} >= {base[name]} of {name}"
        if self.selectornet is not None:
            keys = ("val_accuracy_best_constant", "val_regret_best_constant", "val_accuracy_lookup", "val_regret_lookup")
            if "val_accuracy" not in sn or any(k not in sn for k in keys):
                out["selectornet"] = "not validated against a constant predictor and the lookup (train it again)"
            else:
                acc = max(sn["val_accuracy_best_constant"], sn["val_accuracy_lookup"])
                reg = min(sn["val_regret_best_constant"], sn["val_regret_lookup"])
                if sn["val_accuracy"] <= acc or sn["val_regret"] >= reg:
                    out["selectornet"] = (
                        f"validation accuracy {sn['val_accuracy']} and regret {sn['val_regret']} against the best constant "
                        f"({sn.get('best_constant')}: {sn['val_accuracy_best_constant']}, {sn['val_regret_best_constant']}) "
                        f"and the lookup ({sn['val_accuracy_lookup']}, {sn['val_regret_lookup']}): it must beat both on both"
                    )
        return out

    def check(self, vocab: Vocabulary) -> str | None:
        """None when the graph's vocabulary is the one the model was trained on; else the reason it is not."""
        return self.inputs.mismatch(InputVocabulary.from_vocabulary(vocab))

    def info(self) -> dict[str, Any]:
        return {
            "name": self.path.name if self.path else None,
            "version": self.version,
            "data_sha256": self.manifest.get("data", {}).get("sha256"),
            "git_commit": self.manifest.get("code", {}).get("git_commit"),
        }

    def save(self, path: Path) -> Path:
        path.mkdir(parents=True, exist_ok=True)
        manifest = dict(self.manifest)
        manifest.update(format=FORMAT, inputs=self.inputs.as_dict(), scaler=self.scaler.as_dict())
        if self.paramnet is not None:
            np.savez_compressed(path / "paramnet.npz", **self.paramnet.weights)  # type: ignore[arg-type]
        if self.selectornet is not None:
            np.savez_compressed(path / "selectornet.npz", **self.selectornet.weights)  # type: ignore[arg-type]
        (path / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")
        self.manifest, self.path = manifest, path
        return path

    @classmethod
    def load(cls, path: Path) -> NeuralModel:
        manifest = json.loads((path / MANIFEST).read_text())
        if manifest.get("format") != FORMAT:
            raise ValueError(f"{path}: not an nFEX model (format {manifest.get('format')!r}, expected {FORMAT})")

        def weights(name: str) -> dict[str, np.ndarray] | None:
            f = path / name
            if not f.exists():
                return None
            with np.load(f) as z:
                return {k: z[k] for k in z.files}

        pw, sw = weights("paramnet.npz"), weights("selectornet.npz")
        return cls(
            inputs=InputVocabulary.from_dict(manifest["inputs"]),
            scaler=Scaler.from_dict(manifest["scaler"]),
            paramnet=ParamNet(pw) if pw is not None else None,
            selectornet=SelectorNet(sw) if sw is not None else None,
            manifest=manifest,
            path=path,
        )


def find_model(models: Path, name: str = "default") -> Path | None:
    """``models/<name>`` when it holds a manifest (or ``models`` itself when it is a model folder)."""
    for p in (models / name, models):
        if (p / MANIFEST).is_file():
            return p
    return None


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def code_version() -> dict[str, Any]:
    from .. import __version__

    repo = Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(
            ["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        dirty = bool(
            subprocess.run(["git", "-C", str(repo), "status", "--porcelain", "nfex_core"], capture_output=True, text=True, timeout=10).stdout.strip()
        )
    except (OSError, subprocess.SubprocessError):
        commit, dirty = None, None
    return {"nfex": __version__, "git_commit": commit, "dirty": dirty}


def new_version(data_sha: str) -> str:
    return time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-" + data_sha[:8]
