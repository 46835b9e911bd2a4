"""Parse nFEX programs (grammar ``rules/nfex.lark``) into AST dataclasses, and print them back.

A program is what the paper (§III-A, §IV-A) calls the symbolic program: statements that prune
candidate extractors, give parameter factors f_kj (θ′_k = θ_k·Π_j f_kj(e_j)), metric weights h_x(E)
and preference bonuses, each under a condition on the context E. The parser only checks syntax;
names are checked against the graph in ``check.py``. ``render`` prints the canonical text of a
program, and ``parse(render(p)) == p`` (positions are not compared).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import lark
from lark import Lark, Token, Transformer, v_args

from ...config import default_home
from ...errors import ParseError

# the language's own grammar, from the installed package (not NFEX_HOME, whose rules/ need not carry it)
GRAMMAR = default_home() / "rules" / "nfex.lark"
COMPARATORS = ("<=", "<", ">=", ">", "=")


@dataclass(frozen=True)
class Pos:
    line: int
    column: int


NOWHERE = Pos(0, 0)


def _at() -> Any:
    return field(default_factory=dict, compare=False, repr=False)


@dataclass(frozen=True)
class Atom:
    """``dimension is [not] value`` or ``dimension is [not] one of (a, b)``; values kept sorted."""

    dimension: str
    values: tuple[str, ...]
    negated: bool = False
    at: Mapping[str, Pos] = _at()  # "dimension", "value:<name>"

    def text(self) -> str:
        neg = "not " if self.negated else ""
        if len(self.values) == 1:
            return f"{self.dimension} is {neg}{self.values[0]}"
        return f"{self.dimension} is {neg}one of ({', '.join(self.values)})"


@dataclass(frozen=True)
class Test:
    """``signal comparator bound``: one test of an ``accept pair if …`` statement (verification/judge.py)."""

    signal: str
    comparator: str
    bound: float | int
    at: Mapping[str, Pos] = _at()  # "signal", "comparator", "bound"

    def text(self) -> str:
        return f"{self.signal} {self.comparator} {_num(self.bound)}"


@dataclass(frozen=True)
class Statement:
    """One statement. ``kind`` is prune | adjust | weight | prefer | require | accept | escalate."""

    kind: str
    when: tuple[Atom, ...] = ()
    reason: str | None = None
    extractor: str | None = None  # prune, prefer, adjust, require
    parameter: str | None = None  # adjust, require (OpenCV argument name)
    metric: str | None = None  # weight
    value: float | int | bool | None = None  # factor, weight, bonus or bound
    comparator: str | None = None  # require
    tests: tuple[Test, ...] = ()  # accept
    pos: Pos = field(default=NOWHERE, compare=False, repr=False)
    at: Mapping[str, Pos] = _at()  # "extractor", "parameter", "metric", "value"

    def head(self) -> str:
        """The statement without its condition and reason."""
        if self.kind == "prune":
            return f"prune {self.extractor}"
        if self.kind == "adjust":
            return f"adjust {self.extractor}.{self.parameter} by {_num(self.value)}"
        if self.kind == "weight":
            return f"weight {self.metric} {_num(self.value)}"
        if self.kind == "prefer":
            return f"prefer {self.extractor} by {_num(self.value)}"
        if self.kind == "accept":
            return "accept pair if " + " and ".join(t.text() for t in self.tests)
        if self.kind == "escalate":
            return f"escalate at most {_num(self.value)}"
        return f"require {self.extractor}.{self.parameter} {self.comparator} {_num(self.value)}"

    def label(self) -> str:
        """The canonical one-line text without the reason: what a selection cites."""
        cond = " and ".join(a.text() for a in self.when)
        return self.head() + (f" when {cond}" if cond else "")

    def text(self) -> str:
        out = self.label()
        if self.reason is not None:
            out += "\n    because " + quote(self.reason)
        return out


@dataclass(frozen=True)
class Program:
    name: str
    statements: tuple[Statement, ...] = ()
    source: str | None = field(default=None, compare=False)


def _num(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(v)


def quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\t", "\\t") + '"'


def unquote(token: str) -> str:
    out, i, body = [], 0, token[1:-1]
    while i < len(body):
        c = body[i]
        if c == "\\":
            i += 1
            c = {"n": "\n", "t": "\t"}.get(body[i], body[i])
        out.append(c)
        i += 1
    return "".join(out)


def render(program: Program) -> str:
    """The canonical program text (what ``nfex program show`` prints)."""
    return f"program {program.name}\n\n" + "".join(s.text() + "\n" for s in program.statements)


def _pos(tok: Token) -> Pos:
    return Pos(tok.line or 0, tok.column or 0)


@v_args(meta=True)
class _ToAst(Transformer):
    def start(self, meta: Any, items: list[Any]) -> tuple[str | None, tuple[Statement, ...]]:
        name = items[0] if items and isinstance(items[0], str) else None
        return name, tuple(i for i in items if isinstance(i, Statement))

    def header(self, meta: Any, items: list[Token]) -> str:
        return str(items[0])

    def qualified(self, meta: Any, items: list[Token]) -> tuple[Token, Token]:
        return items[0], items[1]

    def number(self, meta: Any, items: list[Token]) -> tuple[float | int, Pos]:
        text = str(items[0])
        value: float | int = int(text) if text.lstrip("+-").isdigit() else float(text)
        return value, _pos(items[0])

    def reason(self, meta: Any, items: list[Token]) -> str:
        return unquote(str(items[0]))

    def test(self, meta: Any, items: list[Any]) -> Test:
        name, cmp, (bound, bpos) = items
        return Test(str(name), str(cmp), bound, {"signal": _pos(name), "comparator": _pos(cmp), "bound": bpos})

    def single(self, meta: Any, items: list[Token]) -> list[Token]:
        return items

    def one_of(self, meta: Any, items: list[Token]) -> list[Token]:
        return items

    def atom(self, meta: Any, items: list[Any]) -> Atom:
        dim, values = items[0], items[-1]
        negated = len(items) == 3
        at = {"dimension": _pos(dim)} | {f"value:{v}": _pos(v) for v in values}
        return Atom(str(dim), tuple(sorted({str(v) for v in values})), negated, at)

    def condition(self, meta: Any, items: list[Atom]) -> tuple[Atom, ...]:
        return tuple(items)

    def _statement(self, kind: str, meta: Any, rest: list[Any], **fields: Any) -> Statement:
        when: tuple[Atom, ...] = ()
        reason = None
        for item in rest:
            if isinstance(item, tuple):
                when = item
            elif isinstance(item, str):
                reason = item
        at = {k: v for k, v in fields.pop("at").items()}
        return Statement(kind, when, reason, pos=Pos(meta.line, meta.column), at=at, **fields)

    def prune(self, meta: Any, items: list[Any]) -> Statement:
        x = items[0]
        return self._statement("prune", meta, items[1:], extractor=str(x), at={"extractor": _pos(x)})

    def adjust(self, meta: Any, items: list[Any]) -> Statement:
        (x, p), (v, vpos) = items[0], items[1]
        at = {"extractor": _pos(x), "parameter": _pos(p), "value": vpos}
        return self._statement("adjust", meta, items[2:], extractor=str(x), parameter=str(p), value=v, at=at)

    def weight(self, meta: Any, items: list[Any]) -> Statement:
        m, (v, vpos) = items[0], items[1]
        return self._statement("weight", meta, items[2:], metric=str(m), value=v, at={"metric": _pos(m), "value": vpos})

    def prefer(self, meta: Any, items: list[Any]) -> Statement:
        x, (v, vpos) = items[0], items[1]
        return self._statement("prefer", meta, items[2:], extractor=str(x), value=v, at={"extractor": _pos(x), "value": vpos})

    def accept(self, meta: Any, items: list[Any]) -> Statement:
        tests = tuple(i for i in items if isinstance(i, Test))
        rest = [i for i in items if not isinstance(i, Test)]
        return self._statement("accept", meta, rest, tests=tests, at={})

    def escalate(self, meta: Any, items: list[Any]) -> Statement:
        v, vpos = items[0]
        return self._statement("escalate", meta, items[1:], value=v, at={"value": vpos})

    def require(self, meta: Any, items: list[Any]) -> Statement:
        (x, p), cmp, bound = items[0], items[1], items[2]
        if isinstance(bound, Token):  # BOOL
            value: Any = str(bound) == "true"
            vpos = _pos(bound)
        else:
            value, vpos = bound
        at = {"extractor": _pos(x), "parameter": _pos(p), "value": vpos, "comparator": _pos(cmp)}
        return self._statement(
            "require", meta, items[3:], extractor=str(x), parameter=str(p), comparator=str(cmp), value=value, at=at
        )


@lru_cache(maxsize=1)
def parser() -> Lark:
    return Lark(GRAMMAR.read_text(), parser="lalr", propagate_positions=True, maybe_placeholders=False)


_READABLE = {
    "SIGNED_NUMBER": "a number",
    "BOOL": "true or false",
    "NAME": "a name",
    "STRING": 'a "quoted reason"',
    "COMPARATOR": "a comparator (<=, <, >=, >, =)",
    "$END": "the end of the program",
}


def _expected(names: set[str]) -> str:
    shown = []
    for name in sorted(names):
        if name in _READABLE:
            shown.append(_READABLE[name])
            continue
        try:
            pattern = parser().get_terminal(name).pattern
        except KeyError:
            shown.append(name)
            continue
        shown.append(repr(pattern.value) if pattern.type == "str" else name.lower())
    return ", ".join(sorted(set(shown)))


def parse(text: str, *, name: str | None = None, source: str | None = None) -> Program:
    """Parse a program; ``name`` is used when the text has no ``program NAME`` header.

    Raises ParseError with the line and column of the first syntax error.
    """
    where = f"{source}:" if source else ""
    try:
        tree = parser().parse(text)
    except lark.exceptions.UnexpectedInput as e:
        line, column = e.line, e.column
        if isinstance(e, lark.exceptions.UnexpectedToken):
            tok = e.token
            got = "the end of the program" if tok.type == "$END" else repr(str(tok))
            msg = f"unexpected {got}; expected {_expected(set(e.accepts or e.expected))}"
            if tok.type == "$END":
                line, column = text.count("\n") + 1, len(text.rsplit("\n", 1)[-1]) + 1
        elif isinstance(e, lark.exceptions.UnexpectedCharacters):
            char = text[e.pos_in_stream or 0]
            msg = "unterminated string (a reason ends with \" on the same line)" if char == '"' else f"unexpected character {char!r}"
            if e.allowed:
                msg += f"; expected {_expected(set(e.allowed))}"
        else:
            msg = "unexpected end of the program"
        extra = {"source": source} if source else {}
        raise ParseError(f"{where}{line}:{column}: {msg}", line=line, column=column, **extra) from None
    header, statements = _ToAst().transform(tree)
    final = header or name
    if not final:
        raise ParseError(f"{where}1:1: the program has no name: start it with 'program NAME'", line=1, column=1)
    return Program(final, statements, source)


def parse_file(path: Path, *, source: str | None = None) -> Program:
    """Parse a ``.nfex`` file; its name is the file's stem unless the text says ``program NAME``."""
    return parse(path.read_text(), name=path.stem.replace("-", "_"), source=source or str(path))
