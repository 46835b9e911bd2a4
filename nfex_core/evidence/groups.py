"""The admitted observations, grouped as a compile reads them, carried from one graph version to the next.

A compile (rules/engine.py) reads the admitted observations (trust.py) four ways:

    summary   (extractor, condition value)            the evidence summaries the SPARQL rules read (view.py)
    observed  (extractor, set of condition values)    the evidence per context (``RuleTable.observed``)
    measured  (extractor, configuration)              the measured configurations (``RuleTable.configurations``)
    cost      (configuration, extractor, W, H)        the cost model's groups, with an extraction time (cost.py)

Each group holds its observations sorted by IRI, as a full read gives them. ``Grouped.of`` groups them all;
``Grouped.advance`` takes the index's Measurements whose row changed (evidence/index.py ``changed``),
re-admits the reports that share a corroboration key with one of them (the only reports whose admission can
have changed: trust.py) where their key's count of reporters moved, and touches only the groups those observations were in or are in now — so a report
costs the groups it lands in, not a pass over every Measurement. ``dirty`` names the groups touched, for the
readers that keep an aggregate per group. tests/nfex_core/rules/test_setup.py compares a carried compile with
a full one after random changes.
"""
from __future__ import annotations

import bisect
import operator
from collections.abc import Callable, Collection, Hashable, Iterable, Mapping
from dataclasses import dataclass, field

from .observations import Observation
from .trust import Admission, TrustPolicy, admit, corroboration_key, report_status

Groups = Mapping[Hashable, tuple[Observation, ...]]


def _summary(o: Observation) -> list[Hashable]:
    return [(o.extractor, cond) for cond in o.conditions]


def _observed(o: Observation) -> list[Hashable]:
    return [(o.extractor, o.conditions)]


def _measured(o: Observation) -> list[Hashable]:
    return [(o.extractor, o.configuration)]


def cost_group(o: Observation) -> tuple[str, str, int, int] | None:
    """The cost model's group of ``o`` (cost.py): its configuration, extractor and frame size, when it has an
    extraction time and a frame size; else None."""
    if o.extraction_ms is None or not o.width or not o.height or o.width <= 0 or o.height <= 0:
        return None
    return (o.configuration, o.extractor, o.width, o.height)


def _cost(o: Observation) -> list[Hashable]:
    group = cost_group(o)
    return [group] if group is not None else []


READERS: dict[str, Callable[[Observation], list[Hashable]]] = {
    "summary": _summary, "observed": _observed, "measured": _measured, "cost": _cost}


@dataclass(frozen=True)
class Grouped:
    """The admission of every observation, and the admitted ones grouped per reader (module docstring)."""

    admission: Admission
    groups: Mapping[str, Groups]  # reader → key → observations, sorted by IRI
    reports: Mapping[tuple[str, frozenset[tuple[str, str]]], frozenset[str]]  # corroboration key → report IRIs
    dirty: Mapping[str, frozenset[Hashable]] | None = None  # reader → keys touched by the last advance; None: all
    # reader → key → IRI → observation; inner dicts are copied before a change (a grouping is shared by two tables)
    _members: Mapping[str, Mapping[Hashable, dict[str, Observation]]] = field(default_factory=dict, repr=False)

    @classmethod
    def of(cls, observations: Iterable[Observation], policy: TrustPolicy) -> Grouped:
        items = sorted(observations, key=lambda o: o.iri)
        admission = admit(items, policy)
        members: dict[str, dict[Hashable, dict[str, Observation]]] = {r: {} for r in READERS}
        for o in items:
            if o.iri in admission.admitted:
                for reader, keys in READERS.items():
                    for k in keys(o):
                        members[reader].setdefault(k, {})[o.iri] = o
        reports: dict[tuple[str, frozenset[tuple[str, str]]], set[str]] = {}
        for o in items:
            if o.reporter is not None:
                reports.setdefault(corroboration_key(o), set()).add(o.iri)
        groups = {r: {k: tuple(m.values()) for k, m in g.items()} for r, g in members.items()}  # inserted in IRI order
        return cls(admission, groups, {k: frozenset(v) for k, v in reports.items()}, None, members)

    def advance(self, before: Mapping[str, Observation], after: Mapping[str, Observation], changed: Collection[str],
                policy: TrustPolicy) -> Grouped:
        """The grouping of ``after`` (the index's observations now), given this one of ``before`` and the IRIs
        whose row was added, removed or changed; the policy must be the one this grouping was made with."""
        reports = dict(self.reports)
        keys: set[tuple[str, frozenset[tuple[str, str]]]] = set()
        for iri in changed:
            for side, o in ((-1, before.get(iri)), (1, after.get(iri))):
                if o is None or o.reporter is None:
                    continue
                k = corroboration_key(o)
                keys.add(k)
                reports[k] = reports.get(k, frozenset()) - {iri} if side < 0 else reports.get(k, frozenset()) | {iri}
        for k in keys:
            if not reports.get(k):
                reports.pop(k, None)
        admitted, quarantined = dict(self.admission.admitted), dict(self.admission.quarantined)
        was = set(admitted)
        # a report's admission (and its reason) depends on it and on its key's count of distinct reporters: the
        # other reports of a key are judged again only where that count moved
        reporters = {k: len({after[i].reporter for i in reports.get(k, ())}) for k in keys}
        moved_keys = [k for k in keys if reporters[k] != len({before[i].reporter for i in self.reports.get(k, ())})]
        recheck = set(changed) | {iri for k in moved_keys for iri in reports.get(k, ())}
        for iri in recheck:
            admitted.pop(iri, None)
            quarantined.pop(iri, None)
            o = after.get(iri)
            if o is None:
                continue
            counts, reason = report_status(o, reporters[corroboration_key(o)] if o.reporter else 0, policy)
            (admitted if counts else quarantined)[iri] = reason
        moved = {iri for iri in recheck if (iri in was) != (iri in admitted) or iri in changed}
        members: dict[str, dict[Hashable, dict[str, Observation]]] = {r: dict(g) for r, g in self._members.items()}
        dirty: dict[str, dict[Hashable, set[str]]] = {r: {} for r in READERS}  # reader → group → the IRIs moved in or out
        for iri in moved:
            for o, add in ((before.get(iri), False), (after.get(iri), True)):
                if o is None or not (iri in admitted if add else iri in was):
                    continue
                for reader, of in READERS.items():
                    for g in of(o):
                        if g not in dirty[reader]:
                            dirty[reader][g] = set()
                            members[reader][g] = dict(members[reader].get(g, {}))
                        dirty[reader][g].add(iri)
                        if add:
                            members[reader][g][iri] = o
                        else:
                            members[reader][g].pop(iri, None)
        groups = {r: dict(g) for r, g in self.groups.items()}
        for reader, touched in dirty.items():
            for g, iris in touched.items():
                if members[reader][g]:
                    groups[reader][g] = _merged(self.groups[reader].get(g, ()), iris, members[reader][g])
                else:
                    members[reader].pop(g)
                    groups[reader].pop(g, None)
        return Grouped(Admission(admitted, quarantined), groups, reports, {r: frozenset(k) for r, k in dirty.items()}, members)


def _merged(group: tuple[Observation, ...], iris: set[str], members: Mapping[str, Observation]) -> tuple[Observation, ...]:
    """``group`` (sorted by IRI) with the observations of ``iris`` taken out and those of them in ``members`` put
    back in order: a report costs a copy and a binary search, not a sort of its group."""
    items = [o for o in group if o.iri not in iris] if _holds_any(group, iris) else list(group)
    for iri in sorted(iris):
        if iri in members:
            bisect.insort(items, members[iri], key=_IRI)
    return tuple(items)


def _holds_any(group: tuple[Observation, ...], iris: set[str]) -> bool:
    """Whether the sorted ``group`` holds an observation of one of ``iris`` (a binary search each)."""
    for iri in iris:
        k = bisect.bisect_left(group, iri, key=_IRI)
        if k < len(group) and group[k].iri == iri:
            return True
    return False


_IRI = operator.attrgetter("iri")
