"""Settings of the core library, read from ``NFEX_*`` environment variables.

The service extends these with its HTTP settings (``service/config.py``); the CLI uses them as is.

| variable      | meaning                                                        | default                         |
|---------------|----------------------------------------------------------------|---------------------------------|
| NFEX_STORE    | a folder (embedded Oxigraph store) or an http(s) SPARQL URL    | ``$XDG_DATA_HOME/nfex/store``   |
| NFEX_HOME     | the folder holding ``ontology/`` and ``rules/``                | the repository of this checkout |
| NFEX_DATA     | the datasets folder (KITTI, EuRoC, handheld, trajectories)     | ``$NFEX_HOME/../shared/data``   |
| NFEX_MODELS   | the trained-model folder                                       | ``$NFEX_HOME/models``           |
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent


def _default_store() -> str:
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return str(Path(base) / "nfex" / "store")


@dataclass(frozen=True)
class Settings:
    store: str
    home: Path
    data: Path
    models: Path

    @classmethod
    def from_env(cls) -> Settings:
        home = Path(os.environ.get("NFEX_HOME") or REPO_ROOT)
        return cls(
            store=os.environ.get("NFEX_STORE") or _default_store(),
            home=home,
            data=Path(os.environ.get("NFEX_DATA") or home.parent / "shared" / "data"),
            models=Path(os.environ.get("NFEX_MODELS") or home / "models"),
        )

    @property
    def ontology_dir(self) -> Path:
        return self.home / "ontology"

    @property
    def rules_dir(self) -> Path:
        return self.home / "rules"
