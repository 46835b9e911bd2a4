"""Service settings, from ``NFEX_*`` environment variables (pydantic-settings)."""
from __future__ import annotations

from pydantic_settings import BaseSettings, SettingsConfigDict

from nfex_core.config import Settings as CoreSettings


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="NFEX_", extra="ignore")

    store: str | None = None
    """A folder (embedded Oxigraph store) or an http(s) SPARQL endpoint shared by several nodes."""
    host: str = "127.0.0.1"
    port: int = 8000
    log_level: str = "info"

    def core(self) -> CoreSettings:
        core = CoreSettings.from_env()
        if self.store:
            from dataclasses import replace

            core = replace(core, store=self.store)
        return core
