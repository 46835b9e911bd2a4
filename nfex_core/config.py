"""Settings of the core library, read from ``NFEX_*`` environment variables in one place.

The service extends these with its HTTP settings (``service/config.py``); the CLI uses them as they are.
Nothing else in nFEX reads the environment: settings are passed down explicitly.

| variable            | meaning                                                          | default                         |
|---------------------|------------------------------------------------------------------|---------------------------------|
| NFEX_STORE          | a folder (embedded Oxigraph store) or an http(s) SPARQL URL      | ``$XDG_DATA_HOME/nfex/store``   |
| NFEX_HOME           | the folder holding ``ontology/`` and ``rules/``                  | the repository of this checkout |
| NFEX_DATA           | the datasets folder (KITTI, EuRoC, handheld, trajectories)       | ``$NFEX_HOME/../shared/data``   |
| NFEX_MODELS         | the trained-model folder                                         | ``$NFEX_HOME/models``           |
| NFEX_NEURAL         | symbolic, paramnet, selectornet or both (neural.serve)           | both                            |
| NFEX_SCORE_THREADS  | candidates extracted side by side when scoring a frame           | the CPU count, at most 8        |
| NFEX_AUTHOR         | the author recorded on CLI writes                                | ``<user> (cli)``                |
"""
from __future__ import annotations

import getpass
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent


def _default_store(env: Mapping[str, str]) -> str:
    base = env.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return str(Path(base) / "nfex" / "store")


@dataclass(frozen=True)
class Settings:
    store: str
    home: Path
    data: Path
    models: Path
    neural: str = "both"
    score_threads: int = 0  # 0: the CPU count, at most 8
    author: str = ""

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> Settings:
        env = os.environ if env is None else env
        home = Path(env.get("NFEX_HOME") or REPO_ROOT)
        return cls(
            store=env.get("NFEX_STORE") or _default_store(env),
            home=home,
            data=Path(env.get("NFEX_DATA") or home.parent / "shared" / "data"),
            models=Path(env.get("NFEX_MODELS") or home / "models"),
            neural=env.get("NFEX_NEURAL") or "both",
            score_threads=int(env.get("NFEX_SCORE_THREADS") or 0),
            author=env.get("NFEX_AUTHOR") or "",
        )

    @property
    def ontology_dir(self) -> Path:
        return self.home / "ontology"

    @property
    def rules_dir(self) -> Path:
        return self.home / "rules"

    @property
    def score_threads_or_cpus(self) -> int:
        return self.score_threads if self.score_threads > 0 else min(8, os.cpu_count() or 1)

    def author_or_user(self) -> str:
        """Who a CLI write is attributed to: NFEX_AUTHOR, else the user name."""
        return self.author or f"{getpass.getuser()} (cli)"
