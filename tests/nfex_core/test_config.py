"""nFEX's one Settings: read from NFEX_* (a given mapping or the process's environment), defaults derived from
the home and the XDG base directories, an unparsable value a BadInput naming its variable."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nfex_core.config import Settings, default_home
from nfex_core.errors import BadInput

BASE = {"HOME": "/h", "XDG_CACHE_HOME": "/c", "XDG_DATA_HOME": "/d"}


def test_unset_variables_take_defaults_derived_from_home_and_the_xdg_folders() -> None:
    s = Settings.from_env(dict(BASE, NFEX_HOME="/k/home"))
    assert s.home == Path("/k/home") and s.data == Path("/k/shared/data") and s.models == Path("/k/home/models")
    assert s.store == "/d/nfex/store"
    assert (s.learned_cache, s.seed_cache, s.compiled_cache) == (Path("/c/nfex/learned"), Path("/c/nfex/seed"),
                                                                Path("/c/nfex/compiled"))
    assert Settings.from_env(BASE).home == default_home()
    assert (s.neural, s.learned_runtime, s.learned_threads, s.score_all, s.store_graph) == ("both", "onnx", 2, False, None)


def test_given_variables_win_and_empty_ones_count_as_unset() -> None:
    s = Settings.from_env(dict(BASE, NFEX_STORE="", NFEX_DATA="/data", NFEX_MODELS="/m", NFEX_SCORE_ALL="1",
                               NFEX_SCORE_THREADS="3", NFEX_STORE_GRAPH="urn:g", NFEX_XFEAT_WEIGHTS="/w.pt"))
    assert s.store == "/d/nfex/store" and s.data == Path("/data") and s.models == Path("/m")
    assert s.score_all and s.score_threads_or_cpus == 3 and s.store_graph == "urn:g" and s.xfeat_weights == Path("/w.pt")


@pytest.mark.parametrize("nowhere", ["none", "OFF", " false ", "0"])
def test_the_compiled_cache_can_be_nowhere(nowhere: str) -> None:
    assert Settings.from_env(dict(BASE, NFEX_COMPILED_CACHE=nowhere)).compiled_cache is None
    assert Settings.from_env(dict(BASE, NFEX_COMPILED_CACHE="/cc")).compiled_cache == Path("/cc")


@pytest.mark.parametrize(("variable", "value"), [("NFEX_LEARNED_THREADS", "0"), ("NFEX_LEARNED_THREADS", "two"),
                                                 ("NFEX_SCORE_THREADS", "many"), ("NFEX_SCORE_ALL", "perhaps")])
def test_a_value_that_does_not_parse_is_bad_input_naming_the_variable(variable: str, value: str) -> None:
    with pytest.raises(BadInput, match=variable):
        Settings.from_env(dict(BASE, **{variable: value}))


def test_the_process_environment_is_read_through_the_same_fields(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NFEX_NEURAL", "symbolic")
    monkeypatch.setenv("NFEX_COMPILED_CACHE", "none")
    first = Settings.from_env()
    assert first.neural == "symbolic" and first.compiled_cache is None
    assert Settings.from_env() is first  # one object per environment: immutable, shared
    monkeypatch.setenv("NFEX_NEURAL", "paramnet")
    assert Settings.from_env().neural == "paramnet"  # a changed environment is read again
    with pytest.raises(Exception, match="frozen"):
        first.neural = "both"  # type: ignore[misc]


def test_replace_keeps_the_rest_and_validates() -> None:
    s = Settings.from_env(BASE)
    t = s.replace(store="/elsewhere", learned_threads=4)
    assert (t.store, t.learned_threads, t.home, t.compiled_cache) == ("/elsewhere", 4, s.home, s.compiled_cache)
    with pytest.raises(BadInput, match="NFEX_LEARNED_THREADS"):
        s.replace(learned_threads=0)


@given(st.integers(min_value=1, max_value=10_000), st.integers(min_value=0, max_value=64))
def test_integers_round_trip_through_their_variables(threads: int, score: int) -> None:
    s = Settings.from_env(dict(BASE, NFEX_LEARNED_THREADS=str(threads), NFEX_SCORE_THREADS=str(score)))
    assert (s.learned_threads, s.score_threads) == (threads, score)
    assert s.score_threads_or_cpus >= 1
