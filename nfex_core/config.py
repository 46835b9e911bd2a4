"""Settings of the core library, read from ``NFEX_*`` environment variables.

The service extends these with its HTTP settings (``service/config.py``); the CLI uses them as is.

| variable      | meaning                                                        | default                         |
|---------------|----------------------------------------------------------------|---------------------------------|
| NFEX_STORE    | a folder (embedded Oxigraph store) or an http(s) SPARQL URL    | ``$XDG_DATA_HOME/nfex/store``   |
| NFEX_HOME     | the folder holding ``ontology/``, ``rules/`` and ``models/``   | ``default_home()``              |
| NFEX_DATA     | the datasets folder (KITTI, EuRoC, handheld, trajectories)     | ``$NFEX_HOME/../shared/data``   |
| NFEX_MODELS   | the trained-model folder                                       | ``$NFEX_HOME/models``           |
| NFEX_STORE_UPDATE   | a SPARQL server's update endpoint                        | the query URL's last segment → ``update`` |
| NFEX_STORE_USER, NFEX_STORE_PASSWORD | credentials for the SPARQL server (Basic or Digest, as it asks) | none |
| NFEX_STORE_GRAPH    | the named graph holding the knowledge (servers whose default graph is the union of all graphs) | the default graph |
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
"""The repository root when nFEX runs from a checkout (``python -m``, an editable install)."""
SHIPPED_HOME = Path(__file__).resolve().parent / "_home"
"""``ontology/``, ``rules/`` and ``models/`` as a wheel ships them (pyproject's force-include); absent in a checkout."""


def default_home() -> Path:
    """Where the ontology, rules and models come from unless ``NFEX_HOME`` says: the copy an installed wheel
    ships, else this checkout. Every reader goes through ``Settings.home`` (and the DSL grammar through this)."""
    return SHIPPED_HOME if SHIPPED_HOME.is_dir() else REPO_ROOT


def _default_store() -> str:
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return str(Path(base) / "nfex" / "store")


@dataclass(frozen=True)
class Settings:
    store: str
    home: Path
    data: Path
    models: Path
    store_update: str | None = None
    store_user: str | None = None
    store_password: str | None = None
    store_graph: str | None = None

    @classmethod
    def from_env(cls) -> Settings:
        home = Path(os.environ.get("NFEX_HOME") or default_home())
        return cls(
            store=os.environ.get("NFEX_STORE") or _default_store(),
            home=home,
            data=Path(os.environ.get("NFEX_DATA") or home.parent / "shared" / "data"),
            models=Path(os.environ.get("NFEX_MODELS") or home / "models"),
            store_update=os.environ.get("NFEX_STORE_UPDATE") or None,
            store_user=os.environ.get("NFEX_STORE_USER") or None,
            store_password=os.environ.get("NFEX_STORE_PASSWORD") or None,
            store_graph=os.environ.get("NFEX_STORE_GRAPH") or None,
        )

    @property
    def ontology_dir(self) -> Path:
        return self.home / "ontology"

    @property
    def rules_dir(self) -> Path:
        return self.home / "rules"
