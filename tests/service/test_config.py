"""The service's settings are nFEX's one Settings with its HTTP fields added: one class, one prefix, one pass."""
from __future__ import annotations

from pathlib import Path

import pytest

from nfex_core.config import Settings as CoreSettings
from nfex_core.errors import BadInput
from service.config import Settings


def test_the_service_settings_are_the_core_settings_extended(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("NFEX_STORE", str(tmp_path / "store"))
    monkeypatch.setenv("NFEX_MAX_SESSIONS", "9")
    monkeypatch.setenv("NFEX_COMPILED_CACHE", "none")
    s = Settings()
    assert isinstance(s, CoreSettings)  # handed to the core as it is
    assert s.store == str(tmp_path / "store") and s.max_sessions == 9 and s.compiled_cache is None
    core = CoreSettings.from_env()
    assert {f: getattr(s, f) for f in CoreSettings.model_fields} == core.model_dump()
    assert set(CoreSettings.model_fields) < set(Settings.model_fields)


def test_a_bad_service_variable_stops_start_up_naming_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NFEX_MAX_SESSIONS", "many")
    with pytest.raises(BadInput, match="NFEX_MAX_SESSIONS"):
        Settings()
    monkeypatch.delenv("NFEX_MAX_SESSIONS")
    assert Settings(max_sessions=3).replace(port=9).max_sessions == 3
