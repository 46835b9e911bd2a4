"""A published rule table's per-context memo: first requests from threads answer as sequential ones and leave the
table's own fields unchanged."""
from __future__ import annotations

import copy
import pickle
import threading

from nfex_core.kg import KnowledgeGraph
from nfex_core.rules.engine import compile_table
from nfex_core.rules.memo import ContextMemo
from nfex_core.rules.table import RuleTable


def _contexts(table: RuleTable, n: int) -> list[dict[str, str | None]]:
    """``n`` distinct contexts of the table (each a key of its decisions)."""
    keys = list(table.decisions)[:: max(1, len(table.decisions) // n)][:n]
    return [dict(zip(table.dimensions, k, strict=True)) for k in keys]


def _answers(table: RuleTable, contexts: list[dict[str, str | None]]) -> list[tuple[object, object]]:
    return [(table.decide(c), table.measured(c)) for c in contexts]


def test_concurrent_first_requests_answer_as_sequential_ones_and_leave_the_table_unchanged(shipped_kg: KnowledgeGraph) -> None:
    table = compile_table(shipped_kg)
    contexts = _contexts(table, 48)
    published = copy.copy(table.decisions)
    observed = {x: dict(g) for x, g in table.observed.items()}
    configurations = {x: dict(c) for x, c in table.configurations.items()}

    sequential = copy.copy(table)  # the same published fields, a memo of its own
    sequential.memo = ContextMemo()
    expected = _answers(sequential, contexts)
    assert any(d.evidence for d, _ in expected) and any(m for _, m in expected)  # the memo had something to derive

    start = threading.Barrier(8)
    got: dict[int, list[tuple[object, object]]] = {}

    def ask(t: int) -> None:
        start.wait()
        mine = contexts[t::8] + contexts  # each thread's own contexts first, then every one (the others' too)
        got[t] = _answers(table, mine)

    threads = [threading.Thread(target=ask, args=(t,)) for t in range(8)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for t in range(8):
        mine = contexts[t::8] + contexts
        assert got[t] == [expected[contexts.index(c)] for c in mine]
    # the table a request reads is as published: no decision replaced by its evidence-filled copy
    assert table.decisions == published and all(table.decisions[k] is published[k] for k in published)
    assert {x: dict(g) for x, g in table.observed.items()} == observed
    assert {x: dict(c) for x, c in table.configurations.items()} == configurations
    # one value per context: every thread holds the very object published first
    for c, (d, m) in zip(contexts, _answers(table, contexts), strict=True):
        assert table.memo.decided[table.key(c)] is d and table.memo.measured[table.key(c)] is m


def test_the_first_published_value_wins_and_made_stays_bounded() -> None:
    memo = ContextMemo(max_made=3)
    first, second = object(), object()
    assert memo.publish(memo.decided, "k", first, {("k", i): (None, i) for i in range(5)}) is first
    assert memo.publish(memo.decided, "k", second, {}) is first
    assert len(memo.made) == 3 and len(memo) == 1


def test_a_pickled_memo_is_empty() -> None:
    memo = ContextMemo()
    memo.publish(memo.measured, "k", {}, {("k", "x"): (None, 1)})
    again = pickle.loads(pickle.dumps(memo))
    assert isinstance(again, ContextMemo) and len(again) == 0 and not again.made
