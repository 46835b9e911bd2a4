"""``NFEX_REQUIRE=all`` (set by .ci/run): a test that would skip for a missing component fails instead.

Virtuoso, Java, Chromium, the C++ toolchain, oxigraph, an extra, the data folder or one of its files: every
skip — ``pytest.skip``, ``skipif``, ``importorskip``, in a fixture, the test or at a module's collection — is
reported as a failure naming its reason. One hook rather than a helper each skip must call, so a skip added
later cannot leave CI green by mistake. A test marked ``may_skip`` keeps its skip: the declared exceptions,
named in the README (the docker compose check: no Docker daemon on the project's machines).
"""
from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

REQUIRE_FLAG = "NFEX_REQUIRE"


def require_all() -> bool:
    return os.environ.get(REQUIRE_FLAG, "").strip().lower() == "all"


def _as_failure(report: pytest.TestReport | pytest.CollectReport) -> None:
    reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
    report.outcome = "failed"
    report.longrepr = f"skipped under {REQUIRE_FLAG}=all, which turns a missing component into a failure: {reason}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Iterator[None]:
    outcome = yield
    report: pytest.TestReport = outcome.get_result()
    if report.skipped and require_all() and not hasattr(report, "wasxfail") \
            and item.get_closest_marker("may_skip") is None:
        _as_failure(report)


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector: pytest.Collector) -> Iterator[None]:
    outcome = yield
    report: pytest.CollectReport = outcome.get_result()
    if report.skipped and require_all():
        _as_failure(report)
