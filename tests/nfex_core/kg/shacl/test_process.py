"""pySHACL in a worker process (nfex_core/kg/shacl/process.py) gives the reports validating in this process gives:
on random writes (the strategies of test_validation.py), after the shapes change, and when the worker dies."""
from __future__ import annotations

from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nfex_core.kg import ChangeSet, KnowledgeGraph, parse_rdf
from nfex_core.kg.shacl import process as shacl_process
from nfex_core.kg.shacl.process import ShaclProcess
from nfex_core.kg.shacl.validation import Report, run_pyshacl, shapes_in, validate_change

from .test_validation import (  # noqa: F401  (graph is a fixture)
    edit_parameter,
    graph,
    hub_note,
    new_condition_value,
    new_configuration,
    new_measurement,
    remove_triple,
)


@pytest.fixture(scope="module")
def worker() -> Iterator[ShaclProcess]:
    proc = ShaclProcess()
    yield proc
    proc.close()


def both(kg: KnowledgeGraph, change: ChangeSet, shapes, worker: ShaclProcess) -> tuple[Report, Report]:  # type: ignore[no-untyped-def]
    return validate_change(kg.backend, change, shapes), validate_change(kg.backend, change, shapes, worker.run)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_the_worker_reports_what_this_process_reports(graph, worker, data) -> None:  # type: ignore[no-untyped-def]  # noqa: F811
    kg, base, shapes = graph
    kinds = [new_configuration(), edit_parameter(base), remove_triple(base), new_condition_value(), new_measurement(), hub_note()]
    change = ChangeSet()
    for c in data.draw(st.lists(st.one_of(*kinds), min_size=1, max_size=2)):
        change = change.then(c)
    change = ChangeSet(added=change.added - set(base), removed=change.removed & set(base))
    here, there = both(kg, change, shapes, worker)
    assert there == here
    assert worker.fallbacks == 0


def test_new_shapes_reach_the_worker(graph, worker) -> None:  # type: ignore[no-untyped-def]  # noqa: F811
    """A second shapes graph (an edit of the shapes) is sent once and judged by; the first is still known."""
    kg, base, shapes = graph
    change = ChangeSet.adding([(s, p, o) for s, p, o in parse_rdf(
        "@prefix nfex: <https://w3id.org/nfex#> . nfex:cfg_x a nfex:Configuration ; nfex:ofExtractor nfex:ORB .")])
    stricter = shapes_in(shapes.graph + parse_rdf("""@prefix nfex: <https://w3id.org/nfex#> . @prefix sh: <http://www.w3.org/ns/shacl#> .
        nfex:NeedsLabel a sh:NodeShape ; sh:targetClass nfex:Configuration ;
            sh:property [ sh:path <http://www.w3.org/2000/01/rdf-schema#label> ; sh:minCount 1 ] ."""))
    here, there = both(kg, change, stricter, worker)
    assert there == here and not there.conforms
    assert both(kg, change, shapes, worker)[1].conforms


def test_a_worker_that_died_idle_is_replaced(graph) -> None:  # type: ignore[no-untyped-def]  # noqa: F811
    kg, base, shapes = graph
    change = ChangeSet.adding([(s, p, o) for s, p, o in parse_rdf(
        "@prefix nfex: <https://w3id.org/nfex#> . nfex:cfg_y a nfex:Configuration ; nfex:ofExtractor nfex:SIFT .")])
    proc = ShaclProcess()
    try:
        proc.warm(shapes)
        assert proc.starts == 1 and proc._proc is not None  # noqa: SLF001
        proc._proc.kill()  # noqa: SLF001 - what an OOM kill does to it
        proc._proc.wait()  # noqa: SLF001
        want = validate_change(kg.backend, change, shapes)
        assert validate_change(kg.backend, change, shapes, proc.run) == want
        assert proc.starts == 2 and proc.fallbacks == 0
    finally:
        proc.close()
    assert validate_change(kg.backend, change, shapes, proc.run) == want  # closed: validated in this process


def test_a_worker_killed_mid_validation_costs_that_validation_in_process(graph) -> None:  # type: ignore[no-untyped-def]  # noqa: F811
    """The worker is killed once the request is sent, before its answer is read (as an OOM kill would)."""
    kg, base, shapes = graph
    focus = set(base.subjects())
    proc = ShaclProcess()
    try:
        proc.warm(shapes)
        worker = proc._proc  # noqa: SLF001
        assert worker is not None
        receive = shacl_process._receive

        def killed_first(stream):  # type: ignore[no-untyped-def]
            worker.kill()
            worker.wait()
            return receive(stream)

        shacl_process._receive = killed_first  # type: ignore[assignment]
        try:
            found = proc.run(list(base), shapes, focus)
        finally:
            shacl_process._receive = receive  # type: ignore[assignment]
        assert worker.poll() is not None and proc.fallbacks == 1
        assert found == run_pyshacl(base, shapes, focus)
        proc.warm()
        assert proc.starts == 2
    finally:
        proc.close()
