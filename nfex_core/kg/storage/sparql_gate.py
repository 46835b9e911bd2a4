"""The gate every client's SPARQL passes before any store sees it: bounded, parsed, then judged on its parse.

Three steps, each a 4xx problem when it fails, so that nothing refused ever reaches a store (embedded or
remote):

1. **Length.** A text over ``MAX_CHARS`` characters is refused (413 ``sparql-too-large``).
2. **Parse.** The text is parsed by tree-sitter's SPARQL 1.1 grammar (``tree-sitter-sparql``), a real parser
   in C with an explicit stack: escapes in strings, IRIs and local names (§19.8 ``PN_LOCAL_ESC``), comments and
   prefixed names are read as the grammar reads them, and no nesting can overflow it. The grammar has no
   code-point escapes (``\\uXXXX``, §19.2): a text that uses one is refused, whatever Oxigraph would make of it.
   A text with a syntax error anywhere is refused (400
   ``parse-error`` with line and column): the gate lets through only what it has understood whole.
3. **Judge the parse.** Operations that reach outside the graph or wipe it — ``SERVICE`` (the store fetches
   a URL), ``LOAD`` (fetches and writes), ``CLEAR``, ``DROP``, ``CREATE``, ``ADD``, ``MOVE``, ``COPY`` (named
   graphs hold the version history) — are refused (403 ``forbidden-operation``) wherever the parse holds them,
   however they were spelt. The depth of the tree an evaluator builds is bounded by ``MAX_DEPTH`` (400
   ``sparql-too-complex``): Oxigraph recurses over nested groups and parentheses and over the left-deep chains
   it makes of joins, ``UNION``, ``OPTIONAL``, ``+``, ``||`` and path steps, and overflows its stack (a crash
   of the whole process, or of ``oxigraph serve``) at a few thousand levels. Flat lists (triples, ``VALUES``
   rows, ``INSERT DATA``'s quads, the prologue, an update's operations) count once.

``tests/nfex_core/kg/storage/test_sparql_gate.py`` generates spellings (escapes, comments, case, prefixed names) and
checks that the gate and Oxigraph agree on whether a text holds a forbidden operation; the hostile-input suite
(``tests/service/test_hostile.py``) sends the bounds' worst shapes to a real ``oxigraph serve``.
"""
from __future__ import annotations

import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from rdflib.namespace import SH
from rdflib.term import Literal

from ...errors import BadInput, ParseError
from ..rdf.namespaces import NFEX

MAX_CHARS = 200_000
MAX_DEPTH = 400
# tree-sitter-sparql node types of the operations nFEX never runs for a client
FORBIDDEN = {
    "service_graph_pattern": "SERVICE",
    "load": "LOAD",
    "clear": "CLEAR",
    "drop": "DROP",
    "create": "CREATE",
    "add": "ADD",
    "move": "MOVE",
    "copy": "COPY",
}
FORMS = {"select_query": "select", "ask_query": "ask", "construct_query": "construct", "describe_query": "describe"}
UPDATES = {"insert_data", "delete_data", "delete_where", "modify", *FORBIDDEN} - {"service_graph_pattern"}
# nodes whose children an evaluator keeps side by side; any other node's n children become a chain n deep
_FLAT = {"unit", "prologue", "select_clause", "triples_block", "triples_template", "triples_same_subject",
         "construct_triples", "construct_template", "property_list", "object_list", "quads", "quads_not_triples",
         "collection", "blank_node_property_list", "inline_data", "data_block", "values_clause", "group_clause",
         "order_clause", "solution_modifier", "limit_offset_clauses", "arg_list", "expression_list", "rdf_literal",
         "prefixed_name", "prefix_declaration", "string", "dataset_clause", "using_clause"}
# predicates whose literal is SPARQL that nFEX or pySHACL evaluates: pruning rules, SHACL-SPARQL constraints
EXECUTED_QUERIES = (NFEX.query, SH.select, SH.ask, SH.construct)
EXECUTED_UPDATES = (SH.update,)


class ForbiddenOperation(BadInput):
    """The SPARQL text contains an operation nFEX never runs for a client."""

    status = 403
    type = "forbidden-operation"
    title = "Forbidden SPARQL operation"


class TooComplex(BadInput):
    type = "sparql-too-complex"
    title = "SPARQL text too complex"


class TooLarge(BadInput):
    status = 413
    type = "sparql-too-large"
    title = "SPARQL text too large"


@dataclass(frozen=True)
class Gated:
    """What the gate learnt of a text it let through."""

    form: str  # select | ask | construct | describe | update
    depth: int


def gate_query(text: str) -> Gated:
    """Let ``text`` through as a read-only query, or raise (see the module docstring)."""
    return _gate(text, update=False)


def gate_update(text: str) -> Gated:
    """Let ``text`` through as a SPARQL 1.1 Update, or raise (see the module docstring)."""
    return _gate(text, update=True)


def _gate(text: str, *, update: bool) -> Gated:
    if not text.strip():
        raise BadInput(f"the {'update' if update else 'query'} is empty")
    if len(text) > MAX_CHARS:
        raise TooLarge(f"the SPARQL text has {len(text)} characters; the limit is {MAX_CHARS}", limit=MAX_CHARS)
    # the verdict is kept per text, a refusal as a fresh exception each time: re-raising one cached object would
    # chain every raise's frames (and the locals they hold) onto its traceback
    gated, error = _judged(text, update) if len(text) <= CACHED_CHARS else _judged.__wrapped__(text, update)
    if error is not None:
        raise type(error)(error.detail, **error.extra) from None
    assert gated is not None
    return gated


@lru_cache(maxsize=1)
def _parser() -> Any:
    import tree_sitter_sparql
    from tree_sitter import Language, Parser

    with warnings.catch_warnings():  # the grammar's wheel hands its language over as an int pointer
        warnings.simplefilter("ignore", DeprecationWarning)
        return Parser(Language(tree_sitter_sparql.language()))


# texts up to this long are judged once (the rules' texts, a workbench's repeated queries); longer ones each time, so
# the cache holds at most 1024 × 8,000 characters whatever an anonymous client sends
CACHED_CHARS = 8_000


@lru_cache(maxsize=1024)
def _judged(text: str, update: bool) -> tuple[Gated | None, BadInput | None]:
    """The verdict on ``text``, kept per text: the endpoint and the rule engine see the same texts again."""
    try:
        source = text.encode("utf-8")
    except UnicodeEncodeError:
        return None, BadInput("the SPARQL text holds a lone surrogate (U+D800–U+DFFF), which is no character")
    root = _parser().parse(source).root_node
    if root.has_error:
        return None, _syntax_error(root, source, update)
    ops = [child.type for child in root.named_children if child.type not in ("prologue", "comment")]
    forms = [FORMS[t] for t in ops if t in FORMS]
    if update and forms:
        return None, BadInput("this is a SPARQL query, not an update; send it to the query endpoint")
    if not update and any(t in UPDATES for t in ops):
        return None, BadInput("this is a SPARQL Update; queries are read-only here (use `nfex kg update` or POST /sparql/update)")
    if not update and len(forms) != 1:
        return None, BadInput("not a SPARQL query: expected one SELECT, ASK, CONSTRUCT or DESCRIBE after the prologue")
    found, depth = _walk(root)
    if found:
        return None, _refusal(found, update)
    if depth > MAX_DEPTH:
        return None, TooComplex(
            f"the SPARQL text builds a pattern or expression tree {depth} deep; the limit is {MAX_DEPTH} "
            "(deep nesting, or long chains of joins, UNION, OPTIONAL, operators or path steps: split the query)",
            depth=depth, limit=MAX_DEPTH,
        )
    return Gated("update" if update else forms[0], depth), None


def _syntax_error(root: Any, source: bytes, update: bool) -> ParseError:
    """The first ERROR or MISSING node, as a line and column in the text."""
    stack = [root]
    where = root
    while stack:
        node = stack.pop()
        if node.type == "ERROR" or node.is_missing:
            where = node
            break
        stack.extend(reversed([c for c in node.children if c.has_error or c.is_missing or c.type == "ERROR"]))
    line, byte = where.start_point
    column = len(source.split(b"\n")[line][:byte].decode("utf-8", "replace")) + 1
    found = source[where.start_byte : where.start_byte + 20].decode("utf-8", "replace")
    what = f"expected {where.type}" if where.is_missing else f"unexpected {found!r}" if found else "unexpected end"
    return ParseError(f"invalid SPARQL {'update' if update else 'query'}: {what} (at {line + 1}:{column})",
                      line=line + 1, column=column)


def _walk(root: Any) -> tuple[list[str], int]:
    """The forbidden operations in the tree, and the depth an evaluator builds from it: one per level, and a
    node's n children chained n deep unless the node keeps them flat (``_FLAT``). Iterative: a tree-sitter
    tree can be as deep as the text is long."""
    found: list[str] = []
    depth: dict[int, int] = {}
    stack: list[tuple[Any, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        if not done:
            op = FORBIDDEN.get(node.type)
            if op is not None and op not in found:
                found.append(op)
            stack.append((node, True))
            stack.extend((c, False) for c in node.named_children)
            continue
        children = node.named_children
        deepest = max((depth.pop(c.id, 0) for c in children), default=0)
        chain = 0 if node.type in _FLAT else max(0, len(children) - 1)
        depth[node.id] = 1 + deepest + chain
    order = list(FORBIDDEN.values())
    return sorted(found, key=order.index), depth[root.id]


def _refusal(found: list[str], update: bool) -> ForbiddenOperation:
    if found == ["SERVICE"] and not update:
        return ForbiddenOperation(
            "SPARQL queries may not use SERVICE: nFEX never fetches URLs for a client (federated queries are off)",
            operations=found,
        )
    return ForbiddenOperation(
        f"SPARQL may not use {', '.join(found)}: nFEX never fetches URLs for a client (LOAD, SERVICE) "
        "nor clears, drops, creates, adds, moves or copies graphs (the named graphs hold the version history); "
        "use INSERT/DELETE DATA or DELETE/INSERT … WHERE on the default graph",
        operations=found,
    )


def gate_change(added: Iterable[tuple[Any, Any, Any]]) -> None:
    """Refuse a write whose ``added`` triples store SPARQL text nFEX would later run (a rule's ``nfex:query``, a
    SHACL constraint's ``sh:select``/``sh:ask``/``sh:update``) that the gate would not let through."""
    for _, p, o in added:
        if isinstance(o, Literal) and (p in EXECUTED_QUERIES or p in EXECUTED_UPDATES):
            try:
                (gate_update if p in EXECUTED_UPDATES else gate_query)(str(o))
            except BadInput as e:
                raise type(e)(f"the change stores SPARQL ({p}) that nFEX would not run: {e.detail}", **e.extra) from None
