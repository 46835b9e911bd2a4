"""Extractor backends by kind: which code runs an extractor the graph describes (rdflib's plugin.py idea).

An extractor individual names its backend (``nfex:backend``; ``opencv`` when it names none): the
registry looks the backend's token up here. Each entry says where its implementation lives (imported
only when an extractor of that kind first extracts: OpenCV for ``opencv``, ONNX Runtime or torch for
``xfeat``) and how to tell, without importing anything heavy, whether it can run in this process.
An unknown kind is an error that lists the known ones; ``register`` adds a kind (a new learned model
is one module with ``extract(spec, grey, params, mask, settings) -> Features`` and one line here).

    >>> backend("opencv").kind
    'opencv'
    >>> backend("superpoint")
    Traceback (most recent call last):
    ...
    nfex_core.errors.UnknownName: unknown extractor backend 'superpoint'; known: opencv, xfeat
"""
from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..config import Settings
from ..errors import UnknownName
from .availability import Availability

if TYPE_CHECKING:
    from ..kg.vocabulary.vocab import ExtractorSpec


def _always(settings: Settings) -> Availability:
    return Availability(True, "OpenCV (a core dependency)")


def _xfeat(settings: Settings) -> Availability:
    from .learned.model import availability

    return availability(settings)


@dataclass(frozen=True)
class Backend:
    """One kind of extractor implementation: ``module:attr`` is its ``extract`` function."""

    kind: str
    module: str
    attr: str
    check: Callable[[Settings], Availability]
    learned: bool = False

    def extract_function(self) -> Callable[..., Any]:
        return getattr(importlib.import_module(self.module), self.attr)

    def availability(self, settings: Settings | None = None) -> Availability:
        return self.check(settings or Settings.from_env())


_BACKENDS: dict[str, Backend] = {}


def register(entry: Backend) -> None:
    _BACKENDS[entry.kind] = entry


register(Backend("opencv", "nfex_core.vision.registry", "extract_opencv", _always))
register(Backend("xfeat", "nfex_core.vision.learned.xfeat", "extract", _xfeat, learned=True))


def backend(kind: str) -> Backend:
    try:
        return _BACKENDS[kind]
    except KeyError:
        raise UnknownName("extractor backend", kind, _BACKENDS) from None


def kinds() -> list[str]:
    return sorted(_BACKENDS)


def unavailable(extractors: Mapping[str, ExtractorSpec], settings: Settings | None = None) -> dict[str, Availability]:
    """Extractor name → why it cannot run here, for those whose backend is unknown or unavailable."""
    settings = settings or Settings.from_env()
    out: dict[str, Availability] = {}
    checked: dict[str, Availability] = {}
    for name, spec in extractors.items():
        if spec.backend not in checked:
            try:
                checked[spec.backend] = backend(spec.backend).availability(settings)
            except UnknownName as e:
                checked[spec.backend] = Availability(False, e.detail, "nfex:backend")
        if not checked[spec.backend].ok:
            out[name] = checked[spec.backend]
    return out


def status(extractors: Mapping[str, ExtractorSpec], settings: Settings | None = None) -> dict[str, dict[str, Any]]:
    """Per backend kind the graph uses: available or not and why (``/readyz``, ``nfex select``)."""
    settings = settings or Settings.from_env()
    out: dict[str, dict[str, Any]] = {}
    for spec in extractors.values():
        entry = out.setdefault(spec.backend, {"extractors": []})
        entry["extractors"].append(spec.name)
        if "available" not in entry:
            try:
                a = backend(spec.backend).availability(settings)
            except UnknownName as e:
                entry.update(available=False, detail=e.detail)
                continue
            entry.update(available=a.ok, detail=a.detail)
            if a.setting:
                entry["setting"] = a.setting
    return out
