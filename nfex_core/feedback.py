"""A client's report of what a selection achieved, as a ``nfex:Measurement`` with provenance.

The measurement has the shape of the sweeps' measurements (rules/shapes/integrity.ttl,
MeasurementShape): a ``sosa:Observation`` whose ``sosa:usedProcedure`` is the configuration (α, Θ —
the full Θ, defaults filled in, so equal configurations share one IRI), made on a ``nfex:Sequence``
under the context's condition values, ``prov:wasGeneratedBy`` a ``nfex:Run`` (one per session, or per
reporter and day) that ``prov:wasAssociatedWith`` the reporter, and ``prov:wasAttributedTo`` the
reporter (a ``nfex:Reporter``: the holder of the token that sent it, ``identity.reporter_iri``).
Being attributed makes it a *report*: it steers selections only once corroborated by ``nfex:minSources``
reporters or accepted by an editor (nfex_core/evidence/trust.py).

Reports arrive as a stream (a fleet reports per window), so ``ReportWriter`` commits those that arrive
together as one transaction (group commit, kg/batch.py): one head read, one presence check, one SHACL
validation of the touched nodes and one new graph version — hence one rule-table recompile — per batch
instead of per report. A report whose own input is bad (unknown name, bad window) fails alone before the
commit. The batch is committed optimistically, as one change; when SHACL rejects it (rare: the request
schema and ``measurement_graph`` catch nearly all bad reports), each report is checked alone
(``KnowledgeGraph.check``, nothing written), the offenders fail with their own validation report and the
rest are committed together again (one by one, should they conform alone but not together). Checking
every report before every commit would pay N validations per batch to save work only in that rare case.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import Future
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

import rdflib
from rdflib.namespace import PROV, RDF, RDFS, SOSA, XSD
from rdflib.term import Literal, URIRef

from . import __version__
from .errors import BadInput, NfexError, ValidationFailed
from .kg import identity
from .kg.batch import Batcher
from .kg.changes import ChangeSet, graph_triples
from .kg.namespaces import NFEX
from .kg.store import CommitResult
from .kg.terms import n3
from .kg.vocab import Vocabulary
from .sweeps import records

if TYPE_CHECKING:
    from .kg.store import KnowledgeGraph


@dataclass(frozen=True)
class Feedback:
    extractor: str
    params: dict[str, Any] = field(default_factory=dict)
    context: dict[str, str] = field(default_factory=dict)
    sequence: str = "client-stream"
    dataset: str | None = None
    client: str | None = None
    session: str | None = None
    reporter: str = "anonymous"  # the token's name
    window_start: int | None = None
    window_end: int | None = None
    frames: int | None = None
    ate_rmse: float | None = None
    rpe_rmse: float | None = None
    tracking_lost: int | None = None
    tracking_failed: bool | None = None
    mean_inliers: float | None = None
    mean_matches: float | None = None
    mean_keypoints: float | None = None
    extraction_ms: float | None = None
    matching_ms: float | None = None
    width: int | None = None
    height: int | None = None
    key: str | None = None  # the client's idempotency key: a retry of the same report is the same Measurement


def feedback_run_iri(fb: Feedback, now: datetime) -> URIRef:
    """One run per session, or per reporter and UTC day."""
    if fb.session:
        return identity.run_iri(f"session_{fb.session}")
    return identity.run_iri(f"feedback_{fb.reporter}_{now:%Y%m%d}")


def configuration_graph(vocab: Vocabulary, extractor: str, params: dict[str, Any]) -> tuple[rdflib.Graph, URIRef]:
    """The configuration (α, full Θ) as triples; parameters are checked against the graph's ranges."""
    spec = vocab.extractor(extractor)
    theta = spec.resolve(params)
    cfg = identity.configuration_iri(spec.name, theta)
    g = rdflib.Graph()
    records.configuration_triples(g, cfg, spec, theta)
    return g, cfg


def _check_values(fb: Feedback) -> None:
    """Refuse what the graph cannot hold or would hold wrongly: a non-finite measurement (it would poison every
    aggregate that reads it), and text that is no Unicode (a lone surrogate cannot be written as UTF-8)."""
    for name in ("ate_rmse", "rpe_rmse", "mean_inliers", "mean_matches", "mean_keypoints", "extraction_ms", "matching_ms"):
        x = getattr(fb, name)
        if x is not None and not math.isfinite(float(x)):
            raise BadInput(f"{name} must be a finite number, not {x}", field=name)
    texts = [fb.extractor, fb.sequence, fb.dataset, fb.client, fb.session, fb.reporter, *fb.context, *fb.params]
    texts += [v for v in (*fb.context.values(), *fb.params.values()) if isinstance(v, str)]
    for text in texts:
        if isinstance(text, str):
            try:
                text.encode("utf-8")
            except UnicodeEncodeError:
                raise BadInput("the report holds a lone surrogate (U+D800–U+DFFF) in a name or value") from None


def measurement_graph(vocab: Vocabulary, fb: Feedback, *, run_exists: bool = False, now: datetime | None = None,
                      configuration: URIRef | None = None) -> tuple[rdflib.Graph, URIRef]:
    """The Measurement for ``fb`` with its configuration, sequence, run and agent (``configuration``: the
    configuration's IRI, its own triples left out, for a writer that has them already: ``ReportWriter``)."""
    now = now or datetime.now(UTC)
    _check_values(fb)
    context = vocab.check_context(fb.context)
    frames = fb.frames
    if frames is None and fb.window_start is not None and fb.window_end is not None:
        frames = fb.window_end - fb.window_start
    if fb.window_start is not None and fb.window_end is not None and fb.window_end <= fb.window_start:
        raise BadInput(f"window_end ({fb.window_end}) must be greater than window_start ({fb.window_start})")
    if fb.tracking_lost is not None and frames is None:
        raise BadInput("tracking_lost needs the window's frame count (frames, or window_start and window_end)")
    if fb.tracking_lost is not None and frames is not None and fb.tracking_lost > frames:
        raise BadInput(f"tracking_lost ({fb.tracking_lost}) exceeds the window's {frames} frames")
    measured = [fb.ate_rmse, fb.rpe_rmse, fb.tracking_lost, fb.tracking_failed, fb.mean_inliers, fb.mean_matches]
    if all(v is None for v in measured):
        raise BadInput("feedback must report at least one of ate_rmse, rpe_rmse, tracking_lost, tracking_failed, mean_inliers, mean_matches")

    g, cfg = configuration_graph(vocab, fb.extractor, fb.params) if configuration is None else (rdflib.Graph(), configuration)
    m = identity.report_iri(fb.reporter, fb.key) if fb.key else identity.measurement_iri()
    seq = records.sequence_triples(g, fb.dataset, fb.sequence)  # the sweeps' node for the same sequence
    agent = identity.reporter_iri(fb.reporter)
    run = feedback_run_iri(fb, now)

    g.add((agent, RDF.type, NFEX.Reporter))
    g.add((agent, RDFS.label, Literal(fb.reporter)))
    if not run_exists:
        where = f"session {fb.session}" if fb.session else f"reporter {fb.reporter}"
        g.add((run, RDF.type, NFEX.Run))
        g.add((run, RDFS.label, Literal(f"client feedback ({where}{', client ' + fb.client if fb.client else ''})")))
        g.add((run, PROV.startedAtTime, Literal(now.isoformat(), datatype=XSD.dateTime)))
        g.add((run, NFEX.codeVersion, Literal(f"nfex {__version__}")))
        g.add((run, PROV.wasAssociatedWith, agent))

    g.add((m, RDF.type, NFEX.Measurement))
    g.add((m, SOSA.usedProcedure, cfg))
    g.add((m, NFEX.sequence, seq))
    g.add((m, PROV.wasGeneratedBy, run))
    g.add((m, PROV.wasAttributedTo, agent))
    g.add((m, SOSA.resultTime, Literal(now.isoformat(), datatype=XSD.dateTime)))
    for dim, value in context.items():
        g.add((m, NFEX.underCondition, vocab.condition_value(dim, value).iri))
    ints: dict[str, int | None] = {"windowStart": fb.window_start, "windowEnd": fb.window_end, "frameCount": frames,
            "trackingLost": fb.tracking_lost, "frameWidth": fb.width, "frameHeight": fb.height}
    doubles: dict[str, float | None] = {"ateRmse": fb.ate_rmse, "rpeRmse": fb.rpe_rmse, "meanInliers": fb.mean_inliers, "meanMatches": fb.mean_matches,
               "meanKeypoints": fb.mean_keypoints, "extractionMs": fb.extraction_ms, "matchingMs": fb.matching_ms}
    for name, v in ints.items():
        if v is not None:
            g.add((m, NFEX[name], Literal(int(v), datatype=XSD.integer)))
    for name, x in doubles.items():
        if x is not None:
            g.add((m, NFEX[name], Literal(float(x), datatype=XSD.double)))
    if fb.tracking_failed is not None:
        g.add((m, NFEX.trackingFailed, Literal(bool(fb.tracking_failed))))
    return g, m


def acceptance_graph(measurement: URIRef, editor: str, now: datetime | None = None) -> rdflib.Graph:
    """The triples by which ``editor`` admits a report as evidence (evidence/trust.py)."""
    now = now or datetime.now(UTC)
    g = rdflib.Graph()
    agent = identity.reporter_iri(editor)  # the agent behind a token name, whatever its role
    g.add((agent, RDF.type, PROV.Agent))
    g.add((agent, RDFS.label, Literal(editor)))
    g.add((measurement, NFEX.acceptedBy, agent))
    g.add((measurement, NFEX.acceptedAt, Literal(now.isoformat(), datatype=XSD.dateTime)))
    return g


@dataclass(frozen=True)
class Written:
    """A report committed: its Measurement's IRI and the commit that holds it (shared with its batch; ``added``
    counts the triples of this report's own graph)."""

    iri: URIRef
    result: CommitResult


class ReportWriter:
    """Commits reports through ``kg.commit``, those arriving together (up to ``max_items`` within ``window_s``)
    as one transaction; ``write`` returns once its report is committed (``max_items=1``: one commit each)."""

    def __init__(self, kg: KnowledgeGraph, *, max_items: int = 64, window_s: float = 0.02) -> None:
        self.kg = kg
        # a fleet reports the same few configurations over and over: their triples, made once per vocabulary
        self._configurations: tuple[Vocabulary | None, dict[URIRef, frozenset[Any]]] = (None, {})
        self.batcher: Batcher[Feedback, Written] = Batcher(self._commit, max_items=max_items, window_s=window_s,
                                                           name="nfex-feedback")

    def write(self, fb: Feedback) -> Written:
        """Validate and commit ``fb`` (with the reports that arrived with it); raises its own error."""
        return self.batcher.submit(fb)

    def submit(self, fb: Feedback) -> Future[Written]:
        """``write`` without waiting: the future is done once ``fb``'s batch is committed (or failed)."""
        return self.batcher.submit_future(fb)

    def close(self) -> None:
        self.batcher.close()

    def _commit(self, reports: Sequence[Feedback]) -> list[Written | BaseException]:
        now = datetime.now(UTC)  # one time for the batch: reports of one new run write identical run triples
        vocab = self.kg.vocabulary()
        existing = self._existing_runs({feedback_run_iri(fb, now) for fb in reports})
        keyed = {i: identity.report_iri(fb.reporter, fb.key) for i, fb in enumerate(reports) if fb.key}
        stored = self._existing_measurements(set(keyed.values()))
        built: list[tuple[frozenset[Any], URIRef] | BaseException] = []
        replayed: dict[int, URIRef] = {}
        for i, fb in enumerate(reports):
            if i in keyed and (keyed[i] in stored or keyed[i] in replayed.values()):
                replayed[i] = keyed[i]  # a retry: the report is already stored (or in this batch), once
                built.append(_PENDING)
                continue
            try:
                cfg, cfg_triples = self._configuration(vocab, fb)
                g, m = measurement_graph(vocab, fb, run_exists=feedback_run_iri(fb, now) in existing, now=now, configuration=cfg)
                built.append((graph_triples(g) | cfg_triples, m))
            except NfexError as e:  # bad input fails alone, before anything is written
                built.append(e)
        good = [(i, b) for i, b in enumerate(built) if not isinstance(b, BaseException)]
        out: list[Written | BaseException] = [b if isinstance(b, BaseException) else _PENDING for b in built]
        if replayed:
            head = self.kg.version
            for i, iri in replayed.items():
                out[i] = Written(iri, CommitResult(version=head, changed=False))
        if not good:
            return out
        try:
            self._commit_together(reports, good, out)
        except ValidationFailed as e:
            if len(good) == 1:
                out[good[0][0]] = e
                return out
            # find the offenders: each report checked alone (no write), the others committed together again
            passing: list[tuple[int, tuple[frozenset[Any], URIRef]]] = []
            for i, (triples, iri) in good:
                report = self.kg.check(ChangeSet.adding(triples))
                if report.conforms:
                    passing.append((i, (triples, iri)))
                else:
                    out[i] = ValidationFailed(report.violations, report.text, current_version=self.kg.version)
            try:
                self._commit_together(reports, passing, out)
            except ValidationFailed:  # reports that conform alone but not together: one commit each
                for i, (triples, iri) in passing:
                    try:
                        self._commit_together(reports, [(i, (triples, iri))], out)
                    except NfexError as err:
                        out[i] = err
        return out

    def _configuration(self, vocab: Vocabulary, fb: Feedback) -> tuple[URIRef, frozenset[Any]]:
        """``fb``'s configuration: its IRI and triples (``configuration_graph``), kept per IRI while the vocabulary is the same."""
        known, made = self._configurations
        if known is not vocab:
            made = {}
            self._configurations = (vocab, made)
        spec = vocab.extractor(fb.extractor)
        iri = identity.configuration_iri(spec.name, spec.resolve(fb.params))
        found = made.get(iri)
        if found is None:
            if len(made) >= 1024:  # a bound, not a policy: thousands of distinct Θ in a stream are made again
                made.clear()
            found = made[iri] = graph_triples(configuration_graph(vocab, fb.extractor, fb.params)[0])
        return iri, found

    def _commit_together(self, reports: Sequence[Feedback], items: Sequence[tuple[int, tuple[frozenset[Any], URIRef]]],
                         out: list[Written | BaseException]) -> None:
        if not items:
            return
        result = self._commit_graphs([reports[i] for i, _ in items], [g for _, (g, _) in items])
        for i, (g, iri) in items:
            out[i] = Written(iri, CommitResult(result.version, result.changed, added=len(g)))

    def _commit_graphs(self, reports: Sequence[Feedback], graphs: Sequence[frozenset[Any]]) -> CommitResult:
        triples: set[Any] = set()
        for g in graphs:
            triples |= g
        authors = sorted({fb.reporter for fb in reports})
        if len(reports) == 1:
            message = f"feedback: {reports[0].extractor} on {reports[0].sequence}"
        else:
            message = f"feedback: {len(reports)} reports (" + "; ".join(f"{fb.extractor} on {fb.sequence}" for fb in reports[:3]) + \
                      ("; …)" if len(reports) > 3 else ")")
        return self.kg.commit(ChangeSet.adding(triples), author=", ".join(authors), message=message)

    def _existing_measurements(self, iris: set[URIRef]) -> set[URIRef]:
        if not iris:
            return set()
        values = " ".join(n3(m) for m in sorted(iris))
        rows = self.kg.select(f"SELECT ?m WHERE {{ VALUES ?m {{ {values} }} ?m a nfex:Measurement }}").rows
        return {URIRef(str(r["m"])) for r in rows}

    def _existing_runs(self, runs: set[URIRef]) -> set[URIRef]:
        values = " ".join(n3(r) for r in sorted(runs))
        rows = self.kg.select(f"SELECT ?r WHERE {{ VALUES ?r {{ {values} }} ?r a nfex:Run }}").rows
        return {URIRef(str(r["r"])) for r in rows}


_PENDING = BadInput("internal: a report of the batch was not committed")  # replaced for every good report
