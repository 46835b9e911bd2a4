"""NFEX_REQUIRE=all turns every kind of skip into a failure, and leaves a ``may_skip`` test's skip alone."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

SKIPS = """
import shutil
import pytest

@pytest.fixture
def server():
    pytest.skip("virtuoso-t is not installed")

def test_in_a_fixture(server):
    pass

def test_in_the_test():
    pytest.skip("no Java runtime")

@pytest.mark.skipif(True, reason="needs headless Chromium")
def test_by_marker():
    pass

def test_by_import():
    pytest.importorskip("a_module_nobody_installed")

@pytest.mark.may_skip("the declared exception")
def test_declared():
    pytest.skip("no Docker daemon")

@pytest.mark.xfail(reason="expected")
def test_expected_failure():
    assert False
"""


def _run(folder: Path, require: str | None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "NFEX_REQUIRE"}
    if require is not None:
        env["NFEX_REQUIRE"] = require
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")])
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:xdist", "-p", "no:cacheprovider", "-p", "tests.require",
                           "-q", "-rA", "-o", "markers=may_skip(why): declared", str(folder)],
                          cwd=folder, env=env, capture_output=True, text=True, timeout=120)


@pytest.fixture
def suite(tmp_path: Path) -> Path:
    (tmp_path / "test_skips.py").write_text(SKIPS)
    return tmp_path


def test_without_the_switch_skips_stay_skips(suite: Path) -> None:
    p = _run(suite, None)
    assert p.returncode == 0, p.stdout
    assert p.stdout.strip().splitlines()[-1].startswith("5 skipped, 1 xfailed"), p.stdout


def test_require_all_fails_every_skip_but_the_declared_one(suite: Path) -> None:
    p = _run(suite, "all")
    assert p.returncode == 1, p.stdout
    for name in ("test_in_the_test", "test_by_import"):
        assert f"FAILED test_skips.py::{name}" in p.stdout, (name, p.stdout)
    for name in ("test_in_a_fixture", "test_by_marker"):  # a skip at setup fails the setup: an error
        assert f"ERROR test_skips.py::{name}" in p.stdout, (name, p.stdout)
    assert "SKIPPED" in p.stdout and "no Docker daemon" in p.stdout
    assert "skipped under NFEX_REQUIRE=all" in p.stdout and "virtuoso-t is not installed" in p.stdout
    assert p.stdout.strip().splitlines()[-1].startswith("2 failed, 1 skipped, 1 xfailed, 2 errors"), p.stdout


def test_require_all_fails_a_module_skipped_at_collection(tmp_path: Path) -> None:
    (tmp_path / "test_module_skip.py").write_text("import pytest\npytest.importorskip('another_absent_module')\n")
    assert _run(tmp_path, None).stdout.strip().splitlines()[-1].startswith("1 skipped")
    p = _run(tmp_path, "all")
    assert p.returncode != 0 and "ERROR test_module_skip.py" in p.stdout and "another_absent_module" in p.stdout, p.stdout
