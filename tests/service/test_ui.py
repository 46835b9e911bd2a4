"""The workbench page (/ui/) driven in headless Chromium (Debian's ``chromium``, through Playwright) against
a real ``nfex serve`` over a store with the shipped sweep's measurements.

Each test checks that every request the page made went to the service (nothing from elsewhere: the page
works offline) and that no script error occurred. With ``NFEX_UI_SCREENSHOTS=1`` the tests write the
screenshots of docs/ui.md to docs/img/ui-*.png; ordinary runs leave those files alone.
"""
from __future__ import annotations

import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import quote

import httpx
import pytest

from tests.conftest import REPO, stop_process

from .conftest import EDITOR, REPORTER, Service, start_service

CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]
EXTRACTORS = "SELECT ?x ?label WHERE { ?x a nfex:FeatureExtractor ; rdfs:label ?label }"
SHOTS = REPO / "docs" / "img"
KITTI = Path("kitti") / "sequences" / "01" / "image_0" / "000010.png"


def chromium() -> str | None:
    for exe in (shutil.which("chromium"), "/usr/bin/chromium"):
        if exe and Path(exe).is_file():
            return exe
    return None


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright for Python is not installed (the dev extra has it)")
    exe = chromium()
    if exe is None:
        pytest.skip("Debian's chromium is not installed here (apt-get install chromium; `make test` installs it)")
    sync_api.expect.set_options(timeout=30_000)  # a view after a commit waits for the rule table's recompilation
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_FLAGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def ui_service(shipped_template: tuple[Path, object], tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """The service over a copy of the store with the shipped KITTI 00 sweep (the evidence views have data);
    NFEX_HOME is this checkout, so the saved queries of docs/queries/ are served."""
    folder = tmp_path_factory.mktemp("ui-service")
    store = folder / "store"
    shutil.copytree(shipped_template[0], store, ignore=shutil.ignore_patterns("LOCK"))
    svc = start_service(str(store), folder / "service.log", {"NFEX_HOME": str(REPO)})
    yield svc
    stop_process(svc.proc)


@pytest.fixture
def page(browser: Any, ui_service: Service) -> Iterator[Any]:
    context = browser.new_context(viewport={"width": 1400, "height": 900})
    pg = context.new_page()
    requests: list[str] = []
    errors: list[str] = []
    pg.on("request", lambda r: requests.append(r.url))
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.set_default_timeout(30_000)
    yield pg
    context.close()
    elsewhere = [u for u in requests if not u.startswith(ui_service.url + "/") and not u.startswith(("data:", "blob:"))]
    assert not elsewhere, f"the page reached beyond the service: {elsewhere}"
    assert not [u for u in requests if EDITOR in u], "a token appeared in a URL"
    assert not errors, errors


def shot(page: Any, name: str) -> None:
    if os.environ.get("NFEX_UI_SCREENSHOTS") == "1":
        page.screenshot(path=str(SHOTS / f"ui-{name}.png"), full_page=True)


def expect(locator: Any) -> Any:
    from playwright.sync_api import expect as pw_expect

    return pw_expect(locator)


def use_token(page: Any, url: str) -> None:
    page.goto(url + "/ui/#/versions")
    page.fill("#token", EDITOR)
    page.click("#token-save")
    expect(page.locator("#token-forget")).to_be_visible()
    assert page.evaluate("sessionStorage.getItem('nfex.token')") == EDITOR


def test_share_link_renders_a_table_whose_iris_open_the_browser(page: Any, ui_service: Service) -> None:
    page.goto(f"{ui_service.url}/ui/#/sparql?query={quote(EXTRACTORS)}")
    table = page.locator("#results-table")
    expect(table).to_be_visible()
    labels = {t.split(" @")[0].strip() for t in table.locator("tbody tr td:nth-child(2)").all_inner_texts()}
    assert {"ORB", "SIFT"} <= labels
    expect(page.locator("#examples optgroup[label^='Saved queries'] option")).to_have_count(
        len(list((REPO / "docs" / "queries").glob("*.rq"))))
    shot(page, "sparql")
    table.locator("a", has_text="nfex:SIFT").click()
    expect(page.locator("#browse-special")).to_contain_text("contrastThreshold")
    expect(page.locator("#browse-special")).to_contain_text("Configurations and their measurements")
    shot(page, "browse-extractor")


def test_completion_and_the_numeric_chart(page: Any, ui_service: Service) -> None:
    page.goto(f"{ui_service.url}/ui/#/sparql")
    expect(page.locator("#view-sparql[data-names=ready]")).to_have_count(1)  # the names to complete have arrived
    editor = page.locator("#view-sparql textarea")
    editor.fill("")
    editor.press_sequentially("SELECT ?x ?w WHERE { ?x a nfex:FeatureExtr")
    popup = page.locator(".complete")
    expect(popup).to_be_visible()
    expect(popup).to_contain_text("nfex:FeatureExtractor")
    editor.press("Enter")
    assert editor.input_value().endswith("nfex:FeatureExtractor")
    editor.press_sequentially(" . ?p nfex:parameterOf ?x ; nfex:defaultValue ?w FILTER (isNumeric(?w)) } ORDER BY ?w")
    editor.press("Control+Enter")
    expect(page.locator("#results svg.chart")).to_be_visible()


def test_a_bad_query_shows_the_error_the_service_reports(page: Any, ui_service: Service) -> None:
    bad = "SELECT ?x WHERE {\n  ?x a nfex:FeatureExtractor .\n  FILTER (?x = )\n}"
    server = httpx.post(ui_service.url + "/sparql", content=bad, headers={"content-type": "application/sparql-query"}).json()
    page.goto(f"{ui_service.url}/ui/#/sparql?query={quote(bad)}")
    error = page.locator("#sparql-error")
    expect(error).to_be_visible()
    expect(error).to_contain_text(server["detail"])
    line, column = server.get("line"), server.get("column")
    if line is None:
        m = re.search(r"error at (\d+):(\d+)", server["detail"])
        assert m, server["detail"]
        line, column = int(m.group(1)), int(m.group(2))
    expect(error).to_contain_text(f"Line {line}, column {column}")
    if line <= bad.count("\n") + 1:  # the editor marks the line when it is one of the query's
        expect(page.locator(".editor .gutter .err")).to_have_text(str(line))
    expect(page.locator("#results")).to_have_count(0)
    shot(page, "sparql-error")


def test_try_a_kitti_frame_shows_alpha_and_keypoints(page: Any, ui_service: Service, data_dir: Path) -> None:
    frame = data_dir / KITTI
    if not frame.is_file():
        pytest.skip(f"{frame} is absent")
    page.goto(ui_service.url + "/ui/#/frame")
    page.set_input_files("#frame-file", str(frame))
    page.select_option("select[name=agent]", "car")
    page.click("#select-btn")
    expect(page.locator("#alpha")).not_to_be_empty(timeout=60_000)
    direct = httpx.post(ui_service.url + "/v1/select?keypoints=true", files={"frame": ("f.png", frame.read_bytes(), "image/png")},
                        data={"context": '{"agent": "car"}'}, timeout=60).json()
    alpha = page.locator("#alpha").inner_text()
    assert alpha == direct["extractor"]
    expect(page.locator("#keypoint-info")).to_contain_text(f"{direct['keypoints']['count']} {alpha} keypoints")
    drawn = page.evaluate("""() => { const c = document.getElementById('frame-canvas');
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let n = 0;
        for (let i = 0; i < d.length; i += 4) if (d[i + 1] > 200 && d[i] < 80) n++; return [c.width, c.height, n]; }""")
    assert drawn[:2] == [1241, 376] and drawn[2] > 100  # green keypoint circles on a grey frame
    expect(page.locator("#theta tbody tr")).to_have_count(len(direct["params"]))
    expect(page.locator("#conditions tbody tr")).to_have_count(len(direct["context"]))
    expect(page.locator("#conditions")).to_contain_text("estimated")
    expect(page.locator("#scores tbody tr")).to_have_count(len(direct["candidates"]))
    shot(page, "frame")


def test_a_program_with_an_unknown_name_shows_the_error_and_applies_nothing(page: Any, ui_service: Service) -> None:
    use_token(page, ui_service.url)
    before = ui_service.version()
    page.goto(ui_service.url + "/ui/#/programs?name=ui_bad")
    page.locator("#view-programs textarea").fill('program ui_bad\nprune ORB when light is drak because "typo"\n')
    problems = page.locator("#check-problems")
    expect(problems).to_contain_text("2:25")
    expect(problems).to_contain_text("known value of light: bright, dark")
    expect(page.locator(".editor .gutter .err")).to_have_text("2")
    page.click("#apply-btn")
    error = page.locator("#apply-error")
    expect(error).to_contain_text("'drak'")
    expect(error).to_contain_text("nothing was applied")
    shot(page, "program-error")
    assert ui_service.version() == before
    assert "ui_bad" not in {p["name"] for p in httpx.get(ui_service.url + "/v1/programs").json()["programs"]}


def test_a_valid_program_previews_applies_and_its_version_is_listed(page: Any, ui_service: Service) -> None:
    text = 'program ui_test\nprune SIFT when light is dark because "workbench test: SIFT too slow here"\n'
    use_token(page, ui_service.url)
    before = ui_service.version()
    page.goto(ui_service.url + "/ui/#/programs?name=ui_test")
    page.locator("#view-programs textarea").fill(text)
    expect(page.locator("#check-status")).to_contain_text("valid: 1 statement")
    page.click("#preview-btn")
    summary = page.locator("#preview p").first
    expect(summary).to_contain_text("contexts change", timeout=120_000)
    changed, contexts = map(int, re.match(r"(\d+) of (\d+) contexts change", summary.inner_text()).groups())  # type: ignore[union-attr]
    assert 0 < changed < contexts  # SIFT is α* in some dark contexts (the API's own count: test_workbench.py)
    expect(page.locator("#preview-table tbody tr")).to_have_count(min(changed, 300))
    expect(page.locator("#preview-table tbody tr").first.locator("td").nth(1)).to_have_text("SIFT")
    shot(page, "program-preview")
    assert ui_service.version() == before  # a preview writes nothing
    page.click("#apply-btn")
    expect(page.locator("#apply-result")).to_contain_text(f"graph version {before + 1}")
    page.click("#apply-result a[href^='#/versions']")
    table = page.locator("#versions-table")
    expect(table.locator("tbody tr").first).to_contain_text("PUT program ui_test")
    expect(table.locator("tbody tr").first.locator("td").first).to_have_text(str(before + 1))
    expect(page.locator("#version-detail")).to_contain_text("workbench test: SIFT too slow here")
    shot(page, "versions")
    assert ui_service.version() == before + 1
    assert "ui_test" in {p["name"] for p in httpx.get(ui_service.url + "/v1/programs").json()["programs"]}


def test_browse_and_evidence_views(page: Any, ui_service: Service) -> None:
    r = httpx.post(ui_service.url + "/v1/feedback", json={"extractor": "ORB", "client": "ui-test-client", "sequence": "kitti/01",
                                                         "context": {"agent": "car"}, "ate_rmse": 0.42, "window_start": 0, "window_end": 10},
                   headers={"Authorization": f"Bearer {REPORTER}"})
    assert r.status_code == 201, r.text
    page.goto(ui_service.url + "/ui/#/browse")
    expect(page.locator("#extractor-cards")).to_contain_text("SIFT")
    expect(page.locator("#view-browse")).to_contain_text("prunes BRISK in")  # a context shape's effect
    shot(page, "browse")
    page.goto(ui_service.url + "/ui/#/browse?iri=" + quote(r.json()["iri"], safe=""))
    expect(page.locator("#provenance")).to_contain_text("ui-test-client")
    page.goto(ui_service.url + "/ui/#/evidence")
    expect(page.locator("#ate-by-condition svg.chart").first).to_be_visible()
    expect(page.locator("#feedback")).to_contain_text("ui-test-client")
    expect(page.locator("#sources tbody tr").first).to_contain_text("run ")
    shot(page, "evidence")
