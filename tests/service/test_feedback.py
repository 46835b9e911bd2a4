"""POST /v1/feedback: a report (a Measurement attributed to its reporter) with provenance, SHACL-checked,
counted by the measured pruning rules once corroborated (tests/service/test_trust.py has the trust rule)."""
from __future__ import annotations

import json

import httpx
import pytest

from .conftest import REPORTERS, Service, assert_problem, auth

TRACKING_LOSS_RULE = "https://w3id.org/nfex#rule_measured_tracking_loss"  # rules/pruning/measured-tracking-loss.rq


def pruned(service: Service, context: dict[str, str]) -> dict[str, list[dict]]:  # type: ignore[type-arg]
    """What a select that waits for the reports just made prunes (``?consistency=latest``: read-your-writes)."""
    sel = httpx.post(service.url + "/v1/select", params={"consistency": "latest"}, json={"context": context}).json()
    return {p["extractor"]: p["because"] for p in sel["pruned"]}


def test_feedback_becomes_a_measurement_with_provenance(service: Service) -> None:
    before = service.version()
    r = httpx.post(service.url + "/v1/feedback", headers=auth(REPORTERS["carol"]), json={
        "extractor": "ORB", "params": {"nfeatures": 1500}, "context": {"agent": "car", "scene": "outdoor"},
        "sequence": "kitti/01", "dataset": "KITTI odometry", "client": "pytest", "window_start": 0, "window_end": 50,
        "ate_rmse": 1.25, "rpe_rmse": 0.05, "tracking_lost": 2, "mean_inliers": 150.0, "extraction_ms": 4.5})
    assert r.status_code == 201, r.text
    body = r.json()
    assert body["version"] == before + 1 and r.headers["etag"] == f'"{before + 1}"'
    q = f"""SELECT ?ate ?frames ?x ?nf ?run ?agent ?seq ?cond WHERE {{
        <{body['iri']}> a nfex:Measurement ; a ?t ; nfex:ateRmse ?ate ; nfex:frameCount ?frames ; nfex:sequence ?seq ;
            sosa:usedProcedure ?cfg ; prov:wasGeneratedBy ?run ; prov:wasAttributedTo ?agent ; nfex:underCondition ?cond .
        ?cfg nfex:ofExtractor ?x ; nfex:hasSetting [ nfex:parameter nfex:ORB_nfeatures ; nfex:value ?nf ] .
        ?run a nfex:Run ; prov:wasAssociatedWith ?agent . ?agent a nfex:Reporter ; rdfs:label "carol" . ?seq a nfex:Sequence }}"""
    rows = httpx.get(service.url + "/sparql", params={"query": q}).json()["results"]["bindings"]
    assert {r["cond"]["value"].rsplit("#", 1)[1] for r in rows} == {"agent_car", "scene_outdoor"}
    row = rows[0]
    assert float(row["ate"]["value"]) == 1.25 and int(row["frames"]["value"]) == 50 and int(row["nf"]["value"]) == 1500
    assert row["x"]["value"].endswith("#ORB")


@pytest.mark.parametrize("body,status", [
    ({"extractor": "FAST9", "ate_rmse": 1.0}, 422),
    ({"extractor": "ORB", "params": {"nfeatures": -3}, "ate_rmse": 1.0}, 422),
    ({"extractor": "ORB", "params": {"colour": 3}, "ate_rmse": 1.0}, 422),
    ({"extractor": "ORB", "context": {"light": "purple"}, "ate_rmse": 1.0}, 422),
    ({"extractor": "ORB", "ate_rmse": -1.0}, 422),
    ({"extractor": "ORB"}, 400),
    ({"extractor": "ORB", "tracking_lost": 3}, 400),
    ({"extractor": "ORB", "window_start": 10, "window_end": 5, "ate_rmse": 1.0}, 400),
    ({"extractor": "ORB", "ate_rmse": 1.0, "session_id": "nope"}, 404),
])
def test_bad_feedback_is_a_clear_4xx_and_writes_nothing(service: Service, body: dict, status: int) -> None:  # type: ignore[type-arg]
    before = service.version()
    assert_problem(httpx.post(service.url + "/v1/feedback", json=body, headers=auth(REPORTERS["carol"])), status)
    assert service.version() == before


def test_enough_bad_feedback_prunes_an_extractor_from_the_next_commit_on(service: Service) -> None:
    """Three windows with 60% of frames lost under texture = high, from three reporters (nfex:minSources),
    exceed nfex:maxTrackingLossRate (0.25) with nfex:minMeasurements (3) windows:
    rules/pruning/measured-tracking-loss.rq prunes BRISK there."""
    context = {"texture": "high"}
    assert "BRISK" not in pruned(service, context)
    for i, token in enumerate(REPORTERS.values()):
        r = httpx.post(service.url + "/v1/feedback", headers=auth(token), json={
            "extractor": "BRISK", "context": context, "sequence": "pytest/high-texture", "window_start": 100 * i,
            "window_end": 100 * i + 100, "tracking_lost": 60, "ate_rmse": 3.0, "client": "pytest"})
        assert r.status_code == 201, r.text
        if i < 2:
            assert "BRISK" not in pruned(service, context)  # not corroborated yet (and below nfex:minMeasurements)
    because = pruned(service, context)["BRISK"]
    assert because[0]["rule"] == TRACKING_LOSS_RULE
    assert "60% of frames over 3 measured windows with texture = high (3 sources" in because[0]["reason"]
    assert "BRISK" not in pruned(service, {"texture": "low"})  # only where it was measured


def test_feedback_and_sweeps_name_one_configuration_alike(kg) -> None:  # type: ignore[no-untyped-def]
    """A client's report and a sweep row for the same (α, Θ) use one configuration IRI, so per-configuration
    queries (cost tier 1, measured pruning) see both."""
    from rdflib.namespace import SOSA

    from nfex_core.feedback import Feedback, measurement_graph
    from nfex_core.kg.namespaces import NFEX
    from nfex_core.sweeps.records import RunInfo
    from nfex_core.sweeps.records import measurement_graph as sweep_graph

    vocab = kg.vocabulary()
    theta = vocab.extractor("ORB").resolve({"nfeatures": 1500})
    row = {"dataset": "kitti", "sequence": "00", "corruption": "none", "severity": 0.0, "window_start": 0, "window_end": 10,
           "frames": 10, "extractor": "ORB", "params": json.dumps(theta, sort_keys=True, separators=(",", ":")),
           "ate_rmse": 1.0, "rpe_rmse": 0.1, "tracking_lost": 0, "failed": 0, "width": 1241, "height": 376, "cell": "x"}
    swept = {o for o in sweep_graph([row], vocab, RunInfo(command="test")).objects(None, SOSA.usedProcedure)}
    g, m = measurement_graph(vocab, Feedback(extractor="ORB", params={"nfeatures": 1500}, ate_rmse=1.0))
    assert set(g.objects(m, SOSA.usedProcedure)) == swept and len(swept) == 1
    assert next(iter(swept)).startswith(str(NFEX["cfg_ORB_"]))


def test_feedback_and_a_sweep_on_one_sequence_share_its_node(kg) -> None:  # type: ignore[no-untyped-def]
    """Regression: feedback named its sequence ``sequence_<seq>`` labelled "<seq>", the sweeps
    ``sequence_<dataset>_<seq>`` labelled "<dataset> <seq>", so `nfex evaluate` could not hold a sequence
    out of feedback measurements and the two never counted together."""
    from rdflib.namespace import RDFS

    from nfex_core.feedback import Feedback, measurement_graph
    from nfex_core.kg.namespaces import NFEX
    from nfex_core.sweeps.records import RunInfo
    from nfex_core.sweeps.records import measurement_graph as sweep_graph

    vocab = kg.vocabulary()
    theta = vocab.extractor("ORB").resolve({})
    row = {"dataset": "kitti", "sequence": "01", "corruption": "none", "severity": 0.0, "window_start": 0, "window_end": 10,
           "frames": 10, "extractor": "ORB", "params": json.dumps(theta, sort_keys=True, separators=(",", ":")),
           "ate_rmse": 1.0, "rpe_rmse": 0.1, "tracking_lost": 0, "failed": 0, "width": 1241, "height": 376, "cell": "y"}
    swept = set(sweep_graph([row], vocab, RunInfo(command="test")).objects(None, NFEX.sequence))
    g, m = measurement_graph(vocab, Feedback(extractor="ORB", params={}, ate_rmse=1.0, dataset="kitti", sequence="01"))
    assert set(g.objects(m, NFEX.sequence)) == swept and len(swept) == 1
    [seq] = swept
    assert str(g.value(seq, RDFS.label)) == "kitti 01" and g.value(seq, NFEX.inDataset) == NFEX["dataset_kitti"]


def _post(service: Service, token: str, body: dict) -> httpx.Response:  # type: ignore[type-arg]
    return httpx.post(service.url + "/v1/feedback", headers=auth(token), json=body, timeout=60)


def test_concurrent_reports_share_commits_and_a_bad_one_fails_alone(service: Service) -> None:
    """Group commit: twelve reports posted at once are committed in fewer graph versions than reports, each
    answered with its own Measurement; the one naming an unknown extractor gets its own 422, not its neighbours."""
    from concurrent.futures import ThreadPoolExecutor

    before = service.version()
    bodies = [{"extractor": "ORB", "context": {"agent": "drone"}, "sequence": "pytest/fleet", "window_start": 10 * i,
               "window_end": 10 * i + 10, "ate_rmse": 0.4 + i / 100} for i in range(12)]
    bodies[5] = {**bodies[5], "extractor": "FAST9"}
    tokens = list(REPORTERS.values())
    with ThreadPoolExecutor(12) as pool:
        answers = list(pool.map(lambda ib: _post(service, tokens[ib[0] % 3], ib[1]), enumerate(bodies)))
    doc = assert_problem(answers[5], 422)
    assert "FAST9" in doc["detail"]
    good = [r for i, r in enumerate(answers) if i != 5]
    assert all(r.status_code == 201 for r in good), [r.text for r in good]
    assert len({r.json()["iri"] for r in good}) == 11
    committed = service.version() - before
    assert 1 <= committed < 11, f"{committed} graph versions for 11 reports"
    assert max(r.json()["version"] for r in good) == service.version()  # each answered after its batch committed


def test_a_select_that_asks_for_the_latest_version_reads_the_reports_just_made(service: Service) -> None:
    """Read-your-writes where the design promises it: ``?consistency=latest`` answers from the head's compile."""
    r = _post(service, REPORTERS["dave"], {"extractor": "BRISK", "context": {"motion": "slow"}, "sequence": "pytest/ryw",
                                           "window_start": 0, "window_end": 20, "ate_rmse": 0.3})
    assert r.status_code == 201, r.text
    version = r.json()["version"]
    sel = httpx.post(service.url + "/v1/select", params={"consistency": "latest"}, json={"context": {"motion": "slow"}},
                     timeout=60).json()
    assert sel["versions"]["graph"] >= version and sel["versions"]["stale_ms"] == 0
    assert sel["versions"]["graph_head"] == sel["versions"]["graph"]
    quick = httpx.post(service.url + "/v1/select", json={"context": {"motion": "slow"}}).json()  # never waits
    assert quick["versions"]["graph_head"] >= version and quick["versions"]["graph"] <= quick["versions"]["graph_head"]
    assert_problem(httpx.post(service.url + "/v1/select", params={"consistency": "eventual"}, json={"context": {}}), 422)
