"""The vocabulary's value types: an extractor, its parameters (role, datatype, range, how a value is
checked and clamped), its norm rules and OpenCV recipe, condition dimensions and values, metrics.

``Vocabulary`` (vocab.py) builds them from the graph; everything that takes a name or a value from a user
checks it through them.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from nfex_slam.features import Recipe
from rdflib.namespace import XSD
from rdflib.term import Literal, URIRef

from ...errors import ParameterError, UnknownName

Value = int | float | bool


@dataclass(frozen=True)
class ParameterSpec:
    iri: URIRef
    extractor: str
    name: str
    datatype: str  # "integer" | "double" | "boolean"
    role: str  # "NF" | "SF" | "NL" | "ST" | "other"
    default: Value
    min: Value | None = None
    max: Value | None = None
    allowed: tuple[Value, ...] | None = None
    tunable: bool = False
    scales_with_resolution: bool = False
    grid_role: str | None = None  # "cellSize" | "oversample": applied by the registry, not passed to OpenCV
    scales_input: bool = False  # nfex:scalesInput: the frame is resized by this factor before extraction
    label: str = ""
    comment: str = ""

    @property
    def qualified(self) -> str:
        return f"{self.extractor}.{self.name}"

    def range_text(self) -> str:
        if self.allowed is not None:
            return "one of {" + ", ".join(str(a) for a in self.allowed) + "}"
        if self.datatype == "boolean":
            return "true or false"
        return f"[{self.min}, {self.max}] ({self.datatype})"

    def coerce(self, value: Any) -> Value:
        """``value`` as this parameter's Python type, or ParameterError naming the parameter and its range."""
        where = f"{self.qualified} = {value!r}"
        if self.datatype == "boolean":
            if isinstance(value, bool):
                return value
            if isinstance(value, str) and value.lower() in ("true", "false"):
                return value.lower() == "true"
            raise ParameterError(f"{where} is not a boolean; allowed: {self.range_text()}", parameter=self.qualified)
        if isinstance(value, bool):
            raise ParameterError(f"{where} is not a number; allowed: {self.range_text()}", parameter=self.qualified)
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise ParameterError(f"{where} is not a number; allowed: {self.range_text()}", parameter=self.qualified) from None
        if not math.isfinite(number):
            raise ParameterError(f"{where} is not a finite number; allowed: {self.range_text()}", parameter=self.qualified)
        if self.datatype == "integer":
            if number != int(number):
                raise ParameterError(f"{where} is not an integer; allowed: {self.range_text()}", parameter=self.qualified)
            out: Value = int(number)
        else:
            out = number
        return out

    def validate(self, value: Any) -> Value:
        """Coerce and check the range (or the allowed values)."""
        v = self.coerce(value)
        if self.allowed is not None and v not in self.allowed:
            raise ParameterError(f"{self.qualified} = {value!r} is not allowed; allowed: {self.range_text()}", parameter=self.qualified)
        if isinstance(v, bool):
            return v
        if (self.min is not None and v < self.min) or (self.max is not None and v > self.max):
            raise ParameterError(
                f"{self.qualified} = {value!r} is outside its range {self.range_text()}", parameter=self.qualified
            )
        return v

    def clamp(self, value: float) -> Value:
        """Round to the datatype and clamp into the range (or to the nearest allowed value)."""
        if self.datatype == "boolean":
            return bool(value)
        if self.allowed is not None:
            return min(self.allowed, key=lambda a: (abs(float(a) - value), a))
        lo = float(self.min) if self.min is not None else -float("inf")
        hi = float(self.max) if self.max is not None else float("inf")
        v = min(max(float(value), lo), hi)
        return int(round(v)) if self.datatype == "integer" else v

    def literal(self, value: Value) -> Literal:
        dt = {"integer": XSD.integer, "double": XSD.double, "boolean": XSD.boolean}[self.datatype]
        return Literal(value, datatype=dt)


@dataclass(frozen=True)
class NormRuleSpec:
    parameter: str
    values: tuple[Value, ...]
    norm: str


@dataclass(frozen=True)
class ExtractorSpec:
    iri: URIRef
    name: str
    label: str
    constructor: str  # the OpenCV factory ("" for a learned model)
    norm: str
    descriptor_kind: str  # "binary" | "real"
    parameters: Mapping[str, ParameterSpec]
    norm_rules: tuple[NormRuleSpec, ...] = ()
    operations: tuple[str, ...] = ()
    comment: str = ""
    backend: str = "opencv"  # the nfex:backend's token: which code runs it (vision.backends)
    matcher: str = "ratio"  # the nfex:matcher's token: "ratio" | "mutual-ratio"
    descriptor_size: int | None = None  # declared for learned models; OpenCV's detectors report theirs

    def parameter(self, name: str) -> ParameterSpec:
        try:
            return self.parameters[name]
        except KeyError:
            raise UnknownName("parameter", f"{self.name}.{name}", [f"{self.name}.{p}" for p in self.parameters]) from None

    def defaults(self) -> dict[str, Value]:
        return {n: p.default for n, p in self.parameters.items()}

    def resolve(self, params: Mapping[str, Any] | None = None) -> dict[str, Value]:
        """Defaults overridden by ``params``, each validated against the graph's datatype and range."""
        out = self.defaults()
        for name, value in (params or {}).items():
            out[name] = self.parameter(name).validate(value)
        return out

    def norm_for(self, params: Mapping[str, Value]) -> str:
        for rule in self.norm_rules:
            if params.get(rule.parameter) in rule.values:
                return rule.norm
        return self.norm

    def nf_parameter(self) -> str | None:
        """The number-of-features parameter (role NF), if the extractor has one."""
        return next((n for n, p in self.parameters.items() if p.role == "NF" and p.grid_role is None), None)

    def grid(self, full: Mapping[str, Value]) -> tuple[int, float] | None:
        """(cell size in px, oversampling factor) when the extractor declares a grid cell size
        (``nfex:gridRole``, ontology/grid.ttl), else None."""
        roles = {p.grid_role: n for n, p in self.parameters.items() if p.grid_role is not None}
        if "cellSize" not in roles:
            return None
        over = float(full[roles["oversample"]]) if "oversample" in roles else 1.0
        return int(full[roles["cellSize"]]), over

    def constructor_args(self, full: Mapping[str, Value]) -> dict[str, Value]:
        """The OpenCV constructor's arguments for the full parameter set ``full``: grid settings left out,
        and under a grid the NF parameter multiplied by the oversampling factor (clamped to its range)."""
        args = {k: v for k, v in full.items() if self.parameters[k].grid_role is None}
        grid = self.grid(full)
        nf = self.nf_parameter()
        if grid is not None and nf is not None and int(args[nf]) > 0:
            args[nf] = self.parameters[nf].clamp(float(args[nf]) * grid[1])
        return args

    def opencv(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """How a client builds this extractor with ``params`` (a Selection's ``opencv``): the constructor
        (a path under cv2), the matching norm, the constructor's ``args``, and ``grid`` — None, or the cell
        size and how many keypoints to keep (0: all) when the detected keypoints are to be spread over a
        grid before descriptors are computed (``nfex_slam.features.spread_over_grid``), the matcher and the
        descriptor kind: all a client needs to run the configuration exactly as the server does."""
        return self.opencv_of(self.resolve(params))

    def opencv_of(self, full: Mapping[str, Value]) -> dict[str, Any]:
        """``opencv`` for an already resolved (full, validated) parameter set."""
        grid = self.grid(full)
        nf = self.nf_parameter()
        return {
            "constructor": self.constructor,
            "norm": self.norm_for(full),
            "args": self.constructor_args(full),
            "grid": None if grid is None else {"cell_size": grid[0], "keep": int(full[nf]) if nf is not None else 0},
            "matcher": self.matcher,
            "descriptor_kind": self.descriptor_kind,
        }

    def recipe(self, full: Mapping[str, Value]) -> Recipe:
        """``opencv_of(full)`` as the SLAM front end runs it (nfex_slam.features.Recipe)."""
        return Recipe.from_selection(self.opencv_of(full))


@dataclass(frozen=True)
class ConditionValueSpec:
    iri: URIRef
    dimension: str
    name: str
    label: str = ""
    ordinal: int | None = None


@dataclass(frozen=True)
class DimensionSpec:
    iri: URIRef
    name: str
    label: str
    estimable: bool
    values: Mapping[str, ConditionValueSpec]

    def value(self, name: str) -> ConditionValueSpec:
        try:
            return self.values[name]
        except KeyError:
            raise UnknownName(f"value of {self.name}", name, self.values) from None


@dataclass(frozen=True)
class MetricSpec:
    iri: URIRef
    name: str
    symbol: str
    label: str
    temporal: bool
    higher_is_better: bool
    formula: str = ""
